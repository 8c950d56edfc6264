// A dataset recipe: the asset libraries a dataset draws from, the distributions each sequence is
// drawn from, the splits and one seed (docs/datasets.md documents every key; `odyssey dataset
// --example` runs the bundled one). Like scene files, relative paths are relative to the recipe,
// "data:" paths name the bundled data folder, unknown keys are refused and every error names the
// file and the JSON path: "recipe.json: cameras.kinds.orbit: not a number".
//
// Libraries are resolved when the recipe is read: each entry is a file, a folder (searched
// recursively for the kind's files) or a glob, as `odyssey batch` finds its inputs, and an entry
// that yields no usable asset is an error. Assets are sorted by path within each library, so a
// library's order does not depend on the file system.
//
// Licences: an entry's "licence" when given; otherwise the licence column (the last) of the row
// naming the file in a CREDITS.md found in the asset's folder or the folders above it; otherwise
// "unknown".
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace odyssey::dataset {

inline constexpr int kRecipeVersion = 1;

struct Asset {
  std::string path;     // resolved; "data:" paths kept as written so scene files stay portable
  std::string file;     // the file on disk (path with "data:" resolved)
  std::string name;     // its path relative to the library entry it was found through, without extension
  std::string licence;
};

struct CharacterAsset : Asset {
  std::optional<std::string> map;  // a bone map: the entry's, or <stem>.map.json beside the character
};

struct MotionAsset : Asset {
  std::string bvh_units = "auto";  // as a scene file's bvh_units ("auto": the reader infers them)
  std::optional<std::string> model;  // AMASS: the body model (unset: the synthetic SMPL-X)
};

// An animal: a glTF character playing one of its own animations, or a DeformingThings4D mesh.
struct AnimalAsset : Asset {
  bool anime = false;
  std::vector<std::string> animations;  // glTF: the names drawn from (at least one)
  double scale = 1;
  double source_fps = 30;  // anime
  std::string up = "y";    // anime
};

struct PropAsset : Asset {
  double scale_low = 1, scale_high = 1;
  bool up_z = false;  // OBJ already Z up
};

struct TrackAsset : Asset {
  bool colmap = false;  // a COLMAP text model's folder; else a RealEstate10K camera file
};

// A scene file whose props make a room; actors stand in `region` (default: the scene's ground,
// shrunk by 1 m).
struct LayoutAsset : Asset {
  nlohmann::ordered_json props;  // the file's props, their mesh paths made absolute
  Eigen::Vector4d region{-2, -2, 2, 2};  // x0, y0, x1, y1
};

// A number drawn uniformly from [low, high] (equal: fixed).
struct Range {
  double low = 0, high = 0;
};

// Named shares (weights, not necessarily summing to 1) of a categorical draw.
using Shares = std::vector<std::pair<std::string, double>>;

struct Recipe {
  std::string file;  // where it was read from (errors, the dataset's records)
  std::string name = "dataset";
  std::uint64_t seed = 0;
  int count = 8;  // sequences (--count overrides)

  std::vector<CharacterAsset> characters;
  std::vector<MotionAsset> motions;
  std::vector<AnimalAsset> animals;
  std::vector<PropAsset> props;
  std::vector<TrackAsset> camera_tracks;
  std::vector<LayoutAsset> layouts;

  // Shots.
  double fps = 30;
  Range seconds{4, 4};
  Range actors{1, 2};   // humanoids per shot (whole numbers)
  Range animal_count{0, 0};
  Shares arrangement{{"together", 1}, {"field", 1}};  // around each other, or spread over a field
  Range together_radius{0.8, 1.6};                    // m from the group's centre
  Eigen::Vector4d field{-6, -6, 6, 6};
  Range speed{0.9, 1.1};
  Shares quality{{"balanced", 1}};
  double layout_share = 0;  // of shots set in a layout (when there are layouts)
  double ground_size = 40;  // m, the ground of a shot outside a layout

  // Cameras.
  Range cameras{1, 3};
  Shares camera_kinds{{"static", 1}, {"orbit", 1}, {"swoop", 1}, {"zoom", 1}, {"dolly_zoom", 1}, {"track", 1}, {"ego", 1}};
  double handheld_share = 0.3;  // of cameras with handheld shake
  int width = 960, height = 540;
  Range hfov{50, 80};
  double min_valid = 0.3;              // share of a camera's point-frames in view, or drawn again
  double ego_min_other_visible = 0.05;  // an ego camera's view of the other actors' point-frames

  // Props scattered (physics).
  Range scatter{0, 0};
  double box_share = 0.5;     // of scattered props that are boxes rather than library meshes
  double dynamic_share = 1;   // of scattered props that Bullet moves
  double on_paths_share = 0.3;
  Range force_rate{0, 0};     // kicks per dynamic prop per second

  // Points and maps.
  int points_per_actor = 2000;
  int prop_points = 0;
  bool depth = true, normals = true, masks = true, exact = false;
  bool previews = false;  // a contact sheet per sequence

  // Splits.
  Shares splits{{"train", 1}};
  std::string split_by = "sequence";  // sequence, motion or character
  int max_redraws = 4;

  // The recipe as read, for the key of every sequence (what its outputs depend on).
  std::string canonical;
};

// Throws io::InputError naming the file and JSON path.
Recipe read_recipe(const std::string& path);
Recipe parse_recipe(const std::string& json_text, const std::string& path);

// The bundled example recipe (data/datasets/example.json, over the bundled data folder).
std::string example_recipe_path();

}  // namespace odyssey::dataset
