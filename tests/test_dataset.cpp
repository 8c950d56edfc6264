// Dataset recipes and draws (dataset/recipe.h, dataset/draw.h): every bad recipe is one line naming
// the file and the JSON path; draws depend on (seed, index, attempt) alone; splits by motion or
// character keep every asset in one split; the shares drawn follow the recipe's.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>

#include "dataset/draw.h"
#include "dataset/recipe.h"
#include "mocap_io/input_error.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;
using test_support::message_of;

const std::string kData = ODYSSEY_DATA_DIR;
const std::string kShared = std::string(ODYSSEY_SHARED_DIR) + "/assets";

// Lengths without reading the files: the draw's only use of them.
const dataset::AssetFacts kFacts{[](const dataset::MotionAsset& motion) { return motion.name.find("jump") != std::string::npos ? 22.9 : 2.86; }};

// A recipe over the shared assets: four BVH clips (split three ways by motion), five characters.
std::string shared_recipe(const std::string& extra = "",
                          const std::string& splits = R"("splits": {"train": 0.6, "val": 0.2, "test": 0.2, "by": "motion"})") {
  return R"({"version": 1, "name": "t", "seed": 5,
    "libraries": {"characters": [")" + kShared + R"(/characters/CesiumMan.glb", ")" + kShared + R"(/characters/RiggedFigure.glb", ")" +
         kShared + R"(/characters/RobotExpressive.glb"],
                  "motions": [")" + kShared + R"(/mocap"],
                  "animals": [{"path": ")" + kShared + R"(/characters/Fox.glb", "animations": ["Walk"], "scale": 0.01}],
                  "props": [")" + kShared + R"(/props"],
                  "camera_tracks": [")" + kShared + R"(/cameras"]},
    "shots": {"actors": [1, 3], "animals": [0, 1], "seconds": [1, 2]},
    "props": {"scatter": [0, 4]},
    )" + splits + extra + "}";
}

fs::path write(const fs::path& dir, const std::string& name, const std::string& text) {
  fs::create_directories(dir);
  std::ofstream(dir / name) << text;
  return dir / name;
}

TEST(DatasetRecipeTest, ReadsLibrariesWithLicences) {
  const dataset::Recipe recipe = dataset::parse_recipe(shared_recipe(), "r.json");
  EXPECT_EQ(recipe.characters.size(), 3u);
  EXPECT_EQ(recipe.motions.size(), 4u);  // cmu_jump, cmu_walk, makehuman_walk1, makehuman_zombie_walk1
  EXPECT_EQ(recipe.props.size(), 4u);    // three glTF props and the brick
  ASSERT_EQ(recipe.camera_tracks.size(), 2u);
  EXPECT_TRUE(recipe.camera_tracks[0].colmap);  // the COLMAP folder, found through its cameras.txt
  EXPECT_FALSE(recipe.camera_tracks[1].colmap);
  // Licences come from the shared CREDITS.md rows naming each file.
  for (const auto& character : recipe.characters) {
    if (contains(character.path, "RobotExpressive")) EXPECT_TRUE(contains(character.licence, "CC0-1.0")) << character.licence;
    if (contains(character.path, "CesiumMan")) EXPECT_TRUE(contains(character.licence, "CC-BY-4.0")) << character.licence;
  }
  EXPECT_TRUE(contains(recipe.camera_tracks[0].licence, "BSD-3-Clause")) << recipe.camera_tracks[0].licence;
  for (const auto& motion : recipe.motions) EXPECT_NE(motion.licence, "unknown") << motion.path;
}

TEST(DatasetRecipeTest, BadRecipesNameTheFileAndJsonPath) {
  const auto error = [](const std::string& text) {
    return message_of<io::InputError>([&] { dataset::parse_recipe(text, "r.json"); });
  };
  EXPECT_TRUE(contains(error(shared_recipe(R"(, "colour": 3)")), "r.json: colour: unknown key"));
  EXPECT_TRUE(contains(error(R"({"version": 2, "libraries": {}})"), "r.json: version: version 2 is not known"));
  // A library entry that yields nothing.
  const fs::path empty = test_support::scratch_dir("dataset_recipe") / "empty";
  fs::create_directories(empty);
  const std::string no_motion = error(R"({"version": 1, "libraries": {"characters": [")" + kShared +
                                      R"(/characters/CesiumMan.glb"], "motions": [")" + empty.string() + R"("]}})");
  EXPECT_TRUE(contains(no_motion, "r.json: libraries.motions[0]: no usable motion")) << no_motion;
  // A split that cannot be made: one motion, three splits by motion.
  const std::string split = error(R"({"version": 1, "libraries": {"characters": [")" + kShared +
                                  R"(/characters/CesiumMan.glb"], "motions": [")" + kShared + R"(/mocap/cmu_walk_cgspeed.bvh"]},
      "splits": {"train": 0.8, "val": 0.1, "test": 0.1, "by": "motion"}})");
  EXPECT_TRUE(contains(split, "r.json: splits: 3 splits by motion need at least 3 motions, the libraries hold 1")) << split;
  EXPECT_TRUE(contains(error(shared_recipe("", R"("splits": {"train": 0.7, "val": 0.2, "test": 0.2})")),
                       "r.json: splits: the fractions of train, val and test must add up to 1"));
  // Distributions that cannot be satisfied.
  EXPECT_TRUE(contains(error(shared_recipe(R"(, "cameras": {"kinds": {"orbit": 0}})")), "r.json: cameras.kinds: no share above 0"));
  EXPECT_TRUE(contains(error(shared_recipe(R"(, "cameras": {"count": [3, 1]})")), "r.json: cameras.count: min is above max"));
  EXPECT_TRUE(contains(error(shared_recipe(R"(, "cameras": {"kinds": {"tripod": 1}})")),
                       "r.json: cameras.kinds: unknown key 'tripod' (expected static, orbit, swoop, zoom, dolly_zoom, track, ego)"));
  const std::string no_one = error(R"({"version": 1, "libraries": {"characters": [")" + kShared + R"(/characters/CesiumMan.glb"], "motions": [")" +
                                   kShared + R"(/mocap"]}, "shots": {"actors": [0, 2]}})");
  EXPECT_TRUE(contains(no_one, "r.json: shots.actors: may draw 0 and there are no animals")) << no_one;
  const std::string no_tracks = error(R"({"version": 1, "libraries": {"characters": [")" + kShared +
                                      R"(/characters/CesiumMan.glb"], "motions": [")" + kShared + R"(/mocap"]}, "cameras": {"kinds": {"track": 1}}})");
  EXPECT_TRUE(contains(no_tracks, "r.json: cameras.kinds.track: above 0 but libraries.camera_tracks is empty")) << no_tracks;
  EXPECT_TRUE(contains(error(R"({"version": 1, "libraries": {"characters": [")" + kShared +
                             R"(/characters/CesiumMan.glb"], "motions": [{"path": ")" + kShared + R"(/mocap", "bvh_units": "furlong"}]}})"),
                       "r.json: libraries.motions[0].bvh_units: expected auto"));
}

TEST(DatasetDrawTest, SequenceDependsOnSeedAndIndexAlone) {
  const dataset::Recipe recipe = dataset::parse_recipe(shared_recipe(), "r.json");
  dataset::Recipe more = recipe;
  more.count = 1000;  // the count never enters a draw
  for (long i : {0L, 3L, 17L}) {
    const dataset::DrawnShot a = dataset::draw_shot(recipe, i, 0, kFacts);
    const dataset::DrawnShot b = dataset::draw_shot(more, i, 0, kFacts);
    EXPECT_EQ(a.scene.dump(), b.scene.dump());
    EXPECT_EQ(a.name, "t_" + std::string(i < 10 ? "0000" : "000") + std::to_string(i));
    // A redraw is another shot, in the same split.
    const dataset::DrawnShot again = dataset::draw_shot(recipe, i, 1, kFacts);
    EXPECT_NE(a.scene.dump(), again.scene.dump());
    EXPECT_EQ(a.split, again.split);
  }
  // Another seed, another dataset.
  dataset::Recipe reseeded = recipe;
  reseeded.seed = 6;
  EXPECT_NE(dataset::draw_shot(recipe, 0, 0, kFacts).scene.dump(), dataset::draw_shot(reseeded, 0, 0, kFacts).scene.dump());
}

// Every motion of a sequence comes from its split's share of the library, the shares partition
// the library, and the splits' frequencies follow the fractions.
TEST(DatasetDrawTest, SplitsByMotionKeepEveryClipInOneSplit) {
  const dataset::Recipe recipe = dataset::parse_recipe(shared_recipe(), "r.json");
  std::map<std::string, std::set<std::string>> motions_of_split;
  std::set<std::size_t> dealt;
  for (const char* split : {"train", "val", "test"}) {
    const std::vector<std::size_t> mine = dataset::assets_of_split(recipe, "motion", split);
    EXPECT_FALSE(mine.empty()) << split;
    for (std::size_t m : mine) {
      EXPECT_TRUE(dealt.insert(m).second) << "motion " << m << " in two splits";
      motions_of_split[split].insert(recipe.motions[m].path);
    }
  }
  EXPECT_EQ(dealt.size(), recipe.motions.size());
  std::map<std::string, int> counts;
  constexpr int kDraws = 600;
  for (long i = 0; i < kDraws; ++i) {
    const dataset::DrawnShot shot = dataset::draw_shot(recipe, i, 0, kFacts);
    ++counts[shot.split];
    for (const auto& actor : shot.scene["actors"]) {
      if (actor.contains("motion")) EXPECT_TRUE(motions_of_split[shot.split].count(actor["motion"])) << shot.name;
    }
  }
  // Binomial: 0.6 of 600 = 360 +- 12 (one sigma); 0.2 of 600 = 120 +- 9.8. Four sigma each.
  EXPECT_NEAR(counts["train"], 360, 48);
  EXPECT_NEAR(counts["val"], 120, 40);
  EXPECT_NEAR(counts["test"], 120, 40);

  // By character: characters and animals are dealt, so one fox cannot go into two splits.
  const std::string by_character = shared_recipe("", R"("splits": {"train": 0.6, "test": 0.4, "by": "character"})");
  const std::string one_fox = message_of<io::InputError>([&] { dataset::parse_recipe(by_character, "r.json"); });
  EXPECT_TRUE(contains(one_fox, "r.json: splits: 2 splits by character need at least 2 animals")) << one_fox;
}

TEST(DatasetDrawTest, SharesFollowTheRecipe) {
  const dataset::Recipe recipe = dataset::parse_recipe(shared_recipe(R"(, "cameras": {"count": 2, "kinds": {"orbit": 3, "ego": 1}, "handheld": 0.5})"),
                                                       "r.json");
  std::map<std::string, int> kinds;
  int handheld = 0, cameras = 0, scattered = 0, shots = 400;
  std::set<int> people;
  for (long i = 0; i < shots; ++i) {
    const dataset::DrawnShot shot = dataset::draw_shot(recipe, i, 0, kFacts);
    ASSERT_EQ(shot.scene["cameras"].size(), 2u);
    for (std::size_t c = 0; c < shot.scene["cameras"].size(); ++c) {
      const auto& camera = shot.scene["cameras"][c];
      ++kinds[camera["type"]];
      ++cameras;
      handheld += camera.contains("handheld");
      EXPECT_EQ(shot.ego_actors[c] >= 0, camera["type"] == "ego");
    }
    int count = 0;
    for (const auto& actor : shot.scene["actors"]) count += actor.contains("motion");
    people.insert(count);
    if (shot.scene.contains("scatter")) scattered += shot.scene["scatter"]["count"].get<int>();
    EXPECT_GE(shot.scene["seconds"].get<double>(), 1.0);
    EXPECT_LE(shot.scene["seconds"].get<double>(), 2.0);
  }
  // 800 cameras, orbit 3/4: 600 +- 12.2; handheld half of the 600 orbits: 300 +- 12.2. Four sigma.
  EXPECT_NEAR(kinds["orbit"], 600, 49);
  EXPECT_NEAR(handheld, 300, 49);
  EXPECT_EQ(people, (std::set<int>{1, 2, 3}));
  EXPECT_NEAR(scattered / double(shots), 2.0, 0.3);  // uniform on 0..4
}

}  // namespace
}  // namespace odyssey
