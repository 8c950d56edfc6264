#include "dataset/draw.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "batch/journal.h"
#include "scene_layouts/seeded_uniform.h"

namespace odyssey::dataset {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

std::uint64_t splitmix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// The seed of sequence `index`: every number it draws comes from SeededUniform(this, stream).
std::uint64_t sequence_seed(const Recipe& recipe, long index) {
  return splitmix(splitmix(recipe.seed) ^ static_cast<std::uint64_t>(index));
}
// Streams: the split, then one per attempt.
constexpr std::uint64_t kSplitStream = 1, kFirstAttemptStream = 100;

// Numbers drawn for one attempt.
class Draws {
 public:
  Draws(std::uint64_t seed, std::uint64_t stream) : uniform_(seed, stream) {}
  double unit() { return uniform_.next(); }
  double in(const Range& range) { return range.low == range.high ? range.low : uniform_.between(range.low, range.high); }
  double between(double low, double high) { return uniform_.between(low, high); }
  // A whole number in [low, high] of the range.
  int count(const Range& range) {
    const int low = static_cast<int>(range.low), high = static_cast<int>(range.high);
    return low + std::min(high - low, static_cast<int>(uniform_.next() * (high - low + 1)));
  }
  std::size_t index(std::size_t size) { return std::min(size - 1, static_cast<std::size_t>(uniform_.next() * static_cast<double>(size))); }
  bool chance(double share) { return uniform_.next() < share; }
  const std::string& pick(const Shares& shares) {
    double total = 0;
    for (const auto& share : shares) total += share.second;
    double u = uniform_.next() * total;
    for (const auto& share : shares) {
      if (u < share.second) return share.first;
      u -= share.second;
    }
    return shares.back().first;
  }

 private:
  scene::SeededUniform uniform_;
};

double rounded(double value, double step = 1e-3) { return std::round(value / step) * step; }

Json region_json(const Eigen::Vector4d& region) {
  return Json::array({rounded(region[0]), rounded(region[1]), rounded(region[2]), rounded(region[3])});
}

// A name safe for the scene (no slash): the asset's file stem.
std::string stem_of(const std::string& path) {
  std::string stem = fs::path(path).stem().string();
  for (char& c : stem) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') c = '_';
  }
  return stem.empty() ? "prop" : stem;
}

}  // namespace

std::string sequence_name(const Recipe& recipe, long index) {
  char digits[32];
  std::snprintf(digits, sizeof digits, "%05ld", index);
  return recipe.name + "_" + digits;
}

std::string split_of(const Recipe& recipe, long index) {
  Draws draws(sequence_seed(recipe, index), kSplitStream);
  return draws.pick(recipe.splits);
}

std::vector<std::size_t> assets_of_split(const Recipe& recipe, const std::string& kind, const std::string& split) {
  const auto names = [&]() {
    std::vector<std::string> out;
    if (kind == "motion") {
      for (const auto& asset : recipe.motions) out.push_back(asset.name + "\n" + asset.path);
    } else if (kind == "character") {
      for (const auto& asset : recipe.characters) out.push_back(asset.name + "\n" + asset.path);
    } else {
      for (const auto& asset : recipe.animals) out.push_back(asset.name + "\n" + asset.path);
    }
    return out;
  }();
  std::vector<std::size_t> all(names.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  const bool dealt = recipe.splits.size() > 1 &&
                     ((recipe.split_by == "motion" && kind == "motion") ||
                      (recipe.split_by == "character" && (kind == "character" || kind == "animal")));
  if (!dealt) return all;
  // Order by a hash of (seed, name), then deal contiguous runs by the fractions: largest
  // remainders round, and every split gets at least one (taken from the largest).
  std::sort(all.begin(), all.end(), [&](std::size_t a, std::size_t b) {
    const std::string ha = batch::hash_text(std::to_string(recipe.seed) + "\n" + names[a]);
    const std::string hb = batch::hash_text(std::to_string(recipe.seed) + "\n" + names[b]);
    return ha != hb ? ha < hb : names[a] < names[b];
  });
  const std::size_t m = all.size(), parts = recipe.splits.size();
  std::vector<std::size_t> counts(parts);
  std::vector<std::pair<double, std::size_t>> remainders;
  std::size_t given = 0;
  for (std::size_t s = 0; s < parts; ++s) {
    const double exact = recipe.splits[s].second * static_cast<double>(m);
    counts[s] = static_cast<std::size_t>(std::floor(exact));
    given += counts[s];
    remainders.push_back({-(exact - std::floor(exact)), s});
  }
  std::sort(remainders.begin(), remainders.end());
  for (std::size_t k = 0; given < m; ++k, ++given) ++counts[remainders[k % parts].second];
  for (std::size_t s = 0; s < parts; ++s) {
    while (counts[s] == 0) {
      const std::size_t largest = static_cast<std::size_t>(std::max_element(counts.begin(), counts.end()) - counts.begin());
      if (counts[largest] < 2) throw std::invalid_argument("too few " + kind + "s to split");
      --counts[largest];
      ++counts[s];
    }
  }
  std::size_t first = 0;
  for (std::size_t s = 0; s < parts; ++s) {
    if (recipe.splits[s].first == split) {
      std::vector<std::size_t> mine(all.begin() + static_cast<long>(first), all.begin() + static_cast<long>(first + counts[s]));
      std::sort(mine.begin(), mine.end());
      return mine;
    }
    first += counts[s];
  }
  return {};
}

DrawnShot draw_shot(const Recipe& recipe, long index, int attempt, const AssetFacts& facts) {
  DrawnShot shot;
  shot.name = sequence_name(recipe, index);
  shot.split = split_of(recipe, index);
  Draws draws(sequence_seed(recipe, index), kFirstAttemptStream + static_cast<std::uint64_t>(attempt));
  shot.seed = static_cast<std::uint64_t>(draws.unit() * 2147483647.0);
  const auto use = [&](const char* kind, const Asset& asset) {
    const bool known = std::any_of(shot.assets.begin(), shot.assets.end(), [&](const UsedAsset& a) { return a.path == asset.path; });
    if (!known) shot.assets.push_back({kind, asset.path, asset.licence, asset.file});
  };

  Json& scene = shot.scene;
  scene["version"] = 1;
  scene["name"] = shot.name;
  scene["description"] = "Drawn by odyssey dataset from " + fs::path(recipe.file).filename().string() + ": sequence " +
                         std::to_string(index) + ", attempt " + std::to_string(attempt) + ", split " + shot.split + ".";
  scene["fps"] = recipe.fps;
  const double seconds = rounded(draws.in(recipe.seconds), 1.0 / recipe.fps);
  scene["seconds"] = seconds;
  scene["seed"] = shot.seed;

  // Where: a layout's room or a ground; the actors together or spread.
  const bool in_layout = !recipe.layouts.empty() && draws.chance(recipe.layout_share);
  Eigen::Vector4d floor_region = recipe.field;
  Json props = Json::array();
  if (in_layout) {
    const LayoutAsset& layout = recipe.layouts[draws.index(recipe.layouts.size())];
    use("layout", layout);
    props = layout.props;
    floor_region = layout.region;
  } else {
    props.push_back({{"name", "ground"}, {"type", "ground"}, {"size", {recipe.ground_size, recipe.ground_size}}});
  }
  const std::string arrangement = draws.pick(recipe.arrangement);
  Eigen::Vector4d actor_region = floor_region;
  if (arrangement == "together") {
    const double radius = draws.in(recipe.together_radius);
    const double cx = draws.between(floor_region[0] + radius, floor_region[2] - radius);
    const double cy = draws.between(floor_region[1] + radius, floor_region[3] - radius);
    if (floor_region[2] - floor_region[0] > 2 * radius && floor_region[3] - floor_region[1] > 2 * radius) {
      actor_region = Eigen::Vector4d(cx - radius, cy - radius, cx + radius, cy + radius);
    }
  }

  // Who.
  std::vector<std::size_t> characters, motions, animals;
  if (recipe.split_by == "character") {
    characters = assets_of_split(recipe, "character", shot.split);
    if (!recipe.animals.empty()) animals = assets_of_split(recipe, "animal", shot.split);
    motions = assets_of_split(recipe, "motion", "");
  } else {
    characters = assets_of_split(recipe, "character", "");
    animals = assets_of_split(recipe, "animal", "");
    motions = assets_of_split(recipe, "motion", shot.split);
  }
  int people = recipe.characters.empty() ? 0 : draws.count(recipe.actors);
  int animal_count = recipe.animals.empty() ? 0 : draws.count(recipe.animal_count);
  if (people + animal_count == 0) (recipe.characters.empty() ? animal_count : people) = 1;
  Json actors = Json::array();
  std::vector<std::string> people_names;
  for (int k = 0; k < people; ++k) {
    const CharacterAsset& character = recipe.characters[characters[draws.index(characters.size())]];
    const MotionAsset& motion = recipe.motions[motions[draws.index(motions.size())]];
    use("character", character);
    use("motion", motion);
    Json actor;
    actor["name"] = "person" + std::to_string(k);
    actor["motion"] = motion.path;
    const bool bvh = fs::path(motion.file).extension() == ".bvh" || fs::path(motion.file).extension() == ".BVH";
    if (bvh && motion.bvh_units != "auto") actor["bvh_units"] = motion.bvh_units;
    if (!bvh && motion.model) actor["model"] = *motion.model;
    actor["character"] = character.path;
    if (character.map) actor["map"] = fs::absolute(*character.map).lexically_normal().string();
    actor["quality"] = draws.pick(recipe.quality);
    const double speed = rounded(draws.in(recipe.speed), 1e-3);
    // The clip's start, drawn so that the shot's seconds of clip (at this speed) fit where they can.
    const double clip_seconds = facts.motion_seconds(motion);
    const double needed = seconds * speed;
    const double latest_start = std::max(0.0, clip_seconds - needed);
    const double trim_start = std::floor(draws.between(0, latest_start) * 1000) / 1000;
    if (trim_start > 0 && clip_seconds > trim_start) actor["trim"] = {trim_start, clip_seconds};
    actor["speed"] = speed;
    actor["placement"] = {{"region", region_json(actor_region)}};
    people_names.push_back(actor["name"]);
    actors.push_back(std::move(actor));
  }
  for (int k = 0; k < animal_count; ++k) {
    const AnimalAsset& animal = recipe.animals[animals[draws.index(animals.size())]];
    use("animal", animal);
    Json actor;
    actor["name"] = "animal" + std::to_string(k);
    if (animal.anime) {
      actor["anime"] = animal.path;
      actor["source_fps"] = animal.source_fps;
      actor["up"] = animal.up;
    } else {
      actor["character"] = animal.path;
      actor["animation"] = animal.animations[draws.index(animal.animations.size())];
    }
    actor["seconds"] = seconds;
    if (animal.scale != 1) actor["scale"] = animal.scale;
    actor["placement"] = {{"region", region_json(actor_region)}};
    actors.push_back(std::move(actor));
  }
  scene["actors"] = std::move(actors);

  // Props scattered about the actors (and kicked).
  const int scattered = draws.count(recipe.scatter);
  bool dynamic_props = false;
  if (scattered > 0) {
    Json templates = Json::array();
    for (int k = 0; k < scattered; ++k) {
      Json prop;
      if (recipe.props.empty() || draws.chance(recipe.box_share)) {
        prop = {{"name", "box"},
                {"type", "box"},
                {"size", {rounded(draws.between(0.15, 0.5)), rounded(draws.between(0.15, 0.5)), rounded(draws.between(0.1, 0.4))}}};
      } else {
        const PropAsset& asset = recipe.props[draws.index(recipe.props.size())];
        use("prop", asset);
        prop = {{"name", stem_of(asset.path)}, {"type", "mesh"}, {"path", asset.path}, {"scale", rounded(draws.between(asset.scale_low, asset.scale_high))}};
        if (asset.up_z) prop["up"] = "z";
      }
      if (draws.chance(recipe.dynamic_share)) {
        prop["dynamic"] = true;
        prop["mass"] = rounded(draws.between(1, 5), 0.01);
        dynamic_props = true;
      }
      prop["name"] = prop["name"].get<std::string>() + std::to_string(k);
      templates.push_back(std::move(prop));
    }
    const Eigen::Vector4d grown(actor_region[0] - 2, actor_region[1] - 2, actor_region[2] + 2, actor_region[3] + 2);
    const Eigen::Vector4d region(std::max(grown[0], floor_region[0]), std::max(grown[1], floor_region[1]),
                                 std::min(grown[2], floor_region[2]), std::min(grown[3], floor_region[3]));
    scene["scatter"] = {{"count", scattered},
                        {"on_paths", static_cast<int>(std::lround(recipe.on_paths_share * scattered))},
                        {"region", region_json(region)},
                        {"props", std::move(templates)}};
  }
  scene["props"] = std::move(props);
  const double rate = rounded(draws.in(recipe.force_rate), 1e-3);
  if (dynamic_props && rate > 0) scene["forces"] = {{"rate", rate}};

  // Cameras.
  Shares kinds;
  for (const auto& [kind, share] : recipe.camera_kinds) {
    // An ego camera rides on a person and must have someone else to see.
    if (kind == "ego" && (people == 0 || people + animal_count < 2)) continue;
    kinds.emplace_back(kind, share);
  }
  if (kinds.empty()) throw std::invalid_argument("cameras.kinds: only ego cameras are allowed, and this shot has no one for them to see");
  const int camera_count = draws.count(recipe.cameras);
  Json cameras = Json::array();
  std::map<std::string, int> used_names;
  for (int k = 0; k < camera_count; ++k) {
    const std::string kind = draws.pick(kinds);
    Json camera;
    camera["name"] = kind + std::to_string(used_names[kind]++);
    int rides = -1;
    const bool track = kind == "track";
    if (kind == "static") {
      camera["type"] = "static";
      camera["jitter"] = rounded(draws.between(0, 0.5));
    } else if (kind == "orbit") {
      camera["type"] = "orbit";
      camera["start_angle"] = rounded(draws.between(0, 360), 0.1);
      camera["period"] = rounded(draws.between(8, 30), 0.1) * (draws.chance(0.5) ? 1 : -1);
      camera["height_m"] = rounded(draws.between(1.0, 3.0));
    } else if (kind == "swoop") {
      camera["type"] = "swoop";
      camera["start_angle"] = rounded(draws.between(0, 360), 0.1);
      camera["sweep"] = rounded(draws.between(30, 120), 0.1) * (draws.chance(0.5) ? 1 : -1);
    } else if (kind == "zoom") {
      camera["type"] = "zoom";
    } else if (kind == "dolly_zoom") {
      camera["type"] = "dolly-zoom";
    } else if (kind == "ego") {
      camera["type"] = "ego";
      rides = static_cast<int>(draws.index(static_cast<std::size_t>(people)));
      camera["actor"] = people_names[static_cast<std::size_t>(rides)];
    } else {
      const TrackAsset& asset = recipe.camera_tracks[draws.index(recipe.camera_tracks.size())];
      use("camera_track", asset);
      camera["type"] = asset.colmap ? "colmap" : "realestate10k";
      camera["path"] = asset.path;
      camera["extent"] = rounded(draws.between(6, 16), 0.1);
      camera["height_m"] = rounded(draws.between(1.2, 2.5));
      camera["start_angle"] = rounded(draws.between(0, 360), 0.1);
      camera["aim"] = 1;
    }
    camera["width"] = recipe.width;
    camera["height"] = recipe.height;
    if (!track) {
      const double hfov = rounded(draws.in(recipe.hfov), 0.1);
      camera["hfov"] = hfov;
      if (kind == "zoom") camera["hfov_end"] = rounded(hfov * draws.between(0.4, 0.8), 0.1);
    }
    if (kind != "ego" && draws.chance(recipe.handheld_share)) {
      camera["handheld"] = {{"amplitude", rounded(draws.between(0.005, 0.03), 1e-4)},
                            {"rotation", rounded(draws.between(0.1, 0.6), 1e-3)},
                            {"band", {0.5, 2}}};
    }
    shot.ego_actors.push_back(rides);
    cameras.push_back(std::move(camera));
  }
  scene["cameras"] = std::move(cameras);

  scene["outputs"] = {{"layout", "pointodyssey"},
                      {"trajectories", true},
                      {"camera_paths", false},
                      {"report", true},
                      {"previews", recipe.previews},
                      {"depth", recipe.depth},
                      {"normals", recipe.normals},
                      {"masks", recipe.masks},
                      {"exact_maps", recipe.exact},
                      {"points_per_actor", recipe.points_per_actor},
                      {"prop_points", recipe.prop_points}};
  return shot;
}

}  // namespace odyssey::dataset
