// GCC 12 reports -Wmaybe-uninitialized inside its own AVX-512 intrinsics (_mm512_undefined_ps,
// GCC bug 105593, fixed in GCC 13) when the skinning kernel's intrinsics are inlined here. The
// diagnostic is tied to where the intrinsics are first included (through Eigen), so silence it
// for those headers only, as skeleton/body_model.cpp does; the project's own code keeps it.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <Eigen/Core>
#pragma GCC diagnostic pop

#include "skinning/lbs.h"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>

#include "skinning/glm_eigen.h"
#include "skinning/lbs_kernel.h"
#include "skinning/normals.h"
#include "skinning/worker_pool.h"

namespace odyssey::skinning {
namespace {

// The vertices of the subset with C non-zero weights; streams as kernel::GroupStreams describes.
struct InfluenceGroup {
  std::vector<glm::vec4> rest_positions;
  std::vector<glm::vec4> rest_normals;
  std::vector<std::uint32_t> palette_entries;
  std::vector<float> weights;
  std::vector<std::uint32_t> rows;

  kernel::GroupStreams streams() const {
    return {rest_positions.data(), rest_normals.data(), palette_entries.data(), weights.data(), rows.data()};
  }
};

// One item of work within a frame: vertices [begin, end) of the group of `influences` weights.
struct Block {
  int influences = 0;
  std::size_t begin = 0, end = 0;
};

// The checks skin_mesh_reference makes, once per mesh the subset uses, so the hot loop needs none.
void validate_mesh(const CharacterMesh& mesh, int joint_count) {
  const std::size_t vertex_count = mesh.positions.size(), slot_count = mesh.skin_joints.size();
  const auto fail = [&](const std::string& problem) {
    throw std::invalid_argument("mesh '" + mesh.name + "' " + problem);
  };
  if (mesh.inverse_bind.size() != slot_count) {
    fail("has " + std::to_string(slot_count) + " skin joints but " + std::to_string(mesh.inverse_bind.size()) +
         " inverse bind matrices");
  }
  if (mesh.influence_slots.size() != vertex_count || mesh.influence_weights.size() != vertex_count) {
    fail("has " + std::to_string(vertex_count) + " positions but " + std::to_string(mesh.influence_slots.size()) +
         " influence slot rows and " + std::to_string(mesh.influence_weights.size()) + " weight rows");
  }
  for (std::size_t k = 0; k < slot_count; ++k) {
    if (mesh.skin_joints[k] < 0 || mesh.skin_joints[k] >= joint_count) {
      fail("skin slot " + std::to_string(k) + " names joint " + std::to_string(mesh.skin_joints[k]) +
           ", but the skeleton has " + std::to_string(joint_count) + " joints");
    }
  }
  for (std::size_t v = 0; v < vertex_count; ++v) {
    for (const std::uint16_t slot : mesh.influence_slots[v]) {
      if (slot >= slot_count) {
        fail("vertex " + std::to_string(v) + " uses skin slot " + std::to_string(slot) + " of " +
             std::to_string(slot_count));
      }
    }
  }
}

void check_size(const char* what, std::size_t expected, std::size_t got) {
  if (expected != got) {
    throw std::invalid_argument(std::string("skinning: ") + what + " holds " + std::to_string(got) + " values, expected " +
                                std::to_string(expected));
  }
}

}  // namespace

struct LinearBlendSkinner::Layout {
  SkinningOptions options;
  int joint_count = 0;
  std::size_t vertex_count = 0;
  std::array<InfluenceGroup, 4> groups;  // groups[C - 1]: the vertices with C influences
  std::vector<Block> blocks;             // the items of one frame
  // Palette entry e: joint and inverse bind of one (mesh, skin slot) pair.
  std::vector<int> entry_joint;
  std::vector<Eigen::Matrix4d> entry_inverse_bind;
  std::vector<kernel::PaletteEntry> palettes;  // scratch: one chunk of frames x palette entries
  WorkerPool pool;

  explicit Layout(const SkinningOptions& o) : options(o), pool(o.threads) {}

  // palette[e] = [R | t](joint_e) inverse_bind_e, in double, then rounded to float.
  void build_palette(std::span<const RigidTransform<double>> joint_world, kernel::PaletteEntry* palette) const {
    for (std::size_t e = 0; e < entry_joint.size(); ++e) {
      const RigidTransform<double>& joint = joint_world[entry_joint[e]];
      Eigen::Matrix<double, 3, 4> world;
      world << joint.rotation, joint.translation;
      palette[e].matrix = to_glm_affine(world * entry_inverse_bind[e]);
    }
  }

  template <int C>
  void run_block(const Block& block, const kernel::PaletteEntry* palette, float* positions, float* normals) const {
    const kernel::GroupStreams streams = groups[C - 1].streams();
    if (normals != nullptr) {
      kernel::skin_block<C, true>(palette, streams, block.begin, block.end, positions, normals);
    } else {
      kernel::skin_block<C, false>(palette, streams, block.begin, block.end, positions, nullptr);
    }
  }

  void run_block(const Block& block, const kernel::PaletteEntry* palette, float* positions, float* normals) const {
    switch (block.influences) {
      case 1: run_block<1>(block, palette, positions, normals); break;
      case 2: run_block<2>(block, palette, positions, normals); break;
      case 3: run_block<3>(block, palette, positions, normals); break;
      default: run_block<4>(block, palette, positions, normals); break;  // 4
    }
  }
};

std::vector<MeshVertex> all_vertices(const Character& character) {
  std::vector<MeshVertex> vertices;
  for (std::size_t m = 0; m < character.meshes.size(); ++m) {
    for (std::size_t v = 0; v < character.meshes[m].positions.size(); ++v) {
      vertices.push_back({std::uint32_t(m), std::uint32_t(v)});
    }
  }
  return vertices;
}

LinearBlendSkinner::LinearBlendSkinner(const Character& character, std::span<const MeshVertex> vertices,
                                       SkinningOptions options) {
  if (options.threads < 1) {
    throw std::invalid_argument("skinning needs at least 1 thread, got " + std::to_string(options.threads));
  }
  layout_ = std::make_unique<Layout>(options);
  Layout& layout = *layout_;
  layout.joint_count = character.skeleton.joint_count();
  layout.vertex_count = vertices.size();

  // Meshes the subset uses: validated once, rest normals computed once.
  std::vector<bool> mesh_used(character.meshes.size(), false);
  for (const MeshVertex& item : vertices) {
    if (item.mesh >= character.meshes.size()) {
      throw std::invalid_argument("skinning subset names mesh " + std::to_string(item.mesh) + " of " +
                                  std::to_string(character.meshes.size()));
    }
    const CharacterMesh& mesh = character.meshes[item.mesh];
    if (item.vertex >= mesh.positions.size()) {
      throw std::invalid_argument("skinning subset names vertex " + std::to_string(item.vertex) + " of mesh '" +
                                  mesh.name + "', which has " + std::to_string(mesh.positions.size()));
    }
    if (!mesh_used[item.mesh]) validate_mesh(mesh, layout.joint_count);
    mesh_used[item.mesh] = true;
  }
  std::vector<std::vector<Eigen::Vector3f>> rest_normals(character.meshes.size());
  if (options.normals) {
    for (std::size_t m = 0; m < character.meshes.size(); ++m) {
      if (mesh_used[m]) rest_normals[m] = rest_vertex_normals(character.meshes[m]);
    }
  }

  // Palette entries in order of first use, then each vertex into the group of its influence count.
  std::map<std::pair<std::uint32_t, std::uint16_t>, std::uint32_t> entry_of;
  const auto palette_entry = [&](std::uint32_t mesh, std::uint16_t slot) {
    const auto [it, inserted] = entry_of.try_emplace({mesh, slot}, std::uint32_t(layout.entry_joint.size()));
    if (inserted) {
      layout.entry_joint.push_back(character.meshes[mesh].skin_joints[slot]);
      layout.entry_inverse_bind.push_back(character.meshes[mesh].inverse_bind[slot]);
    }
    return it->second;
  };
  for (std::size_t row = 0; row < vertices.size(); ++row) {
    const CharacterMesh& mesh = character.meshes[vertices[row].mesh];
    const std::size_t v = vertices[row].vertex;
    std::array<std::uint32_t, 4> entries{};
    std::array<float, 4> weights{};
    int count = 0;
    for (int i = 0; i < 4; ++i) {
      if (mesh.influence_weights[v][i] == 0.0f) continue;
      entries[count] = palette_entry(vertices[row].mesh, mesh.influence_slots[v][i]);
      weights[count++] = mesh.influence_weights[v][i];
    }
    if (count == 0) entries[count++] = palette_entry(vertices[row].mesh, mesh.influence_slots[v][0]);  // weight 0
    InfluenceGroup& group = layout.groups[count - 1];
    group.rest_positions.push_back(to_glm_point(mesh.positions[v]));
    if (options.normals) group.rest_normals.push_back(to_glm_direction(rest_normals[vertices[row].mesh][v]));
    group.palette_entries.insert(group.palette_entries.end(), entries.begin(), entries.begin() + count);
    group.weights.insert(group.weights.end(), weights.begin(), weights.begin() + count);
    group.rows.push_back(std::uint32_t(row));
  }
  for (int c = 1; c <= 4; ++c) {
    const std::size_t size = layout.groups[c - 1].rows.size();
    for (std::size_t begin = 0; begin < size; begin += kBlockVertices) {
      layout.blocks.push_back({c, begin, std::min(size, begin + kBlockVertices)});
    }
  }
}

LinearBlendSkinner::~LinearBlendSkinner() = default;
LinearBlendSkinner::LinearBlendSkinner(LinearBlendSkinner&&) noexcept = default;
LinearBlendSkinner& LinearBlendSkinner::operator=(LinearBlendSkinner&&) noexcept = default;

const SkinningOptions& LinearBlendSkinner::options() const { return layout_->options; }
std::size_t LinearBlendSkinner::vertex_count() const { return layout_->vertex_count; }
int LinearBlendSkinner::joint_count() const { return layout_->joint_count; }
std::size_t LinearBlendSkinner::palette_size() const { return layout_->entry_joint.size(); }

std::array<std::size_t, 4> LinearBlendSkinner::influence_histogram() const {
  std::array<std::size_t, 4> histogram{};
  for (int c = 0; c < 4; ++c) histogram[c] = layout_->groups[c].rows.size();
  return histogram;
}

void LinearBlendSkinner::parallel_for(std::size_t count, std::size_t work, const std::function<void(std::size_t)>& body) {
  if (work >= kMinSharedVertexFrames) {
    layout_->pool.run(count, body);
  } else {
    for (std::size_t i = 0; i < count; ++i) body(i);
  }
}

void LinearBlendSkinner::skin(std::span<const RigidTransform<double>> joint_world, std::span<float> positions,
                              std::span<float> normals) {
  skin_frames(1, joint_world, positions, normals);
}

void LinearBlendSkinner::skin_frames(std::size_t frames, std::span<const RigidTransform<double>> joint_world,
                                     std::span<float> positions, std::span<float> normals) {
  Layout& layout = *layout_;
  const std::size_t joints = std::size_t(layout.joint_count), floats_per_frame = 3 * layout.vertex_count;
  check_size("joint_world (frames x joints)", frames * joints, joint_world.size());
  check_size("positions (frames x vertices x 3)", frames * floats_per_frame, positions.size());
  if (!normals.empty()) {
    if (!layout.options.normals) {
      throw std::invalid_argument("skinning: normals asked of a skinner built without SkinningOptions::normals");
    }
    check_size("normals (frames x vertices x 3)", frames * floats_per_frame, normals.size());
  }
  const std::size_t entries = layout.entry_joint.size(), blocks = layout.blocks.size();
  for (std::size_t first = 0; first < frames; first += kChunkFrames) {
    const std::size_t chunk = std::min(kChunkFrames, frames - first);
    layout.palettes.resize(chunk * entries);
    const std::size_t work = chunk * layout.vertex_count;
    parallel_for(chunk, work, [&](std::size_t f) {
      layout.build_palette(joint_world.subspan((first + f) * joints, joints), layout.palettes.data() + f * entries);
    });
    parallel_for(chunk * blocks, work, [&](std::size_t item) {
      const std::size_t f = item / blocks, frame = first + f;
      float* frame_normals = normals.empty() ? nullptr : normals.data() + frame * floats_per_frame;
      layout.run_block(layout.blocks[item % blocks], layout.palettes.data() + f * entries,
                       positions.data() + frame * floats_per_frame, frame_normals);
    });
  }
}

}  // namespace odyssey::skinning
