#include "skinning/body_character.h"

#include <algorithm>
#include <numeric>
#include <string>

#include "skeleton/rotation.h"

namespace odyssey::skinning {

Character body_character(const BodyModel& model, std::span<const double> betas) {
  BodyModelEvaluator evaluator(model);
  evaluator.set_shape(betas);
  const RowMatrixXd& rest_joints = evaluator.rest_joints();
  const RowMatrixXd& shaped = evaluator.shaped_vertices();
  const int joints = model.joint_count();

  std::vector<Eigen::Vector3d> offsets(joints);
  std::vector<Eigen::Quaterniond> rest_rotations(joints, Eigen::Quaterniond::Identity());
  offsets[0] = rest_joints.row(0).transpose();
  rest_rotations[0] = Eigen::Quaterniond(y_up_to_z_up());
  for (int j = 1; j < joints; ++j) offsets[j] = (rest_joints.row(j) - rest_joints.row(model.parents[j])).transpose();

  Character character;
  character.name = std::string(body_model_kind_name(model.kind)) + " body";
  character.skeleton = Skeleton(model.joint_names, model.parents, std::move(offsets), std::move(rest_rotations));
  character.source_node_of_joint.assign(joints, -1);
  character.source_scale_of_joint.assign(joints, 1.0);

  CharacterMesh mesh;
  mesh.name = "body";
  const int vertex_count = model.vertex_count();
  mesh.positions.reserve(vertex_count);
  for (int v = 0; v < vertex_count; ++v) mesh.positions.push_back(shaped.row(v).transpose().cast<float>());
  mesh.triangles.reserve(3 * std::size_t(model.faces.rows()));
  for (Eigen::Index f = 0; f < model.faces.rows(); ++f) {
    for (int c = 0; c < 3; ++c) mesh.triangles.push_back(std::uint32_t(model.faces(f, c)));
  }
  for (int j = 0; j < joints; ++j) {
    mesh.skin_joints.push_back(j);
    Eigen::Matrix4d inverse_bind = Eigen::Matrix4d::Identity();
    inverse_bind.block<3, 1>(0, 3) = -rest_joints.row(j).transpose();
    mesh.inverse_bind.push_back(inverse_bind);
  }

  // The four largest weights of each vertex (ties: the lower joint first), renormalised.
  int truncated = 0;
  mesh.influence_slots.resize(vertex_count);
  mesh.influence_weights.resize(vertex_count);
  std::vector<std::pair<double, int>> row;
  for (int v = 0; v < vertex_count; ++v) {
    row.clear();
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(model.weights, v); it; ++it) {
      if (it.value() != 0.0) row.emplace_back(it.value(), int(it.col()));
    }
    std::stable_sort(row.begin(), row.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    if (row.size() > 4) {
      ++truncated;
      row.resize(4);
    }
    const double total = std::accumulate(row.begin(), row.end(), 0.0, [](double s, const auto& w) { return s + w.first; });
    mesh.influence_slots[v] = {0, 0, 0, 0};
    mesh.influence_weights[v] = {0.0f, 0.0f, 0.0f, 0.0f};
    for (std::size_t k = 0; k < row.size(); ++k) {
      mesh.influence_slots[v][k] = std::uint16_t(row[k].second);
      mesh.influence_weights[v][k] = float(row[k].first / total);
    }
  }
  if (truncated > 0) {
    character.warnings.push_back(std::to_string(truncated) + " vertices have more than four skinning weights; the four " +
                                 "largest are kept and renormalised");
  }
  character.meshes.push_back(std::move(mesh));
  return character;
}

}  // namespace odyssey::skinning
