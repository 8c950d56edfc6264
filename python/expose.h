// The binding of each part of the library, one function per file (Pinocchio's expose-*.cpp), and
// the helpers they share.
#pragma once

#include <pybind11/pybind11.h>

#include <memory>
#include <optional>
#include <string>

#include "batch/batch.h"
#include "scene_layouts/actor.h"
#include "skeleton/character.h"
#include "skeleton/clip.h"

namespace odyssey::python {

namespace py = pybind11;

void expose_motion(py::module_& m);    // inspect, Motion (BVH), AMASS sequences, Character, BodyModel
void expose_retarget(py::module_& m);  // retarget, Retargeted (clip, world joints, report, skinning)
void expose_scene(py::module_& m);     // scenes into files or numpy arrays
void expose_batch(py::module_& m);     // batches with a progress callback
void expose_dataset(py::module_& m);   // datasets from recipes (when the dataset library is built)

// A motion on a skeleton (a BVH's, or a retargeted character's), shared with the arrays that view it.
struct MotionHandle {
  std::shared_ptr<const Clip> clip;
};

// A loaded character, shared with the retargetings that use it.
struct CharacterHandle {
  std::shared_ptr<const Character> character;
  std::string path;
};

// The world position of every joint in every frame, T x J x 3 (GIL released by the caller).
std::vector<double> world_joints(const Clip& clip);

// Every vertex of every mesh of `character`, skinned by `clip` (on its skeleton) at `frames`:
// F x V x 3 float32 (the point cache's numbers).
std::vector<float> skin_frames(const Character& character, const Clip& clip, const std::vector<int>& frames, int threads);

// The retargeting request the CLI's options build, from Python keywords (motion empty: a batch's
// defaults, without the checks that need the motion's kind). UsageError with the CLI's wording.
scene::RetargetRequest request_from(const std::string& motion, const std::string& character, const std::string& quality,
                                    double fps, const std::string& parts, const py::object& map,
                                    const py::object& source_map, const py::object& model, const std::string& betas,
                                    const py::object& bvh_units, const std::string& source_rest, const py::object& weights,
                                    const py::object& contact_lift, int threads);

// A batch's counts as the progress callbacks and results give them (finished: the job's record or None).
py::dict batch_counts(const batch::BatchProgress& progress);

// A batch's progress callback around a Python callable. An exception the callable raises is kept,
// not thrown into the batch (its worker processes would outlive it): the callable is not called
// again, the batch finishes its jobs, and rethrow() raises it then.
class BatchProgressRelay {
 public:
  explicit BatchProgressRelay(py::object callable) : callable_(std::move(callable)) {}
  // The callback to give the batch: empty when the callable is None.
  batch::BatchProgressCallback callback();
  void rethrow();

 private:
  py::object callable_;
  std::optional<py::error_already_set> failure_;
};

// BVH units: None (inferred), a name of io::kBvhUnits or metres per unit; UsageError otherwise.
std::optional<double> bvh_units_argument(const py::handle& units);

}  // namespace odyssey::python
