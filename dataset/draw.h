// Drawing a dataset's sequence from its recipe: sequence i, attempt t is a scene file (JSON, as
// docs/scenes.md reads it) drawn from splitmix64 numbers seeded by (seed, i, t) alone, so any one
// sequence is re-made without the others and adding sequences never changes earlier ones. Its
// split depends on (seed, i) only, not on the attempt: a redraw stays in its split.
//
// Splits. By sequence: sequence i's split is drawn with the recipe's fractions. By motion (or
// character): the library's assets are first dealt into the splits by the fractions (each asset
// placed by a hash of (seed, its name), so the deal does not depend on the library's order;
// every split with a fraction gets at least one), sequence i's split is drawn as above, and its
// motions (characters and animals) are drawn from that split's assets only: no asset of one
// split appears in another.
//
// A shot: a layout (with the recipe's layout share) or a ground; its people (each a character
// and a motion, at a drawn speed and quality, the clip's start drawn so the shot fits in it where
// it can) and animals (a glTF animal playing one of its animations, or an .anime mesh); placed
// together (in a square of the drawn radius about a point, so they meet) or spread over the field
// (or, in a layout, over its region), by the scene's own seeded placement, which draws again
// while footprints overlap; scattered props (boxes and library meshes, dynamic with the recipe's
// share, some on the walkers' paths) with seeded kicks; cameras of the drawn kinds (an ego camera
// on a drawn person), some handheld; points and maps as the recipe asks.
#pragma once

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dataset/recipe.h"

namespace odyssey::dataset {

// What the draw needs to know of an asset's file: a motion's length in seconds.
struct AssetFacts {
  std::function<double(const MotionAsset&)> motion_seconds;
};

struct UsedAsset {
  std::string kind;  // character, motion, animal, prop, camera_track, layout
  std::string path, licence;
  std::string file;  // on disk
};

struct DrawnShot {
  std::string name;   // the sequence's name: <recipe name>_<i, 5 digits>
  std::string split;
  std::uint64_t seed = 0;  // the scene's seed
  nlohmann::ordered_json scene;  // the scene file
  std::vector<UsedAsset> assets;
  std::vector<int> ego_actors;   // per camera: the actor an ego camera rides on, else -1
};

std::string sequence_name(const Recipe& recipe, long index);

// The split of sequence `index` (not of the attempt).
std::string split_of(const Recipe& recipe, long index);

// The indices of the library's assets in `split` when the recipe splits by their kind; all of
// them otherwise. `kind` is "motion", "character" or "animal".
std::vector<std::size_t> assets_of_split(const Recipe& recipe, const std::string& kind, const std::string& split);

// Throws std::invalid_argument when the recipe cannot make the shot (a distribution that cannot be
// satisfied), io::InputError from `facts` for a motion file that cannot be read.
DrawnShot draw_shot(const Recipe& recipe, long index, int attempt, const AssetFacts& facts);

}  // namespace odyssey::dataset
