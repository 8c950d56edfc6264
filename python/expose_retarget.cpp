// Retargeting from Python: a motion file onto a character file at a quality, through the same
// scene::retarget_actor every command runs, so the numbers are the CLI's. The result keeps the
// C++ actor; its arrays view it.
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <filesystem>

#include "mocap_io/input_error.h"
#include "python/convert.h"
#include "python/expose.h"
#include "retarget/parts.h"
#include "retarget/refine.h"
#include "scene_layouts/actor.h"

namespace odyssey::python {
namespace {

struct RetargetedHandle {
  std::shared_ptr<const scene::RetargetedActor> actor;
  // Computed on first use and kept: forward kinematics over the clip, the report.
  std::optional<py::object> world_joints, report;
};

std::string weight_names() {
  std::string names;
  for (const retarget::RefineWeightName& entry : retarget::refine_weight_names()) names += (names.empty() ? "" : ", ") + std::string(entry.name);
  return names;
}

}  // namespace

// The request the CLI's retarget options build (cli/retarget_options.cpp), with the same checks
// and messages, the option names spelled as Python keywords.
scene::RetargetRequest request_from(const std::string& motion, const std::string& character, const std::string& quality_text,
                                    double fps, const std::string& parts_text, const py::object& map,
                                    const py::object& source_map, const py::object& model, const std::string& betas,
                                    const py::object& bvh_units, const std::string& source_rest, const py::object& weights,
                                    const py::object& contact_lift, int threads) {
  const auto quality = retarget::parse_quality(quality_text);
  if (!quality) throw UsageError("quality expects fast, balanced or accurate, got '" + quality_text + "'");
  scene::RetargetRequest request = scene::retarget_request(motion, character, *quality);
  if (!map.is_none()) request.map_path = path_argument(map, "map");
  if (!source_map.is_none()) request.source_map_path = path_argument(source_map, "source_map");
  if (!model.is_none()) request.model_path = path_argument(model, "model");
  const auto policy = parse_betas_policy(betas);
  if (!policy) throw UsageError("betas expects fit, truncate, pad or error, got '" + betas + "'");
  request.betas = *policy;
  const auto parts = retarget::parse_parts(parts_text);
  if (!parts) throw UsageError("parts expects body, body+hands or all, got '" + parts_text + "'");
  request.parts = *parts;
  if (!(fps > 0) || !std::isfinite(fps)) throw UsageError("fps must be positive");
  request.fps = fps;
  if (threads < 1 || threads > 1024) throw UsageError("threads expects 1 to 1024, got " + std::to_string(threads));
  request.refine_options.threads = threads;
  if (*quality == retarget::Quality::fast && (!weights.is_none() || !contact_lift.is_none())) {
    throw UsageError("weights and contact_lift set the refinement, which quality fast does not run (use balanced or accurate)");
  }
  if (!weights.is_none()) {
    if (!py::isinstance<py::dict>(weights)) throw UsageError("weights expects a dict NAME: VALUE; names: " + weight_names());
    for (const auto& [key, value] : py::reinterpret_borrow<py::dict>(weights)) {
      const std::string name = py::str(key);
      double* weight = retarget::refine_weight(request.refine_options.weights, name);
      if (!weight) throw UsageError("weights: unknown weight '" + name + "' (weights: " + weight_names() + ")");
      const double number = number_argument(value, "weights: " + name);
      if (!(number >= 0) || !std::isfinite(number)) throw UsageError("weights: " + name + " expects a finite number >= 0");
      *weight = number;
    }
  }
  if (!contact_lift.is_none()) {
    if (py::isinstance<py::str>(contact_lift) && contact_lift.cast<std::string>() == "off") {
      request.refine_options.contact_lift.reset();
    } else {
      const double lift = number_argument(contact_lift, "contact_lift");
      if (!(lift >= 0) || !std::isfinite(lift)) throw UsageError("contact_lift expects metres >= 0 or 'off'");
      request.refine_options.contact_lift = lift;
    }
  }
  if (source_rest == "rest") {
    request.options.source_rest = retarget::SourceRest::rest;
  } else if (source_rest == "first-frame") {
    request.options.source_rest = retarget::SourceRest::first_frame;
  } else {
    throw UsageError("source_rest expects rest or first-frame, got '" + source_rest + "'");
  }
  request.bvh_metres_per_unit = bvh_units_argument(bvh_units);
  if (motion.empty()) return request;
  const bool bvh = std::filesystem::path(motion).extension() == ".bvh";
  if (request.model_path && bvh) throw UsageError("model is for AMASS sequences; " + motion + " is a BVH file");
  if (betas != "fit" && bvh) throw UsageError("betas is for AMASS sequences; " + motion + " is a BVH file");
  if (request.bvh_metres_per_unit && !bvh) throw UsageError("bvh_units is for BVH files; " + motion + " is not one");
  return request;
}

namespace {

const char* kRetargetDoc =
    "Retargets a BVH or AMASS motion onto a rigged glTF/GLB/VRM character, as `odyssey retarget` does (same\n"
    "options, same numbers): quality 'fast', 'balanced' or 'accurate'; fps the rate the motion is resampled to;\n"
    "parts 'body', 'body+hands' or 'all'; map/source_map JSON bone maps over the found ones; model the body model\n"
    "for an AMASS motion (default: the synthetic SMPL-X); betas 'fit', 'truncate', 'pad' or 'error'; bvh_units;\n"
    "source_rest 'rest' or 'first-frame'; weights {name: value} over the quality's refinement weights;\n"
    "contact_lift metres or 'off'; threads for the refinement. The GIL is released while it runs.\n"
    "Raises InputError naming a bad file, UsageError for a bad option, Error otherwise.";

}  // namespace

void expose_retarget(py::module_& m) {
  py::class_<RetargetedHandle>(m, "Retargeted", "A motion retargeted onto a character, with its report.")
      .def_property_readonly(
          "motion",
          [](const RetargetedHandle& h) {
            // Shares ownership of the actor: the clip lives inside it.
            return MotionHandle{std::shared_ptr<const Clip>(h.actor, &h.actor->clip())};
          },
          "The character's motion (Motion): local rotations and root translation on the character's skeleton.")
      .def_property_readonly(
          "source", [](const RetargetedHandle& h) { return MotionHandle{std::shared_ptr<const Clip>(h.actor, &h.actor->source)}; },
          "The source motion as retargeted (resampled to fps, on the source skeleton).")
      .def_property_readonly(
          "character",
          [](const RetargetedHandle& h) {
            return CharacterHandle{std::shared_ptr<const Character>(h.actor, &h.actor->character), h.actor->request.character_path};
          })
      .def_property_readonly("fps", [](const RetargetedHandle& h) { return h.actor->clip().fps; })
      .def_property_readonly("frame_count", [](const RetargetedHandle& h) { return h.actor->clip().frame_count(); })
      .def_property_readonly("joint_names", [](const RetargetedHandle& h) { return h.actor->clip().skeleton.names(); })
      .def_property_readonly("parents", [](const RetargetedHandle& h) { return h.actor->clip().skeleton.parents(); })
      .def_property_readonly(
          "rotations", [](py::object self) -> py::object {
            py::object motion = self.attr("motion");
            return motion.attr("rotations");
          },
          "float64 [T, J, 4]: the character's local joint rotations, quaternions (x, y, z, w); a view, no copy")
      .def_property_readonly(
          "root_translation", [](py::object self) -> py::object {
            py::object motion = self.attr("motion");
            return motion.attr("root_translation");
          },
          "float64 [T, 3]: the root joint's local translation, metres, Z up; a view, no copy")
      .def_property_readonly(
          "world_joints",
          [](RetargetedHandle& h) {
            if (!h.world_joints) {
              std::vector<double> out;
              {
                py::gil_scoped_release release;
                out = world_joints(h.actor->clip());
              }
              h.world_joints = owning_array(std::move(out), {h.actor->clip().frame_count(), h.actor->clip().joint_count(), 3});
            }
            return *h.world_joints;
          },
          "float64 [T, J, 3]: the character's joints in world space every frame, metres, Z up")
      .def_property_readonly(
          "report",
          [](RetargetedHandle& h) {
            if (!h.report) h.report = to_python(scene::actor_report_json(*h.actor));
            return *h.report;
          },
          "The retargeting report as a dict (what `odyssey retarget --report` writes before the outputs: inputs,\n"
          "settings, maps, scale, metrics, refinement, timings)")
      .def(
          "skin",
          [](const RetargetedHandle& h, const py::object& frames, int threads) {
            const Clip& clip = h.actor->clip();
            std::vector<int> which;
            if (frames.is_none()) {
              which.resize(clip.frame_count());
              for (int f = 0; f < clip.frame_count(); ++f) which[f] = f;
            } else {
              if (!py::isinstance<py::iterable>(frames) || py::isinstance<py::str>(frames)) {
                throw ArrayError("frames: expected frame numbers (a list or an integer array), got " +
                                 std::string(py::str(py::type::of(frames).attr("__name__"))));
              }
              for (const auto& item : frames) {
                long long f = 0;
                try {
                  f = integer_argument(item, "frames");
                } catch (const UsageError& error) {
                  throw ArrayError(error.what());
                }
                if (f < 0 || f >= clip.frame_count()) {
                  throw ArrayError("frames: frame " + std::to_string(f) + " is outside [0, " + std::to_string(clip.frame_count()) + ")");
                }
                which.push_back(static_cast<int>(f));
              }
            }
            if (threads < 1 || threads > 1024) throw UsageError("threads expects 1 to 1024, got " + std::to_string(threads));
            std::size_t vertices = 0;
            for (const CharacterMesh& mesh : h.actor->character.meshes) vertices += mesh.positions.size();
            if (vertices == 0) throw io::InputError(h.actor->request.character_path, "the character has no mesh to skin");
            std::vector<float> out;
            {
              py::gil_scoped_release release;
              out = skin_frames(h.actor->character, clip, which, threads);
            }
            return owning_array(std::move(out), {py::ssize_t(which.size()), py::ssize_t(vertices), 3});
          },
          py::arg("frames") = py::none(), py::arg("threads") = 1,
          "float32 [F, V, 3]: every mesh vertex skinned (linear blend skinning, the point cache's numbers and vertex\n"
          "order) at the given frames (default: all), metres, Z up.")
      .def("__repr__", [](const RetargetedHandle& h) {
        return "<odyssey.Retargeted " + h.actor->request.motion_path + " onto " + h.actor->request.character_path + ", " +
               std::to_string(h.actor->clip().frame_count()) + " frames, " + retarget::quality_name(h.actor->request.quality) + ">";
      });

  m.def(
      "retarget",
      [](const py::object& motion, const py::object& character, const std::string& quality, double fps,
         const std::string& parts, const py::object& map, const py::object& source_map, const py::object& model,
         const std::string& betas, const py::object& bvh_units, const std::string& source_rest, const py::object& weights,
         const py::object& contact_lift, int threads) {
        const scene::RetargetRequest request =
            request_from(path_argument(motion, "motion"), path_argument(character, "character"), quality, fps, parts, map,
                         source_map, model, betas, bvh_units, source_rest, weights, contact_lift, threads);
        std::shared_ptr<const scene::RetargetedActor> actor;
        {
          py::gil_scoped_release release;
          actor = std::make_shared<const scene::RetargetedActor>(scene::retarget_actor(request));
        }
        return RetargetedHandle{std::move(actor), std::nullopt, std::nullopt};
      },
      py::arg("motion"), py::arg("character"), py::arg("quality") = "fast", py::kw_only(), py::arg("fps") = 30.0,
      py::arg("parts") = "body", py::arg("map") = py::none(), py::arg("source_map") = py::none(),
      py::arg("model") = py::none(), py::arg("betas") = "fit", py::arg("bvh_units") = py::none(),
      py::arg("source_rest") = "rest", py::arg("weights") = py::none(), py::arg("contact_lift") = py::none(),
      py::arg("threads") = 1, kRetargetDoc);

  // For bench/bench_python.py: the same C++ call timed in C++, in this process, `repeats` times.
  m.def(
      "_cpp_retarget_seconds",
      [](const std::string& motion, const std::string& character, const std::string& quality, int repeats) {
        const scene::RetargetRequest request = request_from(motion, character, quality, 30, "body", py::none(), py::none(),
                                                            py::none(), "fit", py::none(), "rest", py::none(), py::none(), 1);
        std::vector<double> seconds;
        py::gil_scoped_release release;
        for (int i = 0; i < repeats; ++i) {
          const auto start = std::chrono::steady_clock::now();
          scene::retarget_actor(request);  // and its result freed, as a caller's is in the end
          seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        }
        return seconds;
      },
      py::arg("motion"), py::arg("character"), py::arg("quality"), py::arg("repeats"));
}

}  // namespace odyssey::python
