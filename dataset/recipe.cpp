#include "dataset/recipe.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include "batch/job.h"
#include "mocap_io/input_error.h"
#include "mocap_io/json_reader.h"
#include "mocap_io/motion_file.h"
#include "scene_layouts/scene_file.h"

namespace odyssey::dataset {
namespace {

namespace fs = std::filesystem;
using io::JsonValue;

// Asset library entry: a path as the recipe gives it, resolved against the recipe's folder or the
// bundled data folder, and the files it names.
struct EntryPath {
  std::string disk;         // on disk
  std::string data_prefix;  // "data:" entries: the bundled folder, to turn found files back into data: paths
};

EntryPath entry_path(const JsonValue& value, const fs::path& base) {
  const std::string text = value.string();
  if (text.empty()) value.fail("an empty path");
  if (text.starts_with("data:")) {
    const std::string folder = fs::path(scene::bundled_data_folder()).lexically_normal().string();
    return {(fs::path(folder) / text.substr(5)).lexically_normal().string(), folder};
  }
  const fs::path path(text);
  return {(path.is_absolute() ? path : base / path).lexically_normal().string(), ""};
}

// The path a scene file names the asset by: data: for the bundled folder, else absolute.
std::string portable_path(const std::string& file, const EntryPath& entry) {
  if (!entry.data_prefix.empty()) {
    const fs::path relative = fs::path(file).lexically_relative(entry.data_prefix);
    if (!relative.empty() && *relative.begin() != "..") return "data:" + relative.generic_string();
  }
  return fs::absolute(file).lexically_normal().string();
}

// Whether a credits table's first cell names `relative`: the path itself, perhaps followed by " (+
// ...)", a list "a/x.txt, y.txt" (later names in a's folder), or a brace list "a/{x,y}.txt".
bool names_file(const std::string& cell, const std::string& relative) {
  std::string named = cell.substr(0, cell.find(" ("));
  std::erase(named, '`');
  std::vector<std::string> names;
  const std::size_t open = named.find('{'), close = named.find('}');
  if (open != std::string::npos && close != std::string::npos && close > open) {
    const std::string prefix = named.substr(0, open), suffix = named.substr(close + 1), list = named.substr(open + 1, close - open - 1);
    for (std::size_t start = 0, comma; start <= list.size(); start = comma + 1) {
      comma = list.find(',', start);
      if (comma == std::string::npos) comma = list.size();
      names.push_back(prefix + list.substr(start, comma - start) + suffix);
    }
  } else {
    std::string folder;
    for (std::size_t start = 0, comma; start <= named.size(); start = comma + 1) {
      comma = named.find(',', start);
      if (comma == std::string::npos) comma = named.size();
      std::string name = named.substr(start, comma - start);
      name.erase(0, name.find_first_not_of(' '));
      if (name.find('/') == std::string::npos) name = folder + name;
      folder = name.substr(0, name.rfind('/') + 1);
      names.push_back(name);
    }
  }
  return std::find(names.begin(), names.end(), relative) != names.end();
}

// The licence column of the CREDITS.md row naming `file`, looked for in the file's folder and
// the folders above it (at most 6 levels).
std::string credited_licence(const std::string& file) {
  fs::path folder = fs::absolute(file).parent_path();
  for (int level = 0; level < 6 && !folder.empty(); ++level, folder = folder.parent_path()) {
    const fs::path credits = folder / "CREDITS.md";
    std::error_code error;
    if (fs::is_regular_file(credits, error) && fs::file_size(credits, error) < (1u << 20)) {
      const std::string relative = fs::absolute(file).lexically_relative(folder).generic_string();
      std::ifstream in(credits);
      for (std::string line; std::getline(in, line);) {
        if (!line.starts_with("|")) continue;
        // Cells between '|'; the first names the file (perhaps followed by " (+ ...)"), the last the licence.
        std::vector<std::string> cells;
        std::size_t start = 1;
        for (std::size_t bar; (bar = line.find('|', start)) != std::string::npos; start = bar + 1) {
          std::string cell = line.substr(start, bar - start);
          const std::size_t first = cell.find_first_not_of(' '), last = cell.find_last_not_of(' ');
          cells.push_back(first == std::string::npos ? "" : cell.substr(first, last - first + 1));
        }
        if (cells.size() < 2) continue;
        if (names_file(cells.front(), relative)) return cells.back();
      }
    }
    if (folder == folder.root_path()) break;
  }
  return "unknown";
}

Range read_range(const JsonValue& value, double low, double high) {
  if (value.is_number()) {
    const double x = value.number_in(low, high);
    return {x, x};
  }
  if (!value.is_array() || value.size() != 2) value.fail("expected a number or [min, max]");
  const Range range{value[0].number_in(low, high), value[1].number_in(low, high)};
  if (range.low > range.high) value.fail("min is above max");
  return range;
}

Range read_count_range(const JsonValue& value, long long low, long long high) {
  if (value.is_number()) {
    const double x = static_cast<double>(value.integer(low, high));
    return {x, x};
  }
  if (!value.is_array() || value.size() != 2) value.fail("expected a whole number or [min, max]");
  const Range range{static_cast<double>(value[0].integer(low, high)), static_cast<double>(value[1].integer(low, high))};
  if (range.low > range.high) value.fail("min is above max");
  return range;
}

Shares read_shares(const JsonValue& value, const std::vector<std::string>& names) {
  if (!value.is_object()) value.fail("expected an object of shares, {name: weight}");
  Shares shares;
  double total = 0;
  for (const auto& [key, item] : value.raw().items()) {
    if (std::find(names.begin(), names.end(), key) == names.end()) {
      std::string allowed;
      for (const std::string& name : names) allowed += (allowed.empty() ? "" : ", ") + name;
      value.fail("unknown key '" + key + "' (expected " + allowed + ")");
    }
    const double weight = value.member(key).number_in(0, 1e9);
    if (weight > 0) shares.emplace_back(key, weight);
    total += weight;
  }
  if (!(total > 0)) value.fail("no share above 0");
  // In the order of `names`, whatever the file's order.
  std::sort(shares.begin(), shares.end(), [&](const auto& a, const auto& b) {
    return std::find(names.begin(), names.end(), a.first) < std::find(names.begin(), names.end(), b.first);
  });
  return shares;
}

Eigen::Vector4d read_region(const JsonValue& value) {
  if (!value.is_array() || value.size() != 4) value.fail("expected [x0, y0, x1, y1]");
  const Eigen::Vector4d region(value[0].number_in(-1e5, 1e5), value[1].number_in(-1e5, 1e5), value[2].number_in(-1e5, 1e5),
                               value[3].number_in(-1e5, 1e5));
  if (!(region[2] > region[0] && region[3] > region[1])) value.fail("x1 must exceed x0 and y1 exceed y0");
  return region;
}

// Each entry of library `key`: a path string, or an object with "path" and the kind's keys. For
// each file found, `make` builds the asset from the entry (null for a string entry).
template <class AssetT>
std::vector<AssetT> read_library(const std::optional<JsonValue>& list, const fs::path& base, const std::vector<std::string>& extensions,
                                 const std::string& what, std::initializer_list<std::string_view> keys,
                                 const std::function<void(AssetT&, const std::optional<JsonValue>&)>& make) {
  std::vector<AssetT> assets;
  if (!list) return assets;
  if (!list->is_array()) list->fail("expected a list of paths (files, folders or globs) or {\"path\": ...} entries");
  std::set<std::string> seen;
  for (std::size_t i = 0; i < list->size(); ++i) {
    const JsonValue entry = (*list)[i];
    std::optional<JsonValue> object;
    JsonValue path_value = entry;
    if (entry.is_object()) {
      entry.allow_only(keys);
      object = entry;
      path_value = entry.member("path");
    }
    const EntryPath where = entry_path(path_value, base);
    std::vector<batch::FoundFile> found;
    try {
      found = batch::find_input_files({where.disk}, extensions, what);
    } catch (const io::InputError& error) {
      path_value.fail(std::string("no usable ") + what + ": " + error.what());
    }
    for (const batch::FoundFile& file : found) {
      AssetT asset;
      asset.file = fs::path(file.path).lexically_normal().string();
      asset.path = portable_path(asset.file, where);
      asset.name = file.name;
      if (!seen.insert(asset.file).second) continue;  // listed twice: once is enough
      asset.licence = object && object->find("licence") ? object->member("licence").string() : credited_licence(asset.file);
      make(asset, object);
      assets.push_back(std::move(asset));
    }
  }
  std::sort(assets.begin(), assets.end(), [](const AssetT& a, const AssetT& b) { return a.path < b.path; });
  return assets;
}

// COLMAP text models (folders holding cameras.txt and images.txt) and RealEstate10K files (any
// other .txt) found through a camera track entry.
std::vector<TrackAsset> read_tracks(const std::optional<JsonValue>& list, const fs::path& base) {
  std::vector<TrackAsset> tracks;
  if (!list) return tracks;
  if (!list->is_array()) list->fail("expected a list of paths (files, folders or globs) or {\"path\": ...} entries");
  for (std::size_t i = 0; i < list->size(); ++i) {
    const JsonValue entry = (*list)[i];
    std::optional<JsonValue> object;
    JsonValue path_value = entry;
    if (entry.is_object()) {
      entry.allow_only({"path", "licence"});
      object = entry;
      path_value = entry.member("path");
    }
    const EntryPath where = entry_path(path_value, base);
    std::vector<batch::FoundFile> found;
    try {
      found = batch::find_input_files({where.disk}, {".txt"}, "camera track");
    } catch (const io::InputError& error) {
      path_value.fail(std::string("no usable camera track: ") + error.what());
    }
    std::set<std::string> models;
    const std::size_t before = tracks.size();
    for (const batch::FoundFile& file : found) {
      const fs::path path(file.path);
      const std::string stem = path.filename().string();
      TrackAsset track;
      if (stem == "cameras.txt" || stem == "images.txt" || stem == "points3D.txt") {
        const fs::path folder = path.parent_path();
        std::error_code error;
        if (!fs::is_regular_file(folder / "cameras.txt", error) || !fs::is_regular_file(folder / "images.txt", error)) continue;
        if (!models.insert(folder.string()).second) continue;
        track.colmap = true;
        track.file = folder.lexically_normal().string();
        track.name = fs::path(file.name).parent_path().generic_string();
        if (track.name.empty()) track.name = folder.filename().string();
      } else {
        track.file = path.lexically_normal().string();
        track.name = file.name;
      }
      track.path = portable_path(track.file, where);
      track.licence = object && object->find("licence") ? object->member("licence").string()
                                                        : credited_licence(track.colmap ? track.file + "/cameras.txt" : track.file);
      tracks.push_back(std::move(track));
    }
    if (tracks.size() == before) path_value.fail("no usable camera track (a RealEstate10K .txt, or a COLMAP folder with cameras.txt and images.txt)");
  }
  std::sort(tracks.begin(), tracks.end(), [](const TrackAsset& a, const TrackAsset& b) { return a.path < b.path; });
  return tracks;
}

// The props of a layout's scene file, mesh paths made absolute (so the dataset's scene files name
// them from anywhere), and the region its actors stand in.
LayoutAsset read_layout_props(LayoutAsset layout, const std::optional<JsonValue>& object) {
  // Read once: the scene reader checks every prop (naming the layout's file and JSON path), the
  // document keeps the props as written.
  const std::string text = io::read_text_file(layout.file);
  const io::JsonDocument document = io::JsonDocument::parse(text, layout.file);
  const JsonValue root = document.root();
  const scene::SceneFile scene_file = scene::parse_scene(text, layout.file);
  const std::optional<JsonValue> props = root.find("props");
  if (!props || props->size() == 0) root.fail("a layout needs props (the room)");
  layout.props = nlohmann::ordered_json::array();
  const scene::Scene& scene = scene_file.scene;
  std::optional<Eigen::Vector4d> ground;
  for (std::size_t k = 0; k < props->size(); ++k) {
    nlohmann::ordered_json prop = nlohmann::ordered_json::parse((*props)[k].raw().dump());
    const scene::Prop& read = scene.props.at(k);
    if (prop.contains("path")) prop["path"] = fs::absolute(read.path).lexically_normal().string();
    if (read.kind == scene::Prop::Kind::ground && !ground) {
      const Eigen::Vector2d half = read.size.head<2>() / 2;
      ground = Eigen::Vector4d(read.position.x() - half.x() + 1, read.position.y() - half.y() + 1, read.position.x() + half.x() - 1,
                               read.position.y() + half.y() - 1);
    }
    layout.props.push_back(std::move(prop));
  }
  if (object && object->find("region")) {
    layout.region = read_region(object->member("region"));
  } else if (ground && (*ground)[2] > (*ground)[0] && (*ground)[3] > (*ground)[1]) {
    layout.region = *ground;
  } else {
    root.fail("a layout without a ground prop of at least 2 x 2 m needs a \"region\" in the recipe");
  }
  return layout;
}

}  // namespace

Recipe parse_recipe(const std::string& json_text, const std::string& path) {
  const io::JsonDocument document = io::JsonDocument::parse(json_text, path);
  const JsonValue root = document.root();
  if (!root.is_object()) root.fail("a recipe is a JSON object");
  root.allow_only({"version", "name", "description", "seed", "count", "libraries", "shots", "cameras", "props", "points",
                   "outputs", "splits", "max_redraws"});
  const long long version = root.member("version").integer(1, 1'000'000);
  if (version != kRecipeVersion) root.member("version").fail("version " + std::to_string(version) + " is not known (this odyssey reads 1)");
  const fs::path base = fs::path(path).parent_path();
  Recipe recipe;
  recipe.file = path;
  recipe.canonical = root.raw().dump();
  if (const auto value = root.find("name")) {
    recipe.name = value->string();
    if (recipe.name.empty() || recipe.name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-") != std::string::npos) {
      value->fail("a name is letters, digits, '_' and '-' (it names the sequences)");
    }
  }
  if (const auto value = root.find("description")) value->string();
  if (const auto value = root.find("seed")) recipe.seed = static_cast<std::uint64_t>(value->integer(0, 9'007'199'254'740'991LL));
  if (const auto value = root.find("count")) recipe.count = static_cast<int>(value->integer(1, 1'000'000));
  if (const auto value = root.find("max_redraws")) recipe.max_redraws = static_cast<int>(value->integer(0, 100));

  // Libraries.
  const JsonValue libraries = root.member("libraries");
  libraries.allow_only({"characters", "motions", "animals", "props", "camera_tracks", "layouts"});
  recipe.characters = read_library<CharacterAsset>(
      libraries.find("characters"), base, batch::kCharacterExtensions, "character", {"path", "map", "licence"},
      [&](CharacterAsset& asset, const std::optional<JsonValue>& entry) {
        if (entry && entry->find("map")) {
          asset.map = entry_path(entry->member("map"), base).disk;
        } else {
          const fs::path beside = fs::path(asset.file).replace_extension(".map.json");
          std::error_code error;
          if (fs::is_regular_file(beside, error)) asset.map = beside.string();
        }
      });
  recipe.motions = read_library<MotionAsset>(
      libraries.find("motions"), base, batch::kMotionExtensions, "motion", {"path", "bvh_units", "model", "licence"},
      [&](MotionAsset& asset, const std::optional<JsonValue>& entry) {
        if (!entry) return;
        if (const auto units = entry->find("bvh_units")) {
          asset.bvh_units = units->string();
          if (asset.bvh_units != "auto" && !io::parse_bvh_units(asset.bvh_units)) {
            units->fail(std::string("expected ") + io::kBvhUnitsHelp);
          }
        }
        if (const auto model = entry->find("model")) asset.model = fs::absolute(entry_path(*model, base).disk).string();
      });
  recipe.animals = read_library<AnimalAsset>(
      libraries.find("animals"), base, {".glb", ".gltf", ".anime"}, "animal",
      {"path", "animations", "scale", "source_fps", "up", "licence"}, [&](AnimalAsset& asset, const std::optional<JsonValue>& entry) {
        asset.anime = fs::path(asset.file).extension() == ".anime";
        if (!entry) {
          if (!asset.anime) libraries.member("animals").fail("a glTF animal needs {\"path\", \"animations\": [names]}");
          return;
        }
        if (const auto scale = entry->find("scale")) asset.scale = scale->number_in(1e-6, 1e6);
        if (asset.anime) {
          if (entry->find("animations")) entry->member("animations").fail("an .anime mesh is its own animation");
          if (const auto fps = entry->find("source_fps")) asset.source_fps = fps->number_in(1e-3, 1e4);
          if (const auto up = entry->find("up")) {
            asset.up = up->string();
            if (asset.up != "y" && asset.up != "z") up->fail("expected y or z");
          }
          return;
        }
        const JsonValue names = entry->member("animations");
        if (!names.is_array() || names.size() == 0) names.fail("expected a list of the animations to draw from");
        for (std::size_t k = 0; k < names.size(); ++k) {
          asset.animations.push_back(names[k].string());
          if (asset.animations.back().empty()) names[k].fail("an empty animation name");
        }
      });
  recipe.props = read_library<PropAsset>(libraries.find("props"), base, {".glb", ".gltf", ".obj"}, "prop mesh",
                                         {"path", "scale", "up", "licence"},
                                         [&](PropAsset& asset, const std::optional<JsonValue>& entry) {
                                           if (!entry) return;
                                           if (const auto scale = entry->find("scale")) {
                                             const Range range = read_range(*scale, 1e-4, 1e4);
                                             asset.scale_low = range.low;
                                             asset.scale_high = range.high;
                                           }
                                           if (const auto up = entry->find("up")) {
                                             const std::string axis = up->string();
                                             if (axis != "y" && axis != "z") up->fail("expected y or z");
                                             asset.up_z = axis == "z";
                                           }
                                         });
  recipe.camera_tracks = read_tracks(libraries.find("camera_tracks"), base);
  recipe.layouts = read_library<LayoutAsset>(libraries.find("layouts"), base, {".json"}, "layout", {"path", "region", "licence"},
                                             [&](LayoutAsset& asset, const std::optional<JsonValue>& entry) {
                                               asset = read_layout_props(std::move(asset), entry);
                                             });
  if (recipe.characters.empty() && recipe.animals.empty()) libraries.fail("no characters and no animals: a shot needs actors");
  if (!recipe.characters.empty() && recipe.motions.empty()) libraries.fail("characters need motions to play");

  // Shots.
  if (const auto shots = root.find("shots")) {
    shots->allow_only({"fps", "seconds", "actors", "animals", "arrangement", "together_radius", "field", "speed", "quality",
                       "layout_share", "ground_size"});
    if (const auto value = shots->find("fps")) recipe.fps = value->number_in(1, 1000);
    if (const auto value = shots->find("seconds")) recipe.seconds = read_range(*value, 0.1, 3600);
    if (const auto value = shots->find("actors")) recipe.actors = read_count_range(*value, 0, 64);
    if (const auto value = shots->find("animals")) recipe.animal_count = read_count_range(*value, 0, 64);
    if (const auto value = shots->find("arrangement")) recipe.arrangement = read_shares(*value, {"together", "field"});
    if (const auto value = shots->find("together_radius")) recipe.together_radius = read_range(*value, 0.1, 100);
    if (const auto value = shots->find("field")) recipe.field = read_region(*value);
    if (const auto value = shots->find("speed")) recipe.speed = read_range(*value, 0.05, 20);
    if (const auto value = shots->find("quality")) recipe.quality = read_shares(*value, {"fast", "balanced", "accurate"});
    if (const auto value = shots->find("layout_share")) recipe.layout_share = value->number_in(0, 1);
    if (const auto value = shots->find("ground_size")) recipe.ground_size = value->number_in(1, 1e4);
  }
  // Problems between keys are reported at the key that asks for what cannot be given, where the
  // recipe has it (else where the default applies).
  const auto at = [&](std::initializer_list<const char*> path) {
    JsonValue value = root;
    for (const char* key : path) {
      const std::optional<JsonValue> child = value.find(key);
      if (!child) break;
      value = *child;
    }
    return value;
  };
  if (recipe.actors.high > 0 && recipe.characters.empty()) {
    if (!root.find("shots") || !root.member("shots").find("actors")) recipe.actors = {0, 0};  // the default: people when there are characters
    else at({"shots", "actors"}).fail("asks for people but libraries.characters is empty");
  }
  if (recipe.animal_count.high > 0 && recipe.animals.empty()) at({"shots", "animals"}).fail("asks for animals but libraries.animals is empty");
  if (recipe.actors.high == 0 && recipe.animal_count.high == 0) at({"shots", "actors"}).fail("a shot would have no actor (no people, no animals)");
  if (recipe.actors.high == 0 && recipe.animal_count.low == 0) at({"shots", "animals"}).fail("may draw 0 while there are no people: a shot would have no actor");
  if (recipe.actors.low == 0 && recipe.animal_count.high == 0) at({"shots", "actors"}).fail("may draw 0 and there are no animals: a shot would have no actor");
  if (recipe.layout_share > 0 && recipe.layouts.empty()) at({"shots", "layout_share"}).fail("above 0 but libraries.layouts is empty");

  // Cameras.
  if (const auto cameras = root.find("cameras")) {
    cameras->allow_only({"count", "kinds", "handheld", "width", "height", "hfov", "min_valid", "ego_min_other_visible"});
    if (const auto value = cameras->find("count")) recipe.cameras = read_count_range(*value, 1, 16);
    if (const auto value = cameras->find("kinds")) {
      recipe.camera_kinds = read_shares(*value, {"static", "orbit", "swoop", "zoom", "dolly_zoom", "track", "ego"});
    }
    if (const auto value = cameras->find("handheld")) recipe.handheld_share = value->number_in(0, 1);
    if (const auto value = cameras->find("width")) recipe.width = static_cast<int>(value->integer(16, 8192));
    if (const auto value = cameras->find("height")) recipe.height = static_cast<int>(value->integer(16, 8192));
    if (const auto value = cameras->find("hfov")) recipe.hfov = read_range(*value, 1, 170);
    if (const auto value = cameras->find("min_valid")) recipe.min_valid = value->number_in(0, 1);
    if (const auto value = cameras->find("ego_min_other_visible")) recipe.ego_min_other_visible = value->number_in(0, 1);
  }
  const auto share_of = [&](const std::string& kind) {
    for (const auto& [name, weight] : recipe.camera_kinds) {
      if (name == kind) return weight;
    }
    return 0.0;
  };
  const bool kinds_given = root.find("cameras") && root.member("cameras").find("kinds");
  if (!kinds_given) {
    // The default kinds: tracks when there are camera tracks, ego cameras when there are people.
    std::erase_if(recipe.camera_kinds, [&](const auto& kind) {
      return (kind.first == "track" && recipe.camera_tracks.empty()) || (kind.first == "ego" && recipe.actors.high == 0);
    });
  }
  if (share_of("track") > 0 && recipe.camera_tracks.empty()) at({"cameras", "kinds", "track"}).fail("above 0 but libraries.camera_tracks is empty");
  if (share_of("ego") > 0 && recipe.actors.high == 0) at({"cameras", "kinds", "ego"}).fail("above 0 but shots.actors draws no people to ride on");

  // Props.
  if (const auto props = root.find("props")) {
    props->allow_only({"scatter", "box_share", "dynamic_share", "on_paths_share", "force_rate"});
    if (const auto value = props->find("scatter")) recipe.scatter = read_count_range(*value, 0, 200);
    if (const auto value = props->find("box_share")) recipe.box_share = value->number_in(0, 1);
    if (const auto value = props->find("dynamic_share")) recipe.dynamic_share = value->number_in(0, 1);
    if (const auto value = props->find("on_paths_share")) recipe.on_paths_share = value->number_in(0, 1);
    if (const auto value = props->find("force_rate")) recipe.force_rate = read_range(*value, 0, 100);
  }
  if (recipe.props.empty()) {
    // Without prop meshes every scattered prop is a box, unless the recipe asks for meshes.
    if (root.find("props") && root.member("props").find("box_share") && recipe.box_share < 1 && recipe.scatter.high > 0) {
      at({"props", "box_share"}).fail("below 1 (some scattered props are library meshes) but libraries.props is empty");
    }
    recipe.box_share = 1;
  }

  if (const auto points = root.find("points")) {
    points->allow_only({"per_actor", "props"});
    if (const auto value = points->find("per_actor")) recipe.points_per_actor = static_cast<int>(value->integer(1, 1'000'000));
    if (const auto value = points->find("props")) recipe.prop_points = static_cast<int>(value->integer(0, 1'000'000));
  }
  if (const auto outputs = root.find("outputs")) {
    outputs->allow_only({"depth", "normals", "masks", "exact", "previews"});
    if (const auto value = outputs->find("depth")) recipe.depth = value->boolean();
    if (const auto value = outputs->find("normals")) recipe.normals = value->boolean();
    if (const auto value = outputs->find("masks")) recipe.masks = value->boolean();
    if (const auto value = outputs->find("exact")) recipe.exact = value->boolean();
    if (const auto value = outputs->find("previews")) recipe.previews = value->boolean();
  }

  // Splits: fractions, and what they partition.
  if (const auto splits = root.find("splits")) {
    splits->allow_only({"train", "val", "test", "by"});
    recipe.splits.clear();
    for (const char* name : {"train", "val", "test"}) {
      if (const auto value = splits->find(name)) {
        const double share = value->number_in(0, 1);
        if (share > 0) recipe.splits.emplace_back(name, share);
      }
    }
    double total = 0;
    for (const auto& [name, share] : recipe.splits) total += share;
    if (std::abs(total - 1) > 1e-6) splits->fail("the fractions of train, val and test must add up to 1 (they add up to " + std::to_string(total) + ")");
    if (const auto value = splits->find("by")) {
      recipe.split_by = value->string();
      if (recipe.split_by != "sequence" && recipe.split_by != "motion" && recipe.split_by != "character") {
        value->fail("expected sequence, motion or character");
      }
    }
    const std::size_t parts = recipe.splits.size();
    const auto check = [&](std::size_t assets, const char* what) {
      if (assets < parts) {
        splits->fail(std::to_string(parts) + " splits by " + recipe.split_by + " need at least " + std::to_string(parts) + " " + what +
                     ", the libraries hold " + std::to_string(assets));
      }
    };
    if (recipe.split_by == "motion") check(recipe.motions.size(), "motions");
    if (recipe.split_by == "character") {
      check(recipe.characters.size(), "characters");
      if (!recipe.animals.empty()) check(recipe.animals.size(), "animals (split by character splits them too)");
    }
  }
  return recipe;
}

Recipe read_recipe(const std::string& path) { return parse_recipe(io::read_text_file(path), path); }

std::string example_recipe_path() { return (fs::path(scene::bundled_data_folder()) / "datasets" / "example.json").string(); }

}  // namespace odyssey::dataset
