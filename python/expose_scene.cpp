// Scenes from Python: a scene file or a dict in the scene file's layout (docs/scenes.md), run into
// files as `odyssey scene` does, or into numpy arrays in memory: per camera the trajectory file's
// arrays (scene::TrajectoryMemorySink), the same values the CLI writes.
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <chrono>
#include <filesystem>

#include "python/convert.h"
#include "python/expose.h"
#include "scene_layouts/memory_sink.h"
#include "scene_layouts/pipeline.h"
#include "scene_layouts/scene_file.h"

namespace odyssey::python {
namespace {

namespace fs = std::filesystem;

// A scene file's path or a dict; a dict's relative paths are relative to base_dir (default: the
// working folder), and its errors name "scene" (or base_dir/scene) as a file's name them.
scene::SceneFile scene_argument(const py::handle& scene, const py::object& base_dir) {
  if (py::isinstance<py::dict>(scene)) {
    const std::string text = from_python(scene, "scene").dump();
    const std::string label = base_dir.is_none() ? "scene" : (fs::path(path_argument(base_dir, "base_dir")) / "scene").string();
    return scene::parse_scene(text, label);
  }
  if (!base_dir.is_none()) throw UsageError("base_dir is for a scene given as a dict; a file's paths are relative to it");
  return scene::read_scene_file(path_argument(scene, "scene"));
}

// The Python progress callback, called with the GIL held; a Python error it raises ends the run.
// The library copies callbacks freely while the GIL is released: the copies share one reference,
// dropped under the GIL.
scene::ProgressCallback progress_callback(const py::object& progress) {
  if (progress.is_none()) return {};
  if (!PyCallable_Check(progress.ptr())) throw UsageError("progress expects a callable taking one dict, or None");
  std::shared_ptr<py::object> callable(new py::object(progress), [](py::object* object) {
    py::gil_scoped_acquire acquire;
    delete object;
  });
  return [callable](const scene::ProgressEvent& event) {
    py::gil_scoped_acquire acquire;
    py::dict info;
    info["stage"] = event.stage;
    info["message"] = event.message;
    info["done"] = event.done;
    info["total"] = event.total;
    (*callable)(info);
  };
}

struct ArraysRun {
  std::vector<std::string> cameras;
  std::vector<scene::TrajectoryArrays> arrays;
  nlohmann::ordered_json report;
};

// The shot's frame loop into one memory sink per camera (run_sinks' loop with every camera tracking).
ArraysRun run_arrays(const scene::Scene& scene, const scene::ProgressCallback& progress) {
  const auto started = std::chrono::steady_clock::now();
  scene::PrepareOptions prepare;
  prepare.sample_points = true;
  scene::SceneResult result;
  static_cast<scene::Shot&>(result) = scene::prepare_shot(scene, prepare, progress);
  result.seconds.retarget = result.retarget_seconds;
  const std::vector<scene::StreamActor> actors = scene::stream_actors(result);
  const std::vector<scene::StreamCamera> cameras = scene::stream_cameras(result);
  const scene::StreamProps* props = scene::stream_props(result);
  const io::TrajectoryFileHeader header = scene::trajectory_file_header(actors, props, result.frames, result.fps);
  if (header.points == 0) throw std::invalid_argument("scene: trajectories asked for, but no points to track");
  std::vector<std::unique_ptr<scene::TrajectoryMemorySink>> sinks;
  std::vector<scene::StreamSink*> pointers;
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    sinks.push_back(std::make_unique<scene::TrajectoryMemorySink>(static_cast<int>(c), header));
    pointers.push_back(sinks.back().get());
  }
  scene::StreamOptions options;
  options.chunk_frames = scene.outputs.chunk_frames;
  options.threads = scene.outputs.threads;
  const auto on_chunk = [&](int done, int total) {
    if (progress) progress(scene::ProgressEvent{"export", std::to_string(done) + " of " + std::to_string(total) + " frames", nullptr, done, total});
  };
  const auto loop_start = std::chrono::steady_clock::now();
  result.streams = scene::run_frame_loop(actors, props, cameras, pointers, options, on_chunk);
  ArraysRun run;
  for (std::size_t c = 0; c < sinks.size(); ++c) {
    sinks[c]->finish(result);
    run.cameras.push_back(result.cameras[c].name);
    run.arrays.push_back(sinks[c]->take());
  }
  const auto now = std::chrono::steady_clock::now();
  result.seconds.streams = std::chrono::duration<double>(now - loop_start).count();
  result.seconds.total = std::chrono::duration<double>(now - started).count();
  run.report = scene::scene_report_json(result);
  return run;
}

py::dict arrays_dict(scene::TrajectoryArrays&& a) {
  const py::ssize_t T = a.frames, N = a.points;
  const py::dtype boolean("bool");
  py::dict out;
  out["trajs_3d"] = owning_array(std::move(a.trajs_3d), {T, N, 3});
  out["trajs_2d"] = owning_array(std::move(a.trajs_2d), {T, N, 2});
  out["visibs"] = owning_array(std::move(a.visibs), {T, N}, boolean);
  out["valids"] = owning_array(std::move(a.valids), {T, N}, boolean);
  out["intrinsics"] = owning_array(std::move(a.intrinsics), {T, 3, 3});
  out["extrinsics"] = owning_array(std::move(a.extrinsics), {T, 4, 4});
  out["point_vertex_ids"] = owning_array(std::move(a.point_vertex_ids), {N, 3});
  out["point_barycentric"] = owning_array(std::move(a.point_barycentric), {N, 3});
  out["point_actor_ids"] = owning_array(std::move(a.point_actor_ids), {N});
  out["visibility_codes"] = owning_array(std::move(a.visibility_codes), {T, N});
  out["fps"] = py::array_t<double>(std::vector<py::ssize_t>{}, &a.fps);  // a 0-d array, as np.load gives
  return out;
}

scene::OutputSelection::Layout layout_argument(const std::string& layout) {
  if (layout == "files") return scene::OutputSelection::Layout::files;
  if (layout == "pointodyssey") return scene::OutputSelection::Layout::pointodyssey;
  throw UsageError("layout expects files or pointodyssey, got '" + layout + "'");
}

scene::SceneResult run_files(scene::SceneFile file, const std::string& out, const std::optional<std::string>& layout,
                             const scene::ProgressCallback& progress) {
  if (layout) file.outputs.layout = layout_argument(*layout);
  fs::create_directories(out);
  scene::set_outputs_in_folder(file.scene, out, file.outputs);
  return scene::run_scene(file.scene, progress);
}

}  // namespace

void expose_scene(py::module_& m) {
  m.def(
      "example_scene",
      []() {
        const std::string text = scene::example_scene_json();
        return py::module_::import("json").attr("loads")(text);
      },
      "The bundled indoor scene (`odyssey scene --example`) as a dict; its 'data:' paths run from any folder.");

  m.def(
      "run_scene",
      [](const py::object& scene, const py::object& out, const py::object& layout, const py::object& base_dir,
         const py::object& progress) {
        std::optional<std::string> layout_text;
        if (!layout.is_none()) {
          layout_text = text_argument(layout, "layout");
          layout_argument(*layout_text);  // refused before anything is read
        }
        const std::string folder = path_argument(out, "out");
        scene::SceneFile file = scene_argument(scene, base_dir);
        const scene::ProgressCallback callback = progress_callback(progress);
        nlohmann::ordered_json report;
        {
          py::gil_scoped_release release;
          report = scene::scene_report_json(run_files(std::move(file), folder, layout_text, callback));
        }
        return to_python(report);
      },
      py::arg("scene"), py::arg("out"), py::kw_only(), py::arg("layout") = py::none(), py::arg("base_dir") = py::none(),
      py::arg("progress") = py::none(),
      "Runs a scene (a scene file's path, or a dict in that layout) into the folder `out`, as\n"
      "`odyssey scene SCENE --out OUT [--layout files|pointodyssey]` does, and returns the scene's report as a\n"
      "dict (its 'outputs' list the files). progress, when given, is called with dicts {stage, message, done,\n"
      "total}. A dict's relative paths are relative to base_dir (default: the working folder). On any error\n"
      "nothing is written. Raises InputError, UsageError or Error with the CLI's message.");

  m.def(
      "scene_arrays",
      [](const py::object& scene, const py::object& base_dir, const py::object& progress) {
        scene::SceneFile file = scene_argument(scene, base_dir);
        const scene::ProgressCallback callback = progress_callback(progress);
        ArraysRun run;
        {
          py::gil_scoped_release release;
          run = run_arrays(file.scene, callback);
        }
        py::dict cameras;
        for (std::size_t c = 0; c < run.cameras.size(); ++c) cameras[py::str(run.cameras[c])] = arrays_dict(std::move(run.arrays[c]));
        py::dict out;
        out["cameras"] = cameras;
        out["report"] = to_python(run.report);
        return out;
      },
      py::arg("scene"), py::kw_only(), py::arg("base_dir") = py::none(), py::arg("progress") = py::none(),
      "Runs a scene's tracked points in memory: {'cameras': {name: arrays}, 'report': dict}, where arrays holds\n"
      "every key of the trajectories_<camera>.npz `odyssey scene` writes (trajs_3d float32 [T, N, 3], trajs_2d\n"
      "[T, N, 2], visibs and valids bool [T, N], intrinsics [T, 3, 3], extrinsics [T, 4, 4], visibility_codes\n"
      "uint8 [T, N], point_vertex_ids int32 [N, 3], point_barycentric float32 [N, 3], point_actor_ids int32 [N],\n"
      "fps) with identical values, for every camera whatever the scene's outputs select. Arrays own their memory\n"
      "(no copy). The scene's other outputs are not written.");

  // For bench/bench_python.py: the same C++ calls timed in C++, in this process.
  m.def(
      "_cpp_scene_seconds",
      [](const std::string& path, const std::string& out, bool arrays, int repeats) {
        std::vector<double> seconds;
        py::gil_scoped_release release;
        for (int i = 0; i < repeats; ++i) {
          const auto start = std::chrono::steady_clock::now();
          scene::SceneFile file = scene::read_scene_file(path);
          if (arrays) {
            const ArraysRun run = run_arrays(file.scene, {});
          } else {
            run_files(std::move(file), out, std::nullopt, {});
          }
          seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        }
        return seconds;
      },
      py::arg("path"), py::arg("out"), py::arg("arrays"), py::arg("repeats"));
}

}  // namespace odyssey::python
