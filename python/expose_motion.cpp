// Motions, characters and body models from Python: `inspect` as a dict, BVH clips as Motion,
// AMASS sequences as arrays, characters, and the body model's forward pass.
#include <pybind11/stl.h>

#include "mocap_io/amass.h"
#include "mocap_io/body_model_file.h"
#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "mocap_io/motion_file.h"
#include "python/convert.h"
#include "python/expose.h"
#include "retarget/inspect.h"
#include "skeleton/body_model.h"
#include "skinning/lbs.h"
#include "synthetic/synthetic_body.h"

namespace odyssey::python {
namespace {

using Json = nlohmann::ordered_json;

// An array viewing memory `owner` keeps alive, read-only: the C++ object is shared.
template <class T>
py::array view(const T* data, std::vector<py::ssize_t> shape, std::vector<py::ssize_t> strides, py::handle owner) {
  py::array array(py::dtype::of<T>(), shape, strides, data, owner);
  py::detail::array_proxy(array.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return array;
}

py::array owning_matrix(RowMatrixXd&& matrix) {
  const std::vector<py::ssize_t> shape = {matrix.rows(), matrix.cols()};
  auto* holder = new RowMatrixXd(std::move(matrix));
  py::capsule owner(holder, [](void* p) { delete static_cast<RowMatrixXd*>(p); });
  return py::array_t<double>(shape, holder->data(), owner);
}

// The body model's options and evaluation: joints T x J x 3 (float64) and vertices T x V x 3
// (float32, empty when not asked), batches of 64 frames (the pose correctives of a batch are one
// matrix product).
std::pair<std::vector<double>, std::vector<float>> body_forward(const BodyModel& model, const double* poses,
                                                               const double* translations, int frames,
                                                               std::span<const double> betas, std::span<const double> expression,
                                                               const BodyModelOptions& options, bool vertices) {
  const std::size_t J = model.joint_count(), V = model.vertex_count(), P = model.pose_size();
  std::vector<double> joints(std::size_t(frames) * J * 3);
  std::vector<float> mesh(vertices ? std::size_t(frames) * V * 3 : 0);
  BodyModelEvaluator evaluator(model, options);
  evaluator.set_shape(betas, expression);
  std::vector<double> zero_translations;
  if (!translations) {
    zero_translations.assign(std::size_t(frames) * 3, 0.0);
    translations = zero_translations.data();
  }
  constexpr int kBatch = 64;
  for (int first = 0; first < frames; first += kBatch) {
    const int count = std::min(kBatch, frames - first);
    evaluator.evaluate_batch(count, {poses + std::size_t(first) * P, std::size_t(count) * P},
                             {translations + std::size_t(first) * 3, std::size_t(count) * 3},
                             {joints.data() + std::size_t(first) * J * 3, std::size_t(count) * J * 3},
                             vertices ? std::span<float>(mesh.data() + std::size_t(first) * V * 3, std::size_t(count) * V * 3)
                                      : std::span<float>());
  }
  return {std::move(joints), std::move(mesh)};
}

struct BodyModelHandle {
  std::shared_ptr<const BodyModel> model;
  std::string description;
};

}  // namespace

std::optional<double> bvh_units_argument(const py::handle& units) {
  if (units.is_none()) return std::nullopt;
  if (py::isinstance<py::float_>(units) || py::isinstance<py::int_>(units)) {
    const double value = number_argument(units, "bvh_units");
    if (!(value > 0) || !std::isfinite(value)) throw UsageError("bvh_units: metres per unit must be positive, got " + std::to_string(value));
    return value;
  }
  if (py::isinstance<py::str>(units)) {
    const std::string text = units.cast<std::string>();
    if (text == "auto") return std::nullopt;
    if (const auto value = io::parse_bvh_units(text)) return value;
    throw UsageError("bvh_units expects " + std::string(io::kBvhUnitsHelp) + ", got '" + text + "'");
  }
  throw UsageError("bvh_units: expected None, a unit name or metres per unit");
}

std::vector<double> world_joints(const Clip& clip) {
  const std::size_t T = clip.frame_count(), J = clip.joint_count();
  std::vector<double> out(T * J * 3);
  std::vector<RigidTransform<double>> world(J);
  for (std::size_t f = 0; f < T; ++f) {
    clip.world_pose(static_cast<int>(f), world);
    for (std::size_t j = 0; j < J; ++j) {
      for (int c = 0; c < 3; ++c) out[(f * J + j) * 3 + c] = world[j].translation(c);
    }
  }
  return out;
}

std::vector<float> skin_frames(const Character& character, const Clip& clip, const std::vector<int>& frames, int threads) {
  const std::vector<skinning::MeshVertex> all = skinning::all_vertices(character);
  skinning::SkinningOptions options;
  options.threads = threads;
  skinning::LinearBlendSkinner skinner(character, all, options);
  const std::size_t J = clip.joint_count(), V = all.size();
  std::vector<RigidTransform<double>> world(frames.size() * J);
  for (std::size_t k = 0; k < frames.size(); ++k) {
    clip.world_pose(frames[k], std::span<RigidTransform<double>>(world.data() + k * J, J));
  }
  std::vector<float> positions(frames.size() * V * 3);
  skinner.skin_frames(frames.size(), world, positions);
  return positions;
}

void expose_motion(py::module_& m) {
  m.def(
      "inspect",
      [](const py::object& path, const py::object& bvh_units) {
        const std::string file = path_argument(path, "path");
        const std::optional<double> metres = bvh_units_argument(bvh_units);
        Json json;
        {
          py::gil_scoped_release release;
          json = retarget::inspect_file(file, metres);
        }
        return to_python(json);
      },
      py::arg("path"), py::arg("bvh_units") = py::none(),
      "What `odyssey inspect PATH` prints, as a dict: for a BVH its frames, fps, unit and joints; for an AMASS\n"
      "sequence its model, frames, fps, gender, betas and skipped keys; for a body model its sizes and joints; for\n"
      "an npz/npy its arrays; for a glTF/GLB/VRM character its skins, meshes, joints (with the canonical joint each\n"
      "plays), animations, rest height, rest pose kind and the bone map a retarget would use. Raises InputError.");

  py::class_<MotionHandle>(m, "Motion",
                           "A motion on a skeleton: per frame the local rotation of every joint and the local\n"
                           "translation of the translated joints (Z up, metres). Arrays view the motion (read-only).")
      .def_property_readonly("fps", [](const MotionHandle& h) { return h.clip->fps; })
      .def_property_readonly("frame_count", [](const MotionHandle& h) { return h.clip->frame_count(); })
      .def_property_readonly("joint_names", [](const MotionHandle& h) { return h.clip->skeleton.names(); })
      .def_property_readonly("parents", [](const MotionHandle& h) { return h.clip->skeleton.parents(); })
      .def_property_readonly("translated_joints", [](const MotionHandle& h) { return h.clip->translated_joints; })
      .def_property_readonly(
          "rotations",
          [](py::object self) {
            const Clip& clip = *self.cast<const MotionHandle&>().clip;
            const py::ssize_t T = clip.frame_count(), J = clip.joint_count();
            // Eigen::Quaterniond stores (x, y, z, w) contiguously: a [T, J, 4] view, no copy.
            return view(clip.rotations.empty() ? nullptr : clip.rotations.front().coeffs().data(), {T, J, 4},
                        {py::ssize_t(J * sizeof(Eigen::Quaterniond)), py::ssize_t(sizeof(Eigen::Quaterniond)), py::ssize_t(sizeof(double))},
                        self);
          },
          "float64 [T, J, 4]: local rotations as unit quaternions (x, y, z, w), replacing each joint's rest rotation")
      .def_property_readonly(
          "translations",
          [](py::object self) {
            const Clip& clip = *self.cast<const MotionHandle&>().clip;
            const py::ssize_t T = clip.frame_count(), K = clip.translated_joints.size();
            return view(clip.translations.empty() ? nullptr : clip.translations.front().data(), {T, K, 3},
                        {py::ssize_t(K * sizeof(Eigen::Vector3d)), py::ssize_t(sizeof(Eigen::Vector3d)), py::ssize_t(sizeof(double))},
                        self);
          },
          "float64 [T, K, 3]: local translations of translated_joints (K of them; the root first), metres")
      .def_property_readonly(
          "root_translation",
          [](py::object self) {
            const Clip& clip = *self.cast<const MotionHandle&>().clip;
            const py::ssize_t T = clip.frame_count(), K = clip.translated_joints.size();
            if (K == 0) throw UsageError("root_translation: the motion translates no joint");
            return view(clip.translations.front().data(), {T, 3},
                        {py::ssize_t(K * sizeof(Eigen::Vector3d)), py::ssize_t(sizeof(double))}, self);
          },
          "float64 [T, 3]: the first translated joint's (the root's) local translation, metres")
      .def(
          "world_joints",
          [](const MotionHandle& h) {
            std::vector<double> out;
            {
              py::gil_scoped_release release;
              out = world_joints(*h.clip);
            }
            return owning_array(std::move(out), {h.clip->frame_count(), h.clip->joint_count(), 3});
          },
          "float64 [T, J, 3]: every joint's world position every frame (forward kinematics), metres, Z up")
      .def(
          "resampled",
          [](const MotionHandle& h, double fps) {
            if (!(fps > 0) || !std::isfinite(fps)) throw UsageError("fps must be positive, got " + std::to_string(fps));
            py::gil_scoped_release release;
            return MotionHandle{std::make_shared<const Clip>(h.clip->resampled(fps))};
          },
          py::arg("fps"), "The motion at another frame rate (slerp for rotations, linear for translations).")
      .def("__repr__", [](const MotionHandle& h) {
        return "<odyssey.Motion " + std::to_string(h.clip->frame_count()) + " frames at " + std::to_string(h.clip->fps) +
               " fps, " + std::to_string(h.clip->joint_count()) + " joints>";
      });

  m.def(
      "load_bvh",
      [](const py::object& path, const py::object& bvh_units) {
        const std::string file = path_argument(path, "path");
        const std::optional<double> metres = bvh_units_argument(bvh_units);
        py::gil_scoped_release release;
        // As the commands do: what the file is first, so a missing file reads as theirs.
        if (io::detect_motion_file(file) != io::MotionFileKind::Bvh) throw io::InputError(file, "not a BVH file");
        io::LoadedBvh loaded = io::load_bvh_inferring_frame(file, metres);
        return MotionHandle{std::make_shared<const Clip>(std::move(loaded.clip))};
      },
      py::arg("path"), py::arg("bvh_units") = py::none(),
      "A BVH file as a Motion, converted to Z up and metres (bvh_units: None infers the unit, or a name such as\n"
      "'cmu', 'cm', or metres per unit). Raises InputError naming the file.");

  m.def(
      "load_amass",
      [](const py::object& path) {
        const std::string file = path_argument(path, "path");
        io::AmassFile loaded;
        {
          py::gil_scoped_release release;
          if (io::detect_motion_file(file) != io::MotionFileKind::Amass) throw io::InputError(file, "not an AMASS sequence");
          loaded = io::load_amass_file(file);
        }
        BodySequence& s = loaded.sequence;
        py::dict out;
        out["model"] = body_model_kind_name(s.kind);
        out["gender"] = s.gender;
        out["fps"] = s.fps;
        out["betas"] = owning_array(std::move(s.betas), {py::ssize_t(s.betas.size())});
        out["poses"] = owning_matrix(std::move(s.poses));
        out["trans"] = owning_matrix(std::move(s.translations));
        out["pose_keys"] = loaded.pose_keys;
        out["frame_rate_key"] = loaded.frame_rate_key;
        out["keys_skipped"] = loaded.skipped_keys;
        return out;
      },
      py::arg("path"),
      "An AMASS-style sequence: dict with 'poses' float64 [T, 3J] axis-angle (split keys joined), 'trans' [T, 3],\n"
      "'betas', 'gender', 'fps', 'model' ('SMPL-X', 'SMPL-H' ...), and the keys read and skipped. Raises InputError.");

  py::class_<CharacterHandle>(m, "Character", "A rigged glTF/GLB/VRM character in odyssey's world (Z up, metres).")
      .def(py::init([](const py::object& path) {
             const std::string file = path_argument(path, "path");
             py::gil_scoped_release release;
             return CharacterHandle{std::make_shared<const Character>(io::load_character(file)), file};
           }),
           py::arg("path"), "Loads a .glb, .gltf or .vrm character. Raises InputError naming the file.")
      .def_property_readonly("name", [](const CharacterHandle& h) { return h.character->name; })
      .def_property_readonly("path", [](const CharacterHandle& h) { return h.path; })
      .def_property_readonly("joint_names", [](const CharacterHandle& h) { return h.character->skeleton.names(); })
      .def_property_readonly("parents", [](const CharacterHandle& h) { return h.character->skeleton.parents(); })
      .def_property_readonly("vertex_count", [](const CharacterHandle& h) {
        std::size_t n = 0;
        for (const CharacterMesh& mesh : h.character->meshes) n += mesh.positions.size();
        return n;
      })
      .def_property_readonly(
          "rest_vertices",
          [](const CharacterHandle& h) {
            std::vector<float> out;
            for (const CharacterMesh& mesh : h.character->meshes) {
              for (const Eigen::Vector3f& p : mesh.positions) out.insert(out.end(), {p.x(), p.y(), p.z()});
            }
            const py::ssize_t n = out.size() / 3;
            return owning_array(std::move(out), {n, 3});
          },
          "float32 [V, 3]: every mesh's vertices as stored (mesh space), meshes in order (the point cache's order)")
      .def_property_readonly(
          "triangles",
          [](const CharacterHandle& h) {
            std::vector<std::uint32_t> out;
            std::uint32_t offset = 0;
            for (const CharacterMesh& mesh : h.character->meshes) {
              for (std::uint32_t v : mesh.triangles) out.push_back(offset + v);
              offset += static_cast<std::uint32_t>(mesh.positions.size());
            }
            const py::ssize_t n = out.size() / 3;
            return owning_array(std::move(out), {n, 3});
          },
          "uint32 [F, 3]: triangles as indices into the vertices numbered across the meshes in order")
      .def(
          "summary",
          [](const CharacterHandle& h) {
            Json json;
            {
              py::gil_scoped_release release;
              json = retarget::character_summary(*h.character, h.path);
            }
            return to_python(json);
          },
          "inspect()'s dict for this character.")
      .def("__repr__", [](const CharacterHandle& h) {
        return "<odyssey.Character '" + h.character->name + "', " + std::to_string(h.character->skeleton.joint_count()) + " joints>";
      });

  py::class_<BodyModelHandle>(m, "BodyModel",
                              "An SMPL / SMPL-H / SMPL-X body model (the smplx package's npz layout) and its forward pass.")
      .def(py::init([](const py::object& path) {
             const std::string file = path_argument(path, "path");
             py::gil_scoped_release release;
             return BodyModelHandle{std::make_shared<const BodyModel>(io::load_body_model(file)), file};
           }),
           py::arg("path"), "Loads a body model npz. Raises InputError naming the file.")
      .def_static(
          "synthetic",
          [](unsigned seed, bool dense) {
            py::gil_scoped_release release;
            return BodyModelHandle{std::make_shared<const BodyModel>(make_synthetic_body(seed, dense).model),
                                   "synthetic SMPL-X, seed " + std::to_string(seed)};
          },
          py::arg("seed") = 0, py::arg("dense") = false,
          "The synthetic SMPL-X body `odyssey make-body` writes (10,475 vertices; dense: the benchmark's denser one).")
      .def_property_readonly("kind", [](const BodyModelHandle& h) { return body_model_kind_name(h.model->kind); })
      .def_property_readonly("joint_names", [](const BodyModelHandle& h) { return h.model->joint_names; })
      .def_property_readonly("parents", [](const BodyModelHandle& h) { return h.model->parents; })
      .def_property_readonly("vertex_count", [](const BodyModelHandle& h) { return h.model->vertex_count(); })
      .def_property_readonly("pose_size", [](const BodyModelHandle& h) { return h.model->pose_size(); })
      .def_property_readonly("shape_count", [](const BodyModelHandle& h) { return h.model->shape_count; })
      .def_property_readonly("expression_count", [](const BodyModelHandle& h) { return h.model->expression_count; })
      .def_property_readonly("faces", [](const BodyModelHandle& h) {
        const RowMatrixXi& f = h.model->faces;
        return owning_array(std::vector<std::int32_t>(f.data(), f.data() + f.size()), {f.rows(), 3});
      }, "int32 [F, 3]")
      .def(
          "forward",
          [](const BodyModelHandle& h, const py::object& poses, const py::object& trans, const py::object& betas,
             const py::object& expression, bool hands, bool face, bool correctives, bool vertices) {
            const BodyModel& model = *h.model;
            const auto p = checked_array<double>(poses, "poses", {-1, model.pose_size()});
            const int T = static_cast<int>(p.shape(0));
            std::optional<py::array_t<double, py::array::c_style>> t, b, e;
            if (!trans.is_none()) t = checked_array<double>(trans, "trans", {T, 3});
            if (!betas.is_none()) b = checked_array<double>(betas, "betas", {-1});
            if (!expression.is_none()) e = checked_array<double>(expression, "expression", {-1});
            if (b && b->shape(0) > model.shape_count) {
              throw ArrayError("betas: expected at most " + std::to_string(model.shape_count) + " values, got shape " +
                               shape_text({b->shape(0)}));
            }
            if (e && e->shape(0) > model.expression_count) {
              throw ArrayError("expression: expected at most " + std::to_string(model.expression_count) +
                               " values, got shape " + shape_text({e->shape(0)}));
            }
            BodyModelOptions options;
            options.hands = hands;
            options.face = face;
            options.pose_correctives = correctives;
            std::pair<std::vector<double>, std::vector<float>> result;
            {
              py::gil_scoped_release release;
              result = body_forward(model, p.data(), t ? t->data() : nullptr, T,
                                    b ? std::span<const double>(b->data(), b->shape(0)) : std::span<const double>(),
                                    e ? std::span<const double>(e->data(), e->shape(0)) : std::span<const double>(), options,
                                    vertices);
            }
            py::object mesh = py::none();
            if (vertices) mesh = owning_array(std::move(result.second), {T, model.vertex_count(), 3});
            return py::make_tuple(owning_array(std::move(result.first), {T, model.joint_count(), 3}), mesh);
          },
          py::arg("poses"), py::arg("trans") = py::none(), py::arg("betas") = py::none(), py::arg("expression") = py::none(),
          py::kw_only(), py::arg("hands") = true, py::arg("face") = true, py::arg("correctives") = true,
          py::arg("vertices") = true,
          "The forward pass (the smplx package's): poses float64 [T, pose_size] axis-angle in model joint order\n"
          "(hands as full 45-D), trans float64 [T, 3] (default 0), betas [<= shape_count], expression\n"
          "[<= expression_count]. Returns (joints float64 [T, J, 3], vertices float32 [T, V, 3] or None).\n"
          "Wrong shapes or dtypes raise ValueError naming the argument.")
      .def("__repr__", [](const BodyModelHandle& h) {
        return "<odyssey.BodyModel " + std::string(body_model_kind_name(h.model->kind)) + ", " +
               std::to_string(h.model->vertex_count()) + " vertices (" + h.description + ")>";
      });
}

}  // namespace odyssey::python
