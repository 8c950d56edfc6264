// What drives an actor. Three sources, each built into the same ActorMotion (a character and a
// clip on its skeleton at the request's rate), so the shot pipeline (pipeline.h) places, times,
// skins, tracks and writes every actor the same way:
//
//   motion     a BVH or AMASS motion retargeted onto a glTF character (actor.h, retarget_actor).
//   animation  a glTF character's own animation, played without retargeting: the file's
//              keyframes (LINEAR, STEP, CUBICSPLINE; translation, rotation, scale; channels on any
//              node, also above the skeleton) evaluated at every output frame
//              (skeleton/node_animation.h). Clip time 0 is the animation's first key; it plays once,
//              `loops` times, or loops for `seconds`.
//   anime      a DeformingThings4D .anime mesh (mocap_io/anime_file.h): no skeleton, every vertex
//              animated. Its character is one joint ("root") carrying one mesh; per frame the joint
//              sits at the mesh's horizontal centroid (x, y of the mean vertex, z = 0), unrotated,
//              and the vertices are stored relative to it (ActorMotion::vertex_animation), so that
//              placement turns and moves the whole mesh with the joint, and footprints and framing
//              follow the mesh. The file's frames (at source_fps) are kept as they are; the shot
//              interpolates them linearly at its own times.
//
// Conventions of the two new sources: the file's axes are Y up (glTF; DeformingThings4D, as
// exported) and are turned to the toolkit's Z up by (x, y, z) -> (x, -z, y); an anime file
// already Z up is read with up = z. `scale` multiplies lengths (the Fox is authored in
// centimetres: scale 0.01). The rest facing is the file's +Z, the glTF front (-Y in the world).
// The root joint (for footprints, framing and placement) is the topmost joint whose offset from
// its parent the animation moves (else the skeleton's first joint); the actor's heading turns with
// that joint's rotation from rest. Neither new source has a bone map: an ego camera needs a head,
// which they do not name, and body-only points keep every vertex.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "scene_layouts/actor.h"
#include "scene_layouts/timed_clip.h"
#include "skeleton/character.h"
#include "skeleton/clip.h"
#include "skeleton/mesh_animation.h"

namespace odyssey::scene {

enum class ActorSourceKind { motion, animation, anime };
const char* actor_source_name(ActorSourceKind kind);  // "motion", "animation", "anime"

// How long a played source lasts: once through (neither), `loops` times, or `seconds` (looping).
struct PlaybackLength {
  std::optional<int> loops;
  std::optional<double> seconds;
};

struct AnimationRequest {
  std::string character_path;
  std::string animation;  // its name in the file
  double fps = 30;        // the clip's rate (rounded up to a whole number of frames a pass)
  PlaybackLength length;
  double scale = 1;
};

struct AnimeRequest {
  std::string path;
  double source_fps = 30;  // the file's frame rate (the format does not store one)
  double fps = 30;         // the shot's: the played length is capped in its frames
  bool up_z = false;       // the file is already Z up
  PlaybackLength length;
  double scale = 1;
};

// What drives a scene actor: the request of its source (a motion to retarget, a character's own
// animation, a .anime mesh). prepare_shot (shot.h) builds each into an ActorMotion.
using ActorSource = std::variant<RetargetRequest, AnimationRequest, AnimeRequest>;

// An actor's motion, whatever its source.
struct ActorMotion {
  ActorSourceKind kind = ActorSourceKind::motion;
  Character character;
  // On character.skeleton, one pass through the source: a motion retargeted at the request's
  // rate; an animation from its first key to its last, at the request's rate rounded up so that
  // a frame falls on the last key; an anime file's frames at its rate.
  Clip clip;
  // How it plays (timed_clip.h): for `played_seconds` in all, wrapping with period
  // clip.duration() when `loops` (an animation or anime looped or played for seconds), else once.
  double played_seconds = 0;
  bool loops = false;
  // Anime: character.meshes[0]'s vertices every frame of `clip`, in joint 0's frame.
  std::shared_ptr<const MeshAnimation> vertex_animation;
  // Animation: its keys on the character, which the shot evaluates at each played time (the pass
  // in `clip` shows what it plays: its root, footprint and facing).
  std::shared_ptr<const NodeAnimationPlayer> keys;
  int root_joint = 0;
  Eigen::Vector3d rest_facing = -Eigen::Vector3d::UnitY();  // horizontal, unit
  int head_joint = -1;          // -1: none known
  std::vector<int> wrists;      // body-only points leave out these joints' subtrees
  std::shared_ptr<const RetargetedActor> retargeted;  // motion: the retargeting behind it
  std::string source_path;      // the file the actor's geometry comes from
  std::string description;      // one line: what was played
  std::vector<std::string> warnings;
  double seconds_to_build = 0;
};

// Builds the actor of an animation or anime request. Throws io::InputError naming the file (an
// animation the file does not have lists the names it has) or std::invalid_argument.
ActorMotion play_character_animation(const AnimationRequest& request, LoadCache* cache = nullptr);
ActorMotion play_anime(const AnimeRequest& request);
// The motion as it plays from its start, for its played length, at `fps` (the frames at k / fps
// up to played_seconds; timed_clip.h), unplaced. It shares the motion.
TimedClip played_clip(const std::shared_ptr<const ActorMotion>& motion, double fps);
// Wraps a retargeting (its clip, character and bone map's pelvis, hips, head and wrists).
ActorMotion retargeted_motion(std::shared_ptr<const RetargetedActor> retargeted);

// The actor's report: for a motion, actor_report_json of its retargeting; else its inputs, what
// was played and the warnings.
nlohmann::ordered_json actor_motion_report_json(const ActorMotion& motion);

}  // namespace odyssey::scene
