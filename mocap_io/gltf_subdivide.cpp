#include "mocap_io/gltf_subdivide.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <stdexcept>
#include <unordered_map>
#include <vector>

#include "mocap_io/input_error.h"

namespace odyssey::io {
namespace {

bool keep_image_bytes(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;  // images are carried over as stored, never decoded
}

// One vertex attribute as doubles, `width` components a vertex.
struct Attribute {
  std::string name;
  int width = 0;
  std::vector<double> values;
};

struct Primitive {
  std::vector<Attribute> attributes;                   // everything but JOINTS_n and WEIGHTS_n
  std::vector<std::vector<Attribute>> targets;         // morph targets, as displacements
  std::vector<std::vector<std::uint32_t>> joints;      // per JOINTS_n set, 4 a vertex
  std::vector<std::vector<double>> weights;            // per WEIGHTS_n set, 4 a vertex
  std::vector<std::uint32_t> triangles;
  std::size_t vertices = 0;
};

int component_count(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    default: return 0;
  }
}

// Accessor `index` as doubles (normalised integers mapped to [0, 1] or [-1, 1] as glTF defines).
std::vector<double> read_accessor(const tinygltf::Model& model, int index, const std::string& path, const std::string& what) {
  if (index < 0 || index >= static_cast<int>(model.accessors.size()))
    throw InputError(path, what + " names accessor " + std::to_string(index) + ", which does not exist");
  const tinygltf::Accessor& accessor = model.accessors[index];
  const int width = component_count(accessor.type);
  if (width == 0) throw InputError(path, what + " (accessor " + std::to_string(index) + ") is not a scalar or vector");
  if (accessor.sparse.isSparse)
    throw InputError(path, what + " (accessor " + std::to_string(index) + ") is sparse, which is not supported here");
  std::vector<double> out(accessor.count * width, 0.0);
  if (accessor.bufferView < 0) return out;  // all zeros, as glTF defines
  const tinygltf::BufferView& view = model.bufferViews.at(accessor.bufferView);
  const std::vector<unsigned char>& buffer = model.buffers.at(view.buffer).data;
  const int size = tinygltf::GetComponentSizeInBytes(accessor.componentType);
  if (size <= 0) throw InputError(path, what + " has an unknown component type");
  const std::size_t stride = view.byteStride ? view.byteStride : static_cast<std::size_t>(size) * width;
  const std::size_t start = view.byteOffset + accessor.byteOffset;
  if (accessor.count > 0 && start + stride * (accessor.count - 1) + std::size_t(size) * width > buffer.size())
    throw InputError(path, what + " (accessor " + std::to_string(index) + ") reads past the end of its buffer");
  for (std::size_t i = 0; i < accessor.count; ++i) {
    const unsigned char* element = buffer.data() + start + i * stride;
    for (int c = 0; c < width; ++c) {
      const unsigned char* at = element + c * size;
      double value = 0;
      switch (accessor.componentType) {
        case TINYGLTF_COMPONENT_TYPE_FLOAT: { float f; std::memcpy(&f, at, 4); value = f; break; }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: value = at[0]; if (accessor.normalized) value /= 255.0; break;
        case TINYGLTF_COMPONENT_TYPE_BYTE: { std::int8_t b; std::memcpy(&b, at, 1); value = accessor.normalized ? std::max(b / 127.0, -1.0) : b; break; }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: { std::uint16_t s; std::memcpy(&s, at, 2); value = accessor.normalized ? s / 65535.0 : s; break; }
        case TINYGLTF_COMPONENT_TYPE_SHORT: { std::int16_t s; std::memcpy(&s, at, 2); value = accessor.normalized ? std::max(s / 32767.0, -1.0) : s; break; }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: { std::uint32_t u; std::memcpy(&u, at, 4); value = u; break; }
        default: throw InputError(path, what + " has an unsupported component type");
      }
      out[i * width + c] = value;
    }
  }
  return out;
}

Primitive read_primitive(const tinygltf::Model& model, const tinygltf::Primitive& source, const std::string& path,
                         const std::string& where) {
  Primitive p;
  const auto position = source.attributes.find("POSITION");
  if (position == source.attributes.end()) throw InputError(path, where + " has no POSITION");
  p.vertices = model.accessors.at(position->second).count;
  std::map<int, std::pair<int, int>> skin_sets;  // set n -> (JOINTS_n, WEIGHTS_n) accessors
  for (const auto& [name, index] : source.attributes) {
    const std::string what = where + " " + name;
    if (model.accessors.at(index).count != p.vertices)
      throw InputError(path, what + " has " + std::to_string(model.accessors.at(index).count) + " elements, POSITION " +
                       std::to_string(p.vertices));
    if (name.rfind("JOINTS_", 0) == 0) {
      skin_sets[std::stoi(name.substr(7))].first = index + 1;
    } else if (name.rfind("WEIGHTS_", 0) == 0) {
      skin_sets[std::stoi(name.substr(8))].second = index + 1;
    } else {
      p.attributes.push_back({name, component_count(model.accessors[index].type), read_accessor(model, index, path, what)});
    }
  }
  for (const auto& [set, accessors] : skin_sets) {
    if (accessors.first == 0 || accessors.second == 0)
      throw InputError(path, where + " has JOINTS_" + std::to_string(set) + " and WEIGHTS_" + std::to_string(set) +
                       " unpaired");
    const std::vector<double> j = read_accessor(model, accessors.first - 1, path, where + " JOINTS_" + std::to_string(set));
    p.weights.push_back(read_accessor(model, accessors.second - 1, path, where + " WEIGHTS_" + std::to_string(set)));
    if (j.size() != 4 * p.vertices || p.weights.back().size() != 4 * p.vertices)
      throw InputError(path, where + " skin set " + std::to_string(set) + " is not VEC4");
    p.joints.emplace_back(j.begin(), j.end());
  }
  for (std::size_t t = 0; t < source.targets.size(); ++t) {
    std::vector<Attribute> target;
    for (const auto& [name, index] : source.targets[t]) {
      const std::string what = where + " target " + std::to_string(t) + " " + name;
      if (model.accessors.at(index).count != p.vertices) throw InputError(path, what + " does not match POSITION's count");
      target.push_back({name, component_count(model.accessors[index].type), read_accessor(model, index, path, what)});
    }
    p.targets.push_back(std::move(target));
  }
  if (source.indices >= 0) {
    const std::vector<double> indices = read_accessor(model, source.indices, path, where + " indices");
    p.triangles.reserve(indices.size());
    for (const double i : indices) {
      if (!(i >= 0 && i < static_cast<double>(p.vertices)))
        throw InputError(path, where + " indices name vertex " + std::to_string(i) + " of " + std::to_string(p.vertices));
      p.triangles.push_back(static_cast<std::uint32_t>(i));
    }
  } else {
    for (std::size_t i = 0; i < p.vertices; ++i) p.triangles.push_back(static_cast<std::uint32_t>(i));
  }
  p.triangles.resize(p.triangles.size() / 3 * 3);
  return p;
}

// The midpoint of a, b for one attribute, appended to `values`.
void append_mean(std::vector<double>& values, int width, std::uint32_t a, std::uint32_t b, bool unit) {
  double norm = 0;
  const std::size_t start = values.size();
  for (int c = 0; c < width; ++c) {
    const double m = 0.5 * (values[a * width + c] + values[b * width + c]);
    values.push_back(m);
    norm += m * m;
  }
  if (unit && norm > 0) {
    // Normals renormalised; a tangent's w (handedness, +-1) is not a direction component.
    const int direction = std::min(width, 3);
    double n = 0;
    for (int c = 0; c < direction; ++c) n += values[start + c] * values[start + c];
    n = std::sqrt(n);
    if (n > 0)
      for (int c = 0; c < direction; ++c) values[start + c] /= n;
  }
}

void subdivide_once(Primitive& p) {
  if (p.vertices + p.triangles.size() * 3 / 2 + 1 > std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("more than 2^32 - 1 vertices");
  std::unordered_map<std::uint64_t, std::uint32_t> midpoints;
  midpoints.reserve(p.triangles.size());
  const std::size_t sets = p.joints.size();
  auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
    const std::uint64_t key = (std::uint64_t{std::min(a, b)} << 32) | std::max(a, b);
    const auto [it, added] = midpoints.try_emplace(key, static_cast<std::uint32_t>(p.vertices));
    if (!added) return it->second;
    for (Attribute& attribute : p.attributes) {
      const bool unit = attribute.name == "NORMAL" || attribute.name == "TANGENT";
      append_mean(attribute.values, attribute.width, a, b, unit);
    }
    for (auto& target : p.targets)
      for (Attribute& attribute : target) append_mean(attribute.values, attribute.width, a, b, false);
    if (sets > 0) {
      // Merge joint by joint, keep the largest 4 x sets, renormalise.
      std::vector<std::pair<double, std::uint32_t>> merged;
      for (const std::uint32_t end : {a, b}) {
        for (std::size_t s = 0; s < sets; ++s) {
          for (int k = 0; k < 4; ++k) {
            const double w = 0.5 * p.weights[s][end * 4 + k];
            if (w <= 0) continue;
            const std::uint32_t joint = p.joints[s][end * 4 + k];
            auto same = std::ranges::find_if(merged, [&](const auto& m) { return m.second == joint; });
            if (same == merged.end()) merged.emplace_back(w, joint); else same->first += w;
          }
        }
      }
      // Largest first; equal weights keep the order met (a's influences, then b's), so a midpoint of
      // two vertices that list a tie alike lists it alike, and readers that take the first of equal
      // weights as the vertex's main joint take the same one for it.
      std::ranges::stable_sort(merged, [](const auto& x, const auto& y) { return x.first > y.first; });
      merged.resize(std::min(merged.size(), 4 * sets));
      double total = 0;
      for (const auto& m : merged) total += m.first;
      for (std::size_t s = 0; s < sets; ++s) {
        for (std::size_t k = 0; k < 4; ++k) {
          const std::size_t slot = s * 4 + k;
          const bool used = slot < merged.size() && total > 0;
          p.joints[s].push_back(used ? merged[slot].second : 0);
          p.weights[s].push_back(used ? merged[slot].first / total : 0.0);
        }
      }
    }
    ++p.vertices;
    return it->second;
  };
  std::vector<std::uint32_t> out;
  out.reserve(p.triangles.size() * 4);
  for (std::size_t t = 0; t < p.triangles.size(); t += 3) {
    const std::uint32_t a = p.triangles[t], b = p.triangles[t + 1], c = p.triangles[t + 2];
    const std::uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    out.insert(out.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
  }
  p.triangles = std::move(out);
}

// Appends `bytes` to the output buffer as a new buffer view (4-byte aligned) and returns its index.
int add_view(tinygltf::Model& model, std::vector<unsigned char>& buffer, const void* bytes, std::size_t size, int target) {
  while (buffer.size() % 4 != 0) buffer.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buffer.size();
  view.byteLength = size;
  view.target = target;
  const auto* b = static_cast<const unsigned char*>(bytes);
  buffer.insert(buffer.end(), b, b + size);
  model.bufferViews.push_back(view);
  return static_cast<int>(model.bufferViews.size() - 1);
}

int add_float_accessor(tinygltf::Model& model, std::vector<unsigned char>& buffer, const Attribute& attribute, bool bounds) {
  const std::vector<float> values(attribute.values.begin(), attribute.values.end());
  tinygltf::Accessor accessor;
  accessor.bufferView = add_view(model, buffer, values.data(), values.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER);
  accessor.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  accessor.count = values.size() / attribute.width;
  accessor.type = attribute.width == 1 ? TINYGLTF_TYPE_SCALAR : attribute.width == 2 ? TINYGLTF_TYPE_VEC2
                  : attribute.width == 3 ? TINYGLTF_TYPE_VEC3 : TINYGLTF_TYPE_VEC4;
  if (bounds) {
    accessor.minValues.assign(attribute.width, std::numeric_limits<double>::infinity());
    accessor.maxValues.assign(attribute.width, -std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < values.size(); ++i) {
      accessor.minValues[i % attribute.width] = std::min<double>(accessor.minValues[i % attribute.width], values[i]);
      accessor.maxValues[i % attribute.width] = std::max<double>(accessor.maxValues[i % attribute.width], values[i]);
    }
  }
  model.accessors.push_back(accessor);
  return static_cast<int>(model.accessors.size() - 1);
}

// Calls visit(index) on every accessor index the model refers to (primitives' attributes, morph
// targets and indices, skins' inverse bind matrices, animation samplers); -1 means none.
template <typename Visit>
void for_each_accessor_reference(tinygltf::Model& model, Visit visit) {
  for (auto& mesh : model.meshes) {
    for (auto& primitive : mesh.primitives) {
      for (auto& [name, index] : primitive.attributes) visit(index);
      for (auto& target : primitive.targets)
        for (auto& [name, index] : target) visit(index);
      visit(primitive.indices);
    }
  }
  for (auto& skin : model.skins) visit(skin.inverseBindMatrices);
  for (auto& animation : model.animations) {
    for (auto& sampler : animation.samplers) {
      visit(sampler.input);
      visit(sampler.output);
    }
  }
}

// Keeps only the accessors and buffer views still referenced, packed into one new buffer.
void pack(tinygltf::Model& model, std::vector<unsigned char>& fresh, std::size_t first_fresh_view) {
  std::vector<int> accessor_map(model.accessors.size(), -1), view_map(model.bufferViews.size(), -1);
  for_each_accessor_reference(model, [&](int& index) {
    if (index >= 0) accessor_map[index] = 0;  // marked; numbered below
  });
  std::vector<tinygltf::Accessor> accessors;
  for (std::size_t i = 0; i < model.accessors.size(); ++i) {
    if (accessor_map[i] < 0) continue;
    accessor_map[i] = static_cast<int>(accessors.size());
    accessors.push_back(model.accessors[i]);
  }
  for_each_accessor_reference(model, [&](int& index) {
    if (index >= 0) index = accessor_map[index];
  });
  model.accessors = std::move(accessors);

  // Views referenced by the kept accessors and by images; the old ones are copied into the fresh
  // buffer, whose own views (first_fresh_view on) are already in place.
  std::vector<unsigned char> packed;
  std::vector<tinygltf::BufferView> views;
  auto use_view = [&](int& index) {
    if (index < 0) return;
    if (view_map[index] < 0) {
      tinygltf::BufferView view = model.bufferViews[index];
      const bool fresh_view = static_cast<std::size_t>(index) >= first_fresh_view;
      const std::vector<unsigned char>& from = fresh_view ? fresh : model.buffers.at(view.buffer).data;
      while (packed.size() % 4 != 0) packed.push_back(0);
      const std::size_t offset = packed.size();
      packed.insert(packed.end(), from.begin() + view.byteOffset, from.begin() + view.byteOffset + view.byteLength);
      view.buffer = 0;
      view.byteOffset = offset;
      view_map[index] = static_cast<int>(views.size());
      views.push_back(view);
    }
    index = view_map[index];
  };
  for (auto& accessor : model.accessors) use_view(accessor.bufferView);
  for (auto& image : model.images) use_view(image.bufferView);
  model.bufferViews = std::move(views);
  tinygltf::Buffer buffer;
  buffer.data = std::move(packed);
  model.buffers = {std::move(buffer)};
}

}  // namespace

SubdividedGltf write_subdivided_glb(const std::string& in_path, const std::string& out_path, int levels) {
  if (levels < 0 || levels > 6) throw std::invalid_argument("subdivision levels must be 0 to 6, got " + std::to_string(levels));
  tinygltf::TinyGLTF parser;
  parser.SetImageLoader(keep_image_bytes, nullptr);
  tinygltf::Model model;
  std::string error, warning;
  const bool binary = std::filesystem::path(in_path).extension() == ".glb";
  const bool ok = binary ? parser.LoadBinaryFromFile(&model, &error, &warning, in_path)
                         : parser.LoadASCIIFromFile(&model, &error, &warning, in_path);
  if (!ok) throw InputError(in_path, "cannot read glTF: " + error);

  SubdividedGltf counts;
  std::vector<unsigned char> fresh;
  const std::size_t first_fresh_view = model.bufferViews.size();
  for (std::size_t m = 0; m < model.meshes.size(); ++m) {
    for (std::size_t q = 0; q < model.meshes[m].primitives.size(); ++q) {
      tinygltf::Primitive& source = model.meshes[m].primitives[q];
      if (source.mode != TINYGLTF_MODE_TRIANGLES && source.mode != -1) continue;
      const std::string where = "mesh " + std::to_string(m) + " primitive " + std::to_string(q);
      Primitive p = read_primitive(model, source, in_path, where);
      counts.vertices_before += p.vertices;
      counts.triangles_before += p.triangles.size() / 3;
      try {
        for (int level = 0; level < levels; ++level) subdivide_once(p);
      } catch (const std::length_error&) {
        throw InputError(in_path, where + " would have more than 2^32 - 1 vertices after " + std::to_string(levels) +
                         " levels");
      }
      counts.vertices_after += p.vertices;
      counts.triangles_after += p.triangles.size() / 3;
      source.attributes.clear();
      // glTF asks for weights summing to 1 (some files hold looser sums, which readers normalise);
      // the copy stores them normalised, as the toolkit's loader reads them.
      for (std::size_t v = 0; v < p.vertices; ++v) {
        double total = 0;
        for (const auto& weights : p.weights)
          for (int k = 0; k < 4; ++k) total += weights[v * 4 + k];
        if (total > 0)
          for (auto& weights : p.weights)
            for (int k = 0; k < 4; ++k) weights[v * 4 + k] /= total;
      }
      for (const Attribute& attribute : p.attributes)
        source.attributes[attribute.name] = add_float_accessor(model, fresh, attribute, attribute.name == "POSITION");
      for (std::size_t s = 0; s < p.joints.size(); ++s) {
        const std::vector<std::uint16_t> joints(p.joints[s].begin(), p.joints[s].end());
        tinygltf::Accessor accessor;
        accessor.bufferView = add_view(model, fresh, joints.data(), joints.size() * 2, TINYGLTF_TARGET_ARRAY_BUFFER);
        accessor.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
        accessor.count = p.vertices;
        accessor.type = TINYGLTF_TYPE_VEC4;
        model.accessors.push_back(accessor);
        source.attributes["JOINTS_" + std::to_string(s)] = static_cast<int>(model.accessors.size() - 1);
        source.attributes["WEIGHTS_" + std::to_string(s)] =
            add_float_accessor(model, fresh, Attribute{"WEIGHTS", 4, p.weights[s]}, false);
      }
      for (std::size_t t = 0; t < p.targets.size(); ++t) {
        source.targets[t].clear();
        for (const Attribute& attribute : p.targets[t])
          source.targets[t][attribute.name] = add_float_accessor(model, fresh, attribute, attribute.name == "POSITION");
      }
      tinygltf::Accessor indices;
      indices.bufferView = add_view(model, fresh, p.triangles.data(), p.triangles.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
      indices.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
      indices.count = p.triangles.size();
      indices.type = TINYGLTF_TYPE_SCALAR;
      model.accessors.push_back(indices);
      source.indices = static_cast<int>(model.accessors.size() - 1);
    }
  }
  pack(model, fresh, first_fresh_view);
  std::filesystem::create_directories(std::filesystem::absolute(out_path).parent_path());
  if (!parser.WriteGltfSceneToFile(&model, out_path, false, true, false, true))
    throw InputError(out_path, "cannot write the subdivided GLB");
  return counts;
}

}  // namespace odyssey::io
