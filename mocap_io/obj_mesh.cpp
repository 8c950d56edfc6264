#include "mocap_io/obj_mesh.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <string_view>

#include "mocap_io/input_error.h"
#include "mocap_io/input_file.h"

namespace odyssey::io {
namespace {

std::string_view next_token(std::string_view& line) {
  const std::size_t begin = line.find_first_not_of(" \t\r");
  if (begin == std::string_view::npos) {
    line = {};
    return {};
  }
  const std::size_t end = line.find_first_of(" \t\r", begin);
  const std::string_view token = line.substr(begin, end == std::string_view::npos ? std::string_view::npos : end - begin);
  line = end == std::string_view::npos ? std::string_view{} : line.substr(end);
  return token;
}

}  // namespace

ObjMesh load_obj(const std::string& path) {
  const std::string whole = read_input_file(path, kMaxTextInputBytes);
  ObjMesh mesh;
  std::vector<std::uint32_t> corners;
  std::string_view rest = whole;
  for (long line_number = 1; !rest.empty(); ++line_number) {
    const auto fail = [&](const std::string& problem) {
      throw InputError(path, "line " + std::to_string(line_number) + ": " + problem);
    };
    const std::size_t end_of_line = rest.find('\n');
    std::string_view line = rest.substr(0, end_of_line);
    rest = end_of_line == std::string_view::npos ? std::string_view{} : rest.substr(end_of_line + 1);
    const std::string_view keyword = next_token(line);
    if (keyword == "v") {
      Eigen::Vector3f p;
      for (int i = 0; i < 3; ++i) {
        const std::string_view token = next_token(line);
        float value = 0;
        const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
        if (token.empty() || error != std::errc() || end != token.data() + token.size() || !std::isfinite(value)) {
          fail("vertex coordinate '" + std::string(token) + "' is not a finite number");
        }
        p[i] = value;
      }
      mesh.positions.push_back(p);
    } else if (keyword == "f") {
      corners.clear();
      for (std::string_view token = next_token(line); !token.empty(); token = next_token(line)) {
        const std::string_view index_text = token.substr(0, token.find('/'));
        long long index = 0;
        const auto [end, error] = std::from_chars(index_text.data(), index_text.data() + index_text.size(), index);
        if (index_text.empty() || error != std::errc() || end != index_text.data() + index_text.size() || index == 0) {
          fail("face corner '" + std::string(token) + "' is not a vertex number");
        }
        const long long count = static_cast<long long>(mesh.positions.size());
        const long long zero_based = index > 0 ? index - 1 : count + index;
        if (zero_based < 0 || zero_based >= count) {
          fail("face corner " + std::to_string(index) + " names a vertex not defined before it (" + std::to_string(count) +
               " so far)");
        }
        corners.push_back(static_cast<std::uint32_t>(zero_based));
      }
      if (corners.size() < 3) fail("a face needs at least 3 corners, got " + std::to_string(corners.size()));
      for (std::size_t c = 1; c + 1 < corners.size(); ++c) {
        mesh.triangles.insert(mesh.triangles.end(), {corners[0], corners[c], corners[c + 1]});
      }
    }
  }
  if (mesh.triangles.empty()) throw InputError(path, "no faces: a prop mesh needs triangles");
  return mesh;
}

}  // namespace odyssey::io
