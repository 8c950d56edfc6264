// A batch job and where jobs come from. A job is one scene run into its own folder: either a
// motion retargeted onto a character (a one-actor scene, the common case) or a scene file.
//
// Jobs from lists (`--motions PATH... --characters PATH...`): a PATH is a file, a folder (searched
// recursively for motion files .bvh/.npz, or characters .glb/.gltf/.vrm) or a glob. Every motion
// goes onto every character. A job's name, which is its folder under DIR/jobs, is
//   <character>/<motion>
// where each part is the file's path relative to the folder (or the glob's fixed leading folder)
// it was found through, without its extension; a file given by itself contributes its stem. So
// `--motions amass/` gives "Robot/CMU/01/01_01_poses" for amass/CMU/01/01_01_poses.npz. A
// character's bone map, when a file <character stem>.map.json lies beside it, is used as its --map.
//
// Jobs from a manifest (JSON: {"jobs": [ROW, ...]} or an array of rows; CSV: a header row then one
// row per job): a row names a motion and a character, or a scene file; optionally its name and
// per-job settings over the batch's (quality, fps, parts, bvh_units, betas, map, source_map,
// model, outputs). Relative paths are relative to the manifest. Errors name the manifest, the row
// (CSV: its line) and the column.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "scene_layouts/actor.h"

namespace odyssey::batch {

// Files each job writes into its folder.
struct JobOutputs {
  bool glb = true;            // animation.glb: the character animated, with the framing camera
  bool report = true;         // retarget.json: the retargeting report (maps, metrics, settings)
  bool trajectories = false;  // trajectories.npz and camera.json (a static camera framing the actor)
  bool point_cache = false;   // point_cache.pc2 and point_cache.obj
  bool preview = false;       // preview.png
};
// "glb,report,trajectories,point-cache,preview" (any subset, at least one); nothing on a bad name.
std::optional<JobOutputs> parse_job_outputs(const std::string& list);
std::string job_outputs_text(const JobOutputs& outputs);
inline constexpr const char* kJobOutputNames = "glb, report, trajectories, point-cache, preview";

// A job that does its own work (a dataset's sequence: dataset/). Its files are not one folder
// under DIR/jobs but any paths under DIR: run() writes them under `staging` at the relative paths
// they take under DIR and lists those paths in the record's "placed"; the worker then moves each
// onto DIR/<path> (a path there from the job's previous run is replaced, and one the new run does
// not place is removed), so each appears whole or not at all.
class JobTask {
 public:
  virtual ~JobTask() = default;
  virtual std::string kind() const = 0;  // the record's "kind"
  // What the outputs depend on besides the files inputs() names (settings, a recipe), for the key.
  virtual std::string key_text() const = 0;
  virtual std::vector<std::string> inputs() const = 0;
  // Returns the record's fields: "placed" (required), "frames", "metrics" and any of its own.
  // Throws with a one-line message when the job fails.
  virtual nlohmann::ordered_json run(const std::string& staging, scene::LoadCache& cache) const = 0;
};

struct Job {
  std::string name;        // its folder under DIR/jobs: '/'-separated, relative, no "." or ".." parts
  std::string scene_path;  // a scene job runs this file (its own outputs, into the job's folder)
  scene::RetargetRequest request;  // a retarget job: motion onto character
  JobOutputs outputs;
  std::string source;      // where the job came from, for errors: "lists" or "manifest.csv: line 4"
  std::shared_ptr<const JobTask> task;  // set: a job of its own kind (above); the fields before are unused
  // A task's paths under DIR from its last finished run (the batch fills this from the journal).
  std::vector<std::string> previously_placed;
};

// Every job of a batch shares these unless a manifest row says otherwise.
struct JobDefaults {
  scene::RetargetRequest request;  // motion and character paths empty
  JobOutputs outputs;
};

// Input files found through a list of PATHs: each with the name it contributes to job names.
struct FoundFile {
  std::string path, name;
};
// `extensions` lower case with the dot. Throws io::InputError naming the PATH when it does not
// exist, cannot be read, or (folder or glob) holds no file of the kind; `what` names the kind
// ("motion", "character") in the message.
std::vector<FoundFile> find_input_files(const std::vector<std::string>& paths, const std::vector<std::string>& extensions,
                                        const std::string& what);
inline const std::vector<std::string> kMotionExtensions{".bvh", ".npz"};
inline const std::vector<std::string> kCharacterExtensions{".glb", ".gltf", ".vrm"};

// The cross product, motions outer; throws io::InputError when two jobs would share a name.
std::vector<Job> cross_product_jobs(const std::vector<FoundFile>& motions, const std::vector<FoundFile>& characters,
                                    const JobDefaults& defaults);

// Throws io::InputError naming the manifest, the row and the column.
std::vector<Job> read_manifest(const std::string& path, const JobDefaults& defaults);

// Throws std::invalid_argument when two jobs would share a folder (names compared as normal_job_name
// makes them; the message names both jobs and where they came from), or a name is not a safe
// relative path (".", "..", absolute, a backslash, a control character such as a NUL).
void check_job_names(const std::vector<Job>& jobs);
// The folder a name makes: its parts joined by single slashes ("a//b" and "a/b/" are "a/b").
std::string normal_job_name(const std::string& name);

}  // namespace odyssey::batch
