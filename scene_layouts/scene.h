// A shot: actors (a motion retargeted onto a character, a character's own animation, or a
// vertex-animated mesh: actor_source.h; each placed in time and on the floor), props
// (static rigid geometry), cameras, and the outputs asked for. run_scene (pipeline.h) runs it;
// scene_file.h reads it from JSON; the single-actor commands build a one-actor scene.
//
// Time. The scene runs at `fps` for `seconds` (default: until the last actor's clip ends). Actor k
// maps scene time t to its retargeted clip's time
//   c(t) = clamp(trim_start + speed (t - start), trim_start, trim_end),
// so before `start` it holds its first pose and after its clip ends its last. A start given as a
// range is drawn from the scene's seed.
//
// Placement on the floor (z = 0 stays where the retargeting put the feet): "as recorded" keeps the
// motion where the capture had it; a fixed placement turns the whole motion about the vertical
// through the actor's root at scene time 0 so that the actor faces `yaw` degrees there (from +x,
// counter-clockwise seen from above; its facing is its rest facing turned as its pelvis turned)
// and moves that root to (x, y); a random placement draws x, y uniformly in `region` and yaw in
// [0, 360) from the scene's seed, drawing again while the actor's footprint meets another's.
// Footprints: a disc about the root's horizontal position of radius 0.15 of the character's rest
// height, swept over the scene's frames; two actors whose discs overlap in some frame are an
// error naming both and the frame (or, placed at random, drawn again).
//
// Props are rigid geometry: a ground plane (size x, y, centred on `position`), a box (size x, y,
// z; its bottom face centred on `position`), or a mesh file (glTF/GLB at its rest pose, or OBJ,
// read Y up like Blender's default export unless `up_z`), each turned by `yaw` degrees about the
// vertical and scaled by `scale` before it is moved to `position`. A prop is static unless it has
// `dynamics`: then Bullet moves it (prop_physics.h), pushed by the actors' bones, by the scene's
// `forces` and by other props. `scatter` adds seeded props on the ground (prop_physics.h).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "scene_layouts/actor.h"
#include "scene_layouts/actor_source.h"
#include "scene_layouts/camera_rigs.h"
#include "skinning/sampling.h"

namespace odyssey::scene {

struct Placement {
  enum class Kind { as_recorded, fixed, random };
  Kind kind = Kind::as_recorded;
  double x = 0, y = 0, yaw_deg = 0;                               // fixed
  Eigen::AlignedBox2d region{Eigen::Vector2d(-2, -2), Eigen::Vector2d(2, 2)};  // random
};

struct SceneActor {
  std::string name;  // unique in the scene; names its output files
  // What drives it (actor_source.h): a RetargetRequest for a motion, an AnimationRequest for a
  // character's own animation, an AnimeRequest for a DeformingThings4D mesh.
  ActorSource source;
  Placement placement;
  double start_s = 0;                   // scene time at which the (trimmed) clip starts
  // When set, start_s is drawn uniformly in [first, second] from the scene's seed instead.
  std::optional<std::pair<double, double>> start_range;
  double trim_start_s = 0;              // clip time of the first pose used
  std::optional<double> trim_end_s;     // clip time of the last (default: the clip's end)
  double speed = 1;                     // > 0; 2 plays the clip twice as fast
  std::optional<int> points;            // tracked points on it (default: outputs.points_per_actor)
  skinning::SamplingMode sampling = skinning::SamplingMode::surface;
};

// What a prop is in a sequence's masks (pointodyssey.h); a ground prop is always ground.
enum class PropCategory { prop, ground, structure };

// A dynamic prop's physical properties (Prop::dynamics). Declared outside Prop: a nested struct
// with default member initializers is not yet complete where std::optional<Prop::Dynamics> asks
// whether it can be default-constructed (clang rejects emplace() on it).
struct PropDynamics {
  double mass = 1;           // kg, > 0, spread uniformly over the shape's volume
  double friction = 0.5;     // [0, 2]; a contact uses the product of both bodies' values
  double restitution = 0.5;  // [0, 1]; likewise
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();          // m/s at t = 0, of the prop's origin
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  // rad/s at t = 0, world axes
  // A mesh collides as the union of its connected pieces' hulls, not as one hull.
  bool pieces = false;
};

struct Prop {
  enum class Kind { ground, box, mesh };
  Kind kind = Kind::box;
  std::string name;
  PropCategory category = PropCategory::prop;
  Eigen::Vector3d size = Eigen::Vector3d::Ones();  // ground: x, y; box: x, y, z (metres)
  std::string path;                                // mesh: .glb, .gltf or .obj
  bool up_z = false;                               // mesh from OBJ: already Z up
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double yaw_deg = 0, scale = 1;
  // Set: a dynamic prop (a box collides as a box, a mesh as the convex hull of its vertices).
  using Dynamics = PropDynamics;
  std::optional<Dynamics> dynamics;
};

// Seeded kicks on the dynamic props (physics/sampling.h, sample_impulses): per prop, `count` kicks
// over the shot (or `rate` per second on average), each a change of velocity of |dv| uniform in
// [min, max] m/s (impulse = mass dv), heading uniform, upward share of the direction uniform in
// [0, max_upward], acting at a point uniform in the ball of radius lever_arm about the prop's
// origin (so it also spins the prop).
struct SceneForces {
  std::optional<double> count;  // kicks per prop over the shot; when set, rate = count / duration
  double rate = 0.1;            // kicks per prop per second
  double min_speed_change = 0.5, max_speed_change = 2.0;  // m/s
  double max_upward = 0.5;                                // [0, 1]
  double lever_arm = 0;                                   // m
};

// `count` props drawn (seeded) from `props` (templates; their positions and yaws are ignored),
// stood on the ground (z = 0) without overlapping each other or the actors where they stand at
// frame 0; the first `on_paths` lie on the root paths of the actors that get 1 m or more from
// their start (prop i on the i mod P-th of those P paths; with no such path, in the region), the
// rest anywhere in `region` (x, y). They are named "<template name>_<k>" and come after the
// scene's own props.
struct SceneScatter {
  int count = 0;
  std::vector<Prop> props;  // at least one
  Eigen::AlignedBox2d region{Eigen::Vector2d(-5, -5), Eigen::Vector2d(5, 5)};
  int on_paths = 0;
  double gap = 0.05;  // m of clearance between footprints
};
// Camera kinds: each holds only its own settings; SceneCamera holds what every camera has. Unset
// positions and targets follow the actors' framing (shot_cameras.h).
//
// Static (the file format's "static"): fixed, looking at the target.
struct StaticRig {
  std::optional<Eigen::Vector3d> position, target;
  // Seeded jitter of the centre (metres, each axis uniform in [-jitter, jitter], drawn once per
  // camera from the scene's seed).
  double jitter_m = 0;
};

// Orbit: circling the target.
struct OrbitRig {
  std::optional<Eigen::Vector3d> target;
  std::optional<double> radius, height_m, start_angle_deg;
  double period_s = 10;
  // Seeded jitter of the target and height, drawn as a static camera's.
  double jitter_m = 0;
};

// Ego: on actor `actor`'s head; unset offsets are 0.06 and 0.047 of its rest height.
struct EgoRig {
  int actor = 0;
  std::optional<double> eye_forward, eye_up;
  double smoothing_s = 0;
};

// File: a camera path JSON with one frame per scene frame.
struct FileRig {
  std::string path;
};

// Swoop (camera_rigs.h): from height_m (default 0.9 of the tallest actor) to height_end_m (default
// 2.5 of it) while turning sweep_deg about the target.
struct SwoopRig {
  std::optional<Eigen::Vector3d> target;
  std::optional<double> radius, height_m, start_angle_deg;
  std::optional<double> height_end_m;
  double sweep_deg = 90;
};

// Dolly-zoom (camera_rigs.h): distance from the target at the last frame (default half the first's).
struct DollyZoomRig {
  std::optional<Eigen::Vector3d> position, target;
  std::optional<double> end_distance;
};

// Zoom (camera_rigs.h): horizontal field of view at the last frame (default half of hfov_deg).
struct ZoomRig {
  std::optional<Eigen::Vector3d> position, target;
  std::optional<double> hfov_end_deg;
};

// A track from real video (scene_layouts/imported_camera.h): a RealEstate10K camera file or a
// COLMAP text model's folder. The circle the path fits (target, when set, is its centre; height_m,
// when set, the centres' mean height; start_angle the direction to the first camera), track
// seconds per scene second, the rate of COLMAP's images, the track's up (default estimated), and,
// when set, the sigma in seconds of the smoothed look-at point on the actors the camera is re-aimed
// at.
struct ImportedRig {
  enum class Format { realestate10k, colmap };
  Format format = Format::realestate10k;
  std::string path;  // realestate10k: the camera file; colmap: the text model's folder
  std::optional<Eigen::Vector3d> target;
  std::optional<double> height_m, start_angle_deg;
  double extent_m = 8;
  bool anchor_focus = false;  // anchor the path on its cameras' focus, not its centroid
  double speed = 1;
  double source_fps = 30;  // colmap
  std::optional<Eigen::Vector3d> up;
  std::optional<double> aim_smoothing_s;
};

using CameraRig = std::variant<StaticRig, OrbitRig, EgoRig, FileRig, SwoopRig, DollyZoomRig, ZoomRig, ImportedRig>;

struct SceneCamera {
  std::string name;  // unique in the scene; names its output files
  int width = 960, height = 540;
  double hfov_deg = 80;  // imported tracks and files carry their own intrinsics
  CameraRig rig;         // default: a static camera framed on the actors
  // Seeded handheld shake on top of any rig (drawn from the scene's seed).
  std::optional<HandheldOptions> handheld;
};

// The actor an ego camera rides on, or -1 for the other kinds.
inline int rides_on(const SceneCamera& camera) {
  const EgoRig* ego = std::get_if<EgoRig>(&camera.rig);
  return ego ? ego->actor : -1;
}

// Dense per-pixel maps of a sequence (dense_maps.h), computed only when asked.
struct DenseOutputs {
  bool depth = false, normals = false, masks = false;
  bool exact = false;  // also the float32 maps as .npy beside the images
  bool any() const { return depth || normals || masks; }
};

// Files to write; an empty path asks for nothing. Vectors are empty or one entry per camera
// (trajectories, camera paths) or per actor (point caches, with the rest OBJ beside each).
struct SceneOutputs {
  std::vector<std::string> trajectories, camera_paths, point_caches;
  std::vector<std::string> previews;       // per camera: a PNG contact sheet (preview.h)
  std::vector<std::string> rest_objs;      // per actor with a point cache; empty: the cache's path with .obj
  std::vector<std::string> actor_reports;  // per actor: its retargeting report (JSON)
  // Every prop's mesh every frame, where it is (dynamic props move), as PC2 with the props' OBJ as
  // placed beside it (the same path with .obj): vertices numbered across the props in order.
  std::string prop_point_cache;
  std::string glb;     // the retargeted actor, with the first camera, as an animated GLB: one actor, no props
  std::string scene_glb;  // the whole scene as one GLB: every actor, prop and camera (mocap_io/scene_glb.h)
  std::string report;  // the scene's report (JSON)
  int points_per_actor = 5000;
  int prop_points = 0;  // tracked points on the props, shared by area
  bool body_points_only = false;  // no tracked points below the wrists (the fingers)
  bool compress = false;          // deflate the trajectory npz members
  int chunk_frames = 0;           // 0: about 16 MiB of output per chunk
  int threads = 1;                // skinning threads
  // Per camera: a sequence folder in the PointOdyssey layout (pointodyssey.h), with the dense maps
  // `dense` asks for.
  std::vector<std::string> sequences;
  DenseOutputs dense;
};

struct Scene {
  std::string name = "scene";
  std::string file;  // the scene file it was read from, if any: an input like the others
  double fps = 30;
  std::optional<double> seconds;
  std::uint64_t seed = 0;
  std::vector<SceneActor> actors;
  std::vector<Prop> props;
  std::optional<SceneForces> forces;
  std::optional<SceneScatter> scatter;
  std::vector<SceneCamera> cameras;
  SceneOutputs outputs;
};

// "DIR/trajectories_<camera>.npz", "DIR/camera_<camera>.json", "DIR/point_cache_<actor>.pc2"
// (and "DIR/props_point_cache.pc2" when the scene has props) and "DIR/report.json" for what
// `which` asks for.
// (and "DIR/retarget_<actor>.json")
struct OutputSelection {
  bool trajectories = true, camera_paths = true, point_caches = false, actor_reports = false, report = true;
  bool previews = false;  // DIR/preview_<camera>.png
  bool glb = false;       // DIR/scene.glb
  // pointodyssey: DIR/<scene>_<camera>/ sequence folders instead of DIR/trajectories_<camera>.npz
  enum class Layout { files, pointodyssey };
  Layout layout = Layout::files;
};
void set_outputs_in_folder(Scene& scene, const std::string& folder, const OutputSelection& which);

}  // namespace odyssey::scene
