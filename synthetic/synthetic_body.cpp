#include "synthetic/synthetic_body.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace odyssey {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::Vector3i;
constexpr double kPi = std::numbers::pi;

constexpr int kJoints = 55;
constexpr int kVertices = 10475;
constexpr int kTriangles = 20908;
constexpr int kShapeCount = 300;
constexpr int kExpressionCount = 100;
constexpr int kMeaningfulShapes = 10;  // shape directions 0-9 have names; the rest are bulges

const std::vector<std::string> kJointNames = body_model_joint_names(BodyModelKind::SMPLX);
const std::vector<int> kParents = smplx_parents();

constexpr int kPelvis = 0, kSpine1 = 3, kSpine2 = 6, kSpine3 = 9, kNeck = 12, kHead = 15, kJaw = 22;

// SMPL-X orders each hand's fingers index, middle, pinky, ring, thumb, three joints each.
enum Finger { kIndex = 0, kMiddle = 1, kPinky = 2, kRing = 3, kThumb = 4 };

// The joints of one side of the body; `sign` is the side's X direction (left is +X).
struct Side {
  double sign;
  int hip, knee, ankle, foot, collar, shoulder, elbow, wrist, eye, hand;
  int finger_joint(int finger, int segment) const { return hand + 3 * finger + segment; }
};
constexpr Side kLeft{+1.0, 1, 4, 7, 10, 13, 16, 18, 20, 23, 25};
constexpr Side kRight{-1.0, 2, 5, 8, 11, 14, 17, 19, 21, 24, 40};
constexpr std::array<Side, 2> kSides = {kLeft, kRight};

// Design heights (metres, model frame): floor, crown, the mouth line and the eye line.
constexpr double kFloor = -1.285;
constexpr double kCrown = 0.415;
constexpr double kMouthY = 0.225;
constexpr double kEyeY = 0.300;

// ---------------------------------------------------------------------------------------------
// Deterministic randomness. std::mt19937 is specified bit for bit, the standard distributions are
// not (their algorithms are left to the library), so the conversions are written out here: a
// seed gives the same model with every standard library.
class Random {
 public:
  explicit Random(unsigned seed) : engine_(seed) {}
  // Uniform in [0, 1) from 53 random bits (27 + 26 of two 32-bit draws).
  double uniform() {
    const std::uint64_t high = static_cast<std::uint64_t>(engine_()) >> 5;
    const std::uint64_t low = static_cast<std::uint64_t>(engine_()) >> 6;
    return static_cast<double>((high << 26) | low) * 0x1p-53;
  }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // Standard normal by Box-Muller: sqrt(-2 ln u) cos(2 pi v), u in (0, 1].
  double normal() {
    const double u = 1.0 - uniform();
    return std::sqrt(-2.0 * std::log(u)) * std::cos(2.0 * kPi * uniform());
  }
  int index(int count) { return std::min(count - 1, static_cast<int>(uniform() * count)); }

 private:
  std::mt19937 engine_;
};

// A bump with compact support: (1 - q^2)^3 for |q| < 1, else exactly 0. Its value and first two
// derivatives vanish at |q| = 1, so everything built from it is smooth and exactly zero away
// from where it acts (which keeps the mostly-zero arrays exactly zero and the file small).
double bump(double q) {
  const double r = 1.0 - q * q;
  return r > 0.0 ? r * r * r : 0.0;
}
double smoothstep(double x) {
  const double t = std::clamp(x, 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

// ---------------------------------------------------------------------------------------------
// A smooth function of one parameter through key rows (s, values...): cubic Hermite between keys
// with Catmull-Rom slopes m_i = (p_{i+1} - p_{i-1}) / (s_{i+1} - s_{i-1}), one-sided at the ends.
// It passes through every key with a continuous first derivative, so radii and centres change
// smoothly from ring to ring. Keys may come in either order of s; outside them the function
// holds the end values.
class Profile {
 public:
  Profile(std::initializer_list<std::initializer_list<double>> keys) {
    for (const auto& key : keys) {
      std::vector<double> row(key);
      s_.push_back(row[0]);
      values_.push_back(Eigen::Map<Eigen::VectorXd>(row.data() + 1, static_cast<Eigen::Index>(row.size() - 1)));
    }
    build_slopes();
  }
  Profile(std::vector<double> s, std::vector<Eigen::VectorXd> values) : s_(std::move(s)), values_(std::move(values)) {
    build_slopes();
  }

  Eigen::VectorXd operator()(double s) const {
    if (s <= s_.front()) return values_.front();
    if (s >= s_.back()) return values_.back();
    const std::size_t i = static_cast<std::size_t>(std::upper_bound(s_.begin(), s_.end(), s) - s_.begin()) - 1;
    const double h = s_[i + 1] - s_[i];
    const double t = (s - s_[i]) / h, t2 = t * t, t3 = t2 * t;
    return (2 * t3 - 3 * t2 + 1) * values_[i] + (t3 - 2 * t2 + t) * h * slopes_[i] +
           (-2 * t3 + 3 * t2) * values_[i + 1] + (t3 - t2) * h * slopes_[i + 1];
  }
  double front() const { return s_.front(); }
  double back() const { return s_.back(); }

 private:
  void build_slopes() {
    if (s_.front() > s_.back()) {
      std::reverse(s_.begin(), s_.end());
      std::reverse(values_.begin(), values_.end());
    }
    const std::size_t n = s_.size();
    slopes_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t lo = i == 0 ? 0 : i - 1, hi = i + 1 == n ? i : i + 1;
      slopes_[i] = (values_[hi] - values_[lo]) / (s_[hi] - s_[lo]);
    }
  }
  std::vector<double> s_;
  std::vector<Eigen::VectorXd> values_, slopes_;
};

// Ring parameters from spans {from, to, quads}: the ends of each span's `quads` equal steps,
// spans joined without repeating the shared end. The first span's start is included.
std::vector<double> ring_stations(std::initializer_list<std::array<double, 3>> spans) {
  std::vector<double> stations;
  for (const auto& [from, to, quads] : spans) {
    if (stations.empty()) stations.push_back(from);
    for (int k = 1; k <= static_cast<int>(quads); ++k) stations.push_back(from + (to - from) * k / quads);
  }
  return stations;
}

// ---------------------------------------------------------------------------------------------
// Mesh construction.

struct Mesh {
  std::vector<Vector3d> points;
  std::vector<int> part;  // body part of each vertex (index into BodyMesh::parts)
  std::vector<Vector3i> triangles;

  int add(const Vector3d& point, int part_index) {
    points.push_back(point);
    part.push_back(part_index);
    return static_cast<int>(points.size()) - 1;
  }
  // A quad a-b-c-d counter-clockwise seen from outside, split along a-c.
  void add_quad(int a, int b, int c, int d) {
    triangles.emplace_back(a, b, c);
    triangles.emplace_back(a, c, d);
  }
};

// A rectangle of `rows` x `columns` quads, and the order in which its boundary is walked: from
// corner (0, 0) first along the row (`columns` steps), then up the far column (`rows` steps),
// back along the last row and down the first column, 2 (rows + columns) points in all. Rims of
// cut blocks, tube rings and lid boundaries all follow this order, which is how one part's ring
// is handed to the next.
struct Layout {
  int rows, columns;
  int size() const { return 2 * (rows + columns); }
  // (row, column) of boundary point k.
  std::pair<int, int> cell(int k) const {
    if (k < columns) return {0, k};
    k -= columns;
    if (k < rows) return {k, columns};
    k -= rows;
    if (k < columns) return {rows, columns - k};
    k -= columns;
    return {rows - k, 0};
  }
  // Boundary point k on the square [-1, 1]^2: U along the first side, V along the second.
  Vector2d unit(int k) const {
    const auto [row, column] = cell(k);
    return {2.0 * column / columns - 1.0, 2.0 * row / rows - 1.0};
  }
};

struct Block {
  int row, column, rows, columns;  // quads [row, row + rows) x [column, column + columns)
  Layout layout() const { return {rows, columns}; }
};

// Vertex ids on a grid of quads. Quad (r, c) has corners (r, c), (r, c+1), (r+1, c+1), (r+1, c),
// counter-clockwise seen from outside. Around a tube the columns wrap. Blocks cut from the grid
// leave a hole; the grid points strictly inside a block get no vertex.
class Grid {
 public:
  Grid(int rows, int columns, bool wraps) : rows_(rows), columns_(columns), wraps_(wraps), ids_(rows * columns, -1) {}

  int rows() const { return rows_; }
  int& id(int row, int column) { return ids_[row * columns_ + wrap(column)]; }
  int id(int row, int column) const { return ids_[row * columns_ + wrap(column)]; }
  void cut(const Block& block) { holes_.push_back(block); }

  // Creates the missing vertices (id -1) that are not buried in a cut block.
  template <class Position>
  void fill(Mesh& mesh, int part, Position position) {
    for (int r = 0; r < rows_; ++r) {
      for (int c = 0; c < columns_; ++c) {
        if (id(r, c) < 0 && !buried(r, c)) id(r, c) = mesh.add(position(r, c), part);
      }
    }
  }
  void emit_quads(Mesh& mesh) const {
    const int quad_columns = wraps_ ? columns_ : columns_ - 1;
    for (int r = 0; r + 1 < rows_; ++r) {
      for (int c = 0; c < quad_columns; ++c) {
        if (!in_hole(r, c)) mesh.add_quad(id(r, c), id(r, c + 1), id(r + 1, c + 1), id(r + 1, c));
      }
    }
  }
  // The rim of a cut block in Layout order from its corner (row, column): counter-clockwise seen
  // from outside, like the quads it replaces, so a child tube built on it faces outward too.
  std::vector<int> rim(const Block& block) const {
    const Layout layout = block.layout();
    std::vector<int> ids(layout.size());
    for (int k = 0; k < layout.size(); ++k) {
      const auto [row, column] = layout.cell(k);
      ids[k] = id(block.row + row, block.column + column);
    }
    return ids;
  }
  std::vector<int> row(int r) const {
    std::vector<int> ids(columns_);
    for (int c = 0; c < columns_; ++c) ids[c] = id(r, c);
    return ids;
  }

 private:
  int wrap(int column) const { return wraps_ ? ((column % columns_) + columns_) % columns_ : column; }
  int column_offset(int column, const Block& block) const { return wrap(column - block.column); }
  bool in_hole(int row, int column) const {
    for (const Block& b : holes_) {
      const int offset = column_offset(column, b);
      if (row >= b.row && row < b.row + b.rows && offset >= 0 && offset < b.columns) return true;
    }
    return false;
  }
  bool buried(int row, int column) const {
    for (const Block& b : holes_) {
      const int offset = column_offset(column, b);
      if (row > b.row && row < b.row + b.rows && offset > 0 && offset < b.columns) return true;
    }
    return false;
  }

  int rows_, columns_;
  bool wraps_;
  std::vector<int> ids_;
  std::vector<Block> holes_;
};

// Closes a ring with a fan around a pole; the ring is counter-clockwise seen from outside the cap.
void cap_with_pole(Mesh& mesh, const std::vector<int>& ring, int pole) {
  const int n = static_cast<int>(ring.size());
  for (int k = 0; k < n; ++k) mesh.triangles.emplace_back(ring[k], ring[(k + 1) % n], pole);
}

std::vector<int> reversed(std::vector<int> ring) {
  std::reverse(ring.begin(), ring.end());
  return ring;
}

Vector3d centroid(const Mesh& mesh, const std::vector<int>& ids) {
  Vector3d sum = Vector3d::Zero();
  for (int id : ids) sum += mesh.points[id];
  return sum / static_cast<double>(ids.size());
}

// One cross-section of a tube: centre, half extents along the tube's reference direction and
// across it, and the superellipse exponent n (2 an ellipse, larger a rounded box).
struct Section {
  Vector3d centre;
  double half_reference, half_across, exponent;
};

// Sections from a profile of rows (s, centre x, y, z, half_reference, half_across, exponent).
std::vector<Section> sections(const Profile& profile, const std::vector<double>& stations) {
  std::vector<Section> out;
  for (double s : stations) {
    const Eigen::VectorXd p = profile(s);
    out.push_back({p.head<3>(), p[3], p[4], p[5]});
  }
  return out;
}

// Frames along a tube: (e_u, e_v, tangent) right-handed, carried from ring to ring by parallel
// transport (e_u loses only its component along the new tangent), so the rings do not twist.
// With a fixed `axis` every ring lies in a plane across it (the torso's rings are horizontal
// however its centre line wanders front to back); otherwise rings stand across the centre line.
struct Frame {
  Vector3d u, v, tangent;
};
std::vector<Frame> transport_frames(const std::vector<Vector3d>& centres, const Vector3d& first_u,
                                    const std::optional<Vector3d>& axis) {
  const std::size_t n = centres.size();
  std::vector<Frame> frames(n);
  Vector3d u = first_u;
  for (std::size_t i = 0; i < n; ++i) {
    const Vector3d tangent =
        axis ? *axis : (centres[std::min(i + 1, n - 1)] - centres[i == 0 ? 0 : i - 1]).normalized();
    u = (u - u.dot(tangent) * tangent).normalized();
    frames[i] = {u, tangent.cross(u), tangent};
  }
  return frames;
}

// Half extents along (e_u, e_v): the section's reference half extent goes to whichever frame
// axis lies closer to the tube's reference direction.
Vector2d half_extents(const Section& section, const Frame& frame, const Vector3d& reference) {
  return std::abs(frame.v.dot(reference)) >= std::abs(frame.u.dot(reference))
             ? Vector2d(section.half_across, section.half_reference)
             : Vector2d(section.half_reference, section.half_across);
}

// A tube that starts free (torso, eyeballs): `columns` points a ring at parameter angles
// t_j = 2 pi j / columns, at centre + h_u c(cos t) e_u + h_v c(sin t) e_v with
// c(x) = sign(x) |x|^(2/n), the superellipse |x/h_u|^n + |y/h_v|^n = 1. e_u starts along
// `reference`, so column 0 faces that way. Rows are rings; cut blocks leave holes.
Grid root_tube(Mesh& mesh, int part, const std::vector<Section>& rings, const Vector3d& reference, int columns,
               const Vector3d& axis, const std::vector<Block>& holes) {
  std::vector<Vector3d> centres;
  for (const Section& s : rings) centres.push_back(s.centre);
  const std::vector<Frame> frames = transport_frames(centres, reference, axis);
  Grid grid(static_cast<int>(rings.size()), columns, true);
  for (const Block& b : holes) grid.cut(b);
  grid.fill(mesh, part, [&](int r, int c) {
    const Section& s = rings[r];
    const Frame& f = frames[r];
    const Vector2d h = half_extents(s, f, reference);
    const double t = 2.0 * kPi * c / columns;
    const auto shape = [&](double x) { return std::copysign(std::pow(std::abs(x), 2.0 / s.exponent), x); };
    return Vector3d(s.centre + h[0] * shape(std::cos(t)) * f.u + h[1] * shape(std::sin(t)) * f.v);
  });
  return grid;
}

// A tube leaving a parent through the rim of a cut block (ring 0). Vertex k of ring r sits at
// the layout point L_k(r) = (1 - lambda_r) from.unit(k) + lambda_r to.unit(k), projected radially
// onto the ring's superellipse: q = L / ||L||_n, point = centre + h_u q_u e_u + h_v q_v e_v. So
// the columns of vertices run straight down the limb, and the layout can change along it (the arm
// leaves the shoulder as a 5 x 8 rim and ends as a 2 x 11 palm). e_u starts along the rim's first
// side. Ring 1 is blended 45/55 with the rim's own shape (translated to its centre) so the skin
// leaves the parent without a crease.
Grid child_tube(Mesh& mesh, int part, const std::vector<int>& rim, Layout from, Layout to,
                const std::vector<double>& lambda, const std::vector<Section>& rings, const Vector3d& reference,
                const std::optional<Vector3d>& axis, const std::vector<Block>& holes) {
  const int columns = from.size();
  if (to.size() != columns || rim.size() != static_cast<std::size_t>(columns)) {
    throw std::logic_error("synthetic body: a tube's layouts do not match its rim");
  }
  const Vector3d rim_centre = centroid(mesh, rim);
  std::vector<Vector3d> centres{rim_centre};
  for (const Section& s : rings) centres.push_back(s.centre);
  const Vector3d first_side = mesh.points[rim[from.columns]] - mesh.points[rim[0]];
  const std::vector<Frame> frames = transport_frames(centres, first_side, axis);

  Grid grid(static_cast<int>(rings.size()) + 1, columns, true);
  for (int k = 0; k < columns; ++k) grid.id(0, k) = rim[k];
  for (const Block& b : holes) grid.cut(b);
  grid.fill(mesh, part, [&](int r, int k) {
    const Section& s = rings[r - 1];
    const Frame& f = frames[r];
    const Vector2d h = half_extents(s, f, reference);
    const Vector2d layout = (1.0 - lambda[r - 1]) * from.unit(k) + lambda[r - 1] * to.unit(k);
    const double norm = std::pow(std::pow(std::abs(layout[0]), s.exponent) + std::pow(std::abs(layout[1]), s.exponent),
                                 1.0 / s.exponent);
    const Vector3d on_section = s.centre + (h[0] * layout[0] / norm) * f.u + (h[1] * layout[1] / norm) * f.v;
    if (r > 1) return on_section;
    const Vector3d rim_shape = mesh.points[rim[k]] + (s.centre - rim_centre);
    return Vector3d(0.45 * rim_shape + 0.55 * on_section);
  });
  return grid;
}

// Closes a ring (counter-clockwise seen from outside) with a grid of layout.rows x
// layout.columns quads whose boundary is the ring in Layout order. Interior points interpolate
// the boundary (a Coons patch: the two ruled surfaces between opposite sides minus the bilinear
// surface of the corners) and rise by `dome` * 16 s(1-s) t(1-t) along `outward`.
Grid lid(Mesh& mesh, int part, const std::vector<int>& ring, Layout layout, const Vector3d& outward, double dome,
         const std::vector<Block>& holes) {
  const int a = layout.rows, b = layout.columns;
  Grid grid(a + 1, b + 1, false);
  for (int k = 0; k < layout.size(); ++k) {
    const auto [row, column] = layout.cell(k);
    grid.id(row, column) = ring[k];
  }
  for (const Block& block : holes) grid.cut(block);
  const auto p = [&](int row, int column) { return mesh.points[grid.id(row, column)]; };
  grid.fill(mesh, part, [&](int row, int column) {
    const double s = static_cast<double>(column) / b, t = static_cast<double>(row) / a;
    const Vector3d ruled_rows = (1 - t) * p(0, column) + t * p(a, column);
    const Vector3d ruled_columns = (1 - s) * p(row, 0) + s * p(row, b);
    const Vector3d corners =
        (1 - s) * (1 - t) * p(0, 0) + s * (1 - t) * p(0, b) + (1 - s) * t * p(a, 0) + s * t * p(a, b);
    return Vector3d(ruled_rows + ruled_columns - corners + dome * 16 * s * (1 - s) * t * (1 - t) * outward);
  });
  grid.emit_quads(mesh);
  return grid;
}

// ---------------------------------------------------------------------------------------------
// The body.

// What a body part's vertices may follow: the bones whose distance sets their skinning weights
// (and whose joints may regress from them), or one joint they follow rigidly (the eyeballs).
struct Part {
  std::vector<int> bones;
  int rigid_joint = -1;
};

// Where the smplx package looks for its extra keypoints (smplx/vertex_ids.py, 'smplx'), and the
// feature each index should sit on.
struct KeypointVertex {
  int smplx_index;
  int vertex;  // the vertex of this mesh on that feature
};

struct BodyMesh {
  Mesh mesh;
  std::vector<Part> parts;
  std::array<Vector3d, kJoints> joints;
  std::array<Vector3d, kJoints> bone_ends;  // where each joint's bone ends (see skinning)
  std::vector<KeypointVertex> keypoints;
  // Vertex ids of the face openings' rims, for landmarks and expressions.
  std::array<std::vector<int>, 2> eye_rims;  // per side (left, right), Layout order
  std::vector<int> mouth_rim;                // Layout order, see the mouth block
  int torso_part = -1;
};

// Builds the skin. Joint centres of the body come from the design below (a 1.70 m adult in the
// SMPL-X frame); finger and eye joints follow the surfaces built for them.
class BodyBuilder {
 public:
  BodyMesh build() {
    body_.joints[kPelvis] = {0.0, -0.355, 0.008};
    body_.joints[kSpine1] = {0.0, -0.240, -0.010};
    body_.joints[kSpine2] = {0.0, -0.110, -0.004};
    body_.joints[kSpine3] = {0.0, -0.055, 0.008};
    body_.joints[kNeck] = {0.0, 0.175, -0.028};
    body_.joints[kHead] = {0.0, 0.245, 0.000};
    body_.joints[kJaw] = {0.0, 0.232, 0.022};
    for (const Side& side : kSides) {
      const auto mirror = [&](double x, double y, double z) { return Vector3d(side.sign * x, y, z); };
      body_.joints[side.hip] = mirror(0.068, -0.440, 0.000);
      body_.joints[side.knee] = mirror(0.100, -0.820, 0.004);
      body_.joints[side.ankle] = mirror(0.090, -1.215, -0.038);
      body_.joints[side.foot] = mirror(0.104, -1.263, 0.092);
      body_.joints[side.collar] = mirror(0.068, 0.110, -0.015);
      body_.joints[side.shoulder] = mirror(0.172, 0.118, -0.025);
      body_.joints[side.elbow] = mirror(0.430, 0.105, -0.035);
      body_.joints[side.wrist] = mirror(0.672, 0.109, -0.030);
    }
    build_torso();
    for (int s = 0; s < 2; ++s) {
      build_leg(kSides[s]);
      build_arm(kSides[s]);
    }
    for (int s = 0; s < 2; ++s) build_eye(kSides[s], s);
    add_head_keypoints();
    const int vertices = static_cast<int>(body_.mesh.points.size());
    const int triangles = static_cast<int>(body_.mesh.triangles.size());
    if (vertices != kVertices || triangles != kTriangles) {
      throw std::logic_error("synthetic body: built " + std::to_string(vertices) + " vertices and " +
                             std::to_string(triangles) + " triangles, expected 10475 and 20908");
    }
    return std::move(body_);
  }

 private:
  int add_part(std::vector<int> bones, int rigid_joint = -1) {
    body_.parts.push_back({std::move(bones), rigid_joint});
    return static_cast<int>(body_.parts.size()) - 1;
  }
  Mesh& mesh() { return body_.mesh; }

  // Torso, neck and head: one tube of 64 columns from the hips (y = -0.50) to the crown, with
  // column 0 facing front and column 16 facing left (+X). Rings are 1.6 cm apart on the trunk and
  // 1 cm on the head, where the face openings are one quad row (eyes) and two rows (mouth) tall.
  // Arms leave through 5 x 8 blocks centred on the sides at shoulder height; the hip end is a
  // 16 x 16 lid, the crown a pole.
  void build_torso() {
    constexpr int kColumns = 64;
    const int torso_part = add_part({kPelvis, kSpine1, kSpine2, kSpine3, kNeck, kHead, kJaw, kLeft.collar,
                                     kRight.collar, kLeft.shoulder, kRight.shoulder, kLeft.hip, kRight.hip});
    body_.torso_part = torso_part;
    // y, centre z, half depth (z), half width (x), exponent.
    const Profile trunk{{-0.500, 0.000, 0.098, 0.160, 2.6}, {-0.470, 0.000, 0.106, 0.168, 2.6},
                        {-0.420, 0.002, 0.108, 0.170, 2.6}, {-0.360, 0.005, 0.106, 0.163, 2.5},
                        {-0.260, 0.008, 0.098, 0.143, 2.3}, {-0.180, 0.008, 0.094, 0.135, 2.2},
                        {-0.080, 0.005, 0.100, 0.145, 2.3}, {0.020, 0.005, 0.110, 0.156, 2.4},
                        {0.065, 0.003, 0.108, 0.158, 2.6}, {0.145, -0.010, 0.088, 0.152, 2.6},
                        {0.155, -0.014, 0.078, 0.128, 2.5}, {0.165, -0.018, 0.068, 0.095, 2.3},
                        {0.175, -0.020, 0.062, 0.072, 2.1}, {0.185, -0.020, 0.060, 0.064, 2.0},
                        {0.195, -0.005, 0.075, 0.060, 2.0}, {0.205, 0.008, 0.088, 0.062, 2.0},
                        {0.215, 0.008, 0.094, 0.066, 2.0}, {0.235, 0.008, 0.098, 0.071, 2.0},
                        {0.250, 0.006, 0.100, 0.074, 2.0}, {0.270, 0.004, 0.101, 0.076, 2.0},
                        {0.300, 0.000, 0.102, 0.077, 2.0}, {0.330, -0.004, 0.101, 0.078, 2.0},
                        {0.360, -0.008, 0.096, 0.076, 2.0}, {0.385, -0.010, 0.084, 0.067, 2.0},
                        {0.400, -0.012, 0.068, 0.055, 2.0}, {0.408, -0.012, 0.048, 0.040, 2.0}};
    torso_heights_ = ring_stations({{-0.50, 0.065, 36}, {0.065, 0.145, 5}, {0.145, 0.185, 4}, {0.185, 0.405, 22}});
    std::vector<Section> rings;
    for (double y : torso_heights_) {
      const Eigen::VectorXd p = trunk(y);
      rings.push_back({Vector3d(0.0, y, p[0]), p[1], p[2], p[3]});
    }
    const int arm_row = torso_ring(0.065);
    left_arm_block_ = {arm_row, 12, 5, 8};
    right_arm_block_ = {arm_row, kColumns - 12 - 8, 5, 8};
    const int eye_row = torso_ring(kEyeY - 0.005);
    const Block left_eye{eye_row, 2, 1, 4}, right_eye{eye_row, kColumns - 2 - 4, 1, 4};
    mouth_block_ = {torso_ring(kMouthY - 0.01), kColumns - 3, 2, 6};
    torso_tube_first_ = static_cast<int>(mesh().points.size());
    torso_ = std::make_unique<Grid>(root_tube(mesh(), torso_part, rings, Vector3d::UnitZ(), kColumns, Vector3d::UnitY(),
                                              {left_arm_block_, right_arm_block_, left_eye, right_eye, mouth_block_}));
    torso_tube_end_ = static_cast<int>(mesh().points.size());
    shape_face();
    body_.eye_rims = {torso_->rim(left_eye), torso_->rim(right_eye)};
    body_.mouth_rim = torso_->rim(mouth_block_);
    almond_eyes();
    torso_->emit_quads(mesh());

    const int top = torso_->rows() - 1;
    const int crown = mesh().add({0.0, kCrown, rings.back().centre.z()}, torso_part);
    cap_with_pole(mesh(), torso_->row(top), crown);
    body_.bone_ends[kHead] = mesh().points[crown];
    body_.bone_ends[kNeck] = body_.joints[kHead];
    body_.bone_ends[kSpine3] = body_.joints[kNeck];
    body_.bone_ends[kSpine2] = body_.joints[kSpine3];
    body_.bone_ends[kSpine1] = body_.joints[kSpine2];
    body_.bone_ends[kJaw] = {0.0, 0.198, 0.090};  // the chin

    // The hip lid: its boundary is ring 0 walked clockwise seen from above (counter-clockwise
    // seen from below, outside), starting at the back-right corner (column 40 = 225 degrees), so
    // lid columns run along +X and lid rows along +Z. The legs leave through 16 x 7 blocks at its
    // two ends; the two columns between them are the crotch.
    std::vector<int> ring(kColumns);
    for (int k = 0; k < kColumns; ++k) ring[k] = torso_->id(0, 40 - k);
    hip_lid_ = std::make_unique<Grid>(lid(mesh(), torso_part, ring, {16, 16}, -Vector3d::UnitY(), 0.025,
                                          {kLeftLegBlock, kRightLegBlock}));
    body_.bone_ends[kPelvis] = body_.joints[kSpine1];
  }

  int torso_ring(double y) const {
    const auto nearest = std::min_element(torso_heights_.begin(), torso_heights_.end(),
                                          [&](double a, double b) { return std::abs(a - y) < std::abs(b - y); });
    return static_cast<int>(nearest - torso_heights_.begin());
  }

  // The face: a nose ridge rising to a tip 2 cm proud at y = 0.252, brow, lips and chin 3-4 mm
  // proud, and the mouth slit closed by pulling the rows around it toward the mouth line:
  //   y' = y - 0.95 (y - y_m) g,  g = (1 - q^2)^2,  q^2 = (x / 4.5 cm)^2 + ((y - y_m) / 2.8 cm)^2,
  // which leaves the lips 5.5 mm apart and keeps every row in order: with u = (y - y_m)^2 / c^2
  // on the centre line, dy'/dy = 1 - 0.95 (1 - u)(1 - 5u) >= 0.05.
  void shape_face() {
    const Profile nose{{0.232, 0.000, 0.012}, {0.243, 0.010, 0.016}, {0.252, 0.020, 0.018}, {0.265, 0.015, 0.016},
                       {0.280, 0.009, 0.013}, {0.295, 0.004, 0.011}, {0.310, 0.000, 0.010}};
    for (int v = torso_tube_first_; v < torso_tube_end_; ++v) {
      Vector3d& p = mesh().points[v];
      if (p.y() < 0.18 || p.z() <= 0.0) continue;
      const double x = p.x(), y = p.y();
      double dz = 0.0;
      if (y > nose.front() && y < nose.back()) {
        const Eigen::VectorXd n = nose(y);
        dz += std::max(0.0, n[0]) * bump(x / (2.5 * n[1]));
      }
      dz += 0.004 * bump((y - 0.318) / 0.014) * bump(x / 0.060);  // brow
      dz += 0.003 * bump((y - kMouthY) / 0.014) * bump(x / 0.030);  // lips
      dz += 0.004 * bump((y - 0.198) / 0.012) * bump(x / 0.030);  // chin
      const double q2 = std::pow(x / 0.045, 2) + std::pow((y - kMouthY) / 0.028, 2);
      const double g = q2 < 1.0 ? (1.0 - q2) * (1.0 - q2) : 0.0;
      p.y() -= 0.95 * (y - kMouthY) * g;
      p.z() += dz;
    }
  }

  // Each eye opening is one quad row tall; pulling its four corner vertices 35% of the way toward
  // the eye line gives the lids an almond outline.
  void almond_eyes() {
    for (const std::vector<int>& rim : body_.eye_rims) {
      for (int k : {0, 4, 5, 9}) {  // the corners of a 1 x 4 rim in Layout order
        Vector3d& p = mesh().points[rim[k]];
        p.y() += 0.35 * (kEyeY - p.y());
      }
    }
  }

  // Hip-lid blocks: all 16 rows (back to front) by 7 columns; the left leg at the +X end.
  static constexpr Block kLeftLegBlock{0, 9, 16, 7};
  static constexpr Block kRightLegBlock{0, 0, 16, 7};

  // A leg: leaves the hip lid as a 16 x 7 rim (deep and narrow) and rounds to a 12 x 11 layout
  // over the thigh; rings about 2.4 cm apart on thigh and calf, 2 cm at knee and ankle. The foot leaves
  // the front face (layout columns 23-33) through a 3 x 11 block at the ankle; the leg ends in the
  // heel pole on the floor.
  void build_leg(const Side& side) {
    const double x = side.sign;
    const int leg_part = add_part({kPelvis, kSpine1, side.hip, side.knee, side.ankle});
    // y, centre x, y, z, half depth (z), half width (x), exponent.
    const Profile leg{{-0.500, 0.090 * x, -0.500, 0.000, 0.094, 0.070, 2.5},
                      {-0.560, 0.088 * x, -0.560, 0.004, 0.085, 0.076, 2.3},
                      {-0.640, 0.092 * x, -0.640, 0.008, 0.076, 0.072, 2.1},
                      {-0.740, 0.097 * x, -0.740, 0.010, 0.064, 0.060, 2.0},
                      {-0.820, 0.100 * x, -0.820, 0.006, 0.052, 0.050, 2.0},
                      {-0.900, 0.098 * x, -0.900, -0.006, 0.056, 0.048, 2.0},
                      {-1.000, 0.095 * x, -1.000, -0.016, 0.050, 0.043, 2.0},
                      {-1.100, 0.092 * x, -1.100, -0.026, 0.038, 0.034, 2.0},
                      {-1.180, 0.090 * x, -1.180, -0.034, 0.034, 0.031, 2.0},
                      {-1.225, 0.090 * x, -1.225, -0.040, 0.042, 0.032, 2.2},
                      {-1.260, 0.090 * x, -1.260, -0.046, 0.036, 0.030, 2.2},
                      {-1.278, 0.090 * x, -1.278, -0.050, 0.022, 0.020, 2.0}};
    const std::vector<double> heights = ring_stations(
        {{-0.50, -0.77, 11}, {-0.77, -0.87, 5}, {-0.87, -1.175, 13}, {-1.175, -1.255, 4}, {-1.255, -1.272, 1}});
    std::vector<double> stations(heights.begin() + 1, heights.end());
    std::vector<double> lambda;
    for (double y : stations) lambda.push_back(smoothstep((-0.52 - y) / 0.23));
    const std::vector<Section> rings = sections(leg, stations);
    const int foot_row = 1 + static_cast<int>(std::find_if(stations.begin(), stations.end(),
                                                            [](double y) { return y < -1.19; }) - stations.begin());
    const Block foot_block{foot_row, 23, 3, 11};
    const std::vector<int> rim = hip_lid_->rim(side.sign > 0 ? kLeftLegBlock : kRightLegBlock);
    Grid grid = child_tube(mesh(), leg_part, rim, {16, 7}, {12, 11}, lambda, rings, Vector3d::UnitZ(),
                           -Vector3d::UnitY(), {foot_block});
    grid.emit_quads(mesh());
    const Vector3d heel_point(0.090 * x, kFloor, -0.050);
    const int heel = mesh().add(heel_point, leg_part);
    cap_with_pole(mesh(), grid.row(grid.rows() - 1), heel);
    body_.bone_ends[side.hip] = body_.joints[side.knee];
    body_.bone_ends[side.knee] = body_.joints[side.ankle];
    body_.bone_ends[side.ankle] = body_.joints[side.foot];
    body_.keypoints.push_back(
        {side.sign > 0 ? 8846 : 8635, nearest(heel_point + Vector3d(0, 0.006, -0.006), leg_part)});
    build_foot(side, grid.rim(foot_block));
  }

  // A foot: a flat tube forward (+Z) from the ankle block to a pole at the toe tip, its sole on
  // the floor. The rim is 3 x 11 (11 across the front of the ankle).
  void build_foot(const Side& side, const std::vector<int>& rim) {
    const double x = side.sign;
    const int foot_part = add_part({side.knee, side.ankle, side.foot});
    // z, centre x, y, z, half height (y), half width (x), exponent.
    const Profile foot{{0.030, 0.093 * x, -1.240, 0.030, 0.036, 0.036, 2.4},
                       {0.060, 0.097 * x, -1.250, 0.060, 0.032, 0.043, 2.6},
                       {0.095, 0.104 * x, -1.262, 0.095, 0.022, 0.046, 2.8},
                       {0.130, 0.110 * x, -1.270, 0.130, 0.015, 0.045, 2.8},
                       {0.158, 0.113 * x, -1.274, 0.158, 0.011, 0.038, 2.6},
                       {0.175, 0.115 * x, -1.277, 0.175, 0.007, 0.028, 2.4}};
    const std::vector<double> stations = ring_stations({{0.025, 0.125, 5}, {0.125, 0.169, 3}});
    const std::vector<double> lambda(stations.size(), 0.0);
    Grid grid = child_tube(mesh(), foot_part, rim, {3, 11}, {3, 11}, lambda, sections(foot, stations),
                           Vector3d::UnitY(), Vector3d::UnitZ(), {});
    grid.emit_quads(mesh());
    const Vector3d toe_point(0.116 * x, -1.279, 0.181);
    const int toe = mesh().add(toe_point, foot_part);
    cap_with_pole(mesh(), grid.row(grid.rows() - 1), toe);
    body_.bone_ends[side.foot] = toe_point;
    // Big toe on the inner (midline) side of the toe tip, little toe on the outer side behind it.
    body_.keypoints.push_back({side.sign > 0 ? 5770 : 8463, nearest({0.094 * x, -1.275, 0.168}, foot_part)});
    body_.keypoints.push_back({side.sign > 0 ? 5780 : 8474, nearest({0.140 * x, -1.276, 0.140}, foot_part)});
  }

  // An arm: leaves the torso through a 5 x 8 rim (rows along Y, columns along Z) and becomes a
  // flat 2 x 11 palm over the forearm; rings about 3 cm apart on the upper arm, 1.2 cm on the
  // palm. The thumb leaves the palm's front edge through a 2 x 2 block; the palm end is a 2 x 11
  // lid from which the four fingers leave through 2 x 2 blocks with one column between them.
  void build_arm(const Side& side) {
    const double x = side.sign;
    const int arm_part =
        add_part({kSpine3, side.collar, side.shoulder, side.elbow, side.wrist, side.finger_joint(kIndex, 0),
                  side.finger_joint(kMiddle, 0), side.finger_joint(kPinky, 0), side.finger_joint(kRing, 0),
                  side.finger_joint(kThumb, 0)});
    // |x|, centre x, y, z, half height (y), half depth (z), exponent.
    const Profile arm{{0.150, 0.150 * x, 0.105, -0.018, 0.040, 0.038, 2.0},
                      {0.185, 0.185 * x, 0.110, -0.023, 0.045, 0.043, 2.1},
                      {0.225, 0.225 * x, 0.111, -0.027, 0.046, 0.045, 2.1},
                      {0.320, 0.320 * x, 0.109, -0.031, 0.040, 0.042, 2.0},
                      {0.400, 0.400 * x, 0.107, -0.034, 0.035, 0.037, 2.0},
                      {0.430, 0.430 * x, 0.105, -0.035, 0.034, 0.036, 2.0},
                      {0.500, 0.500 * x, 0.106, -0.034, 0.036, 0.041, 2.0},
                      {0.590, 0.590 * x, 0.108, -0.032, 0.030, 0.035, 2.0},
                      {0.665, 0.665 * x, 0.109, -0.030, 0.020, 0.029, 2.2},
                      {0.700, 0.700 * x, 0.108, -0.030, 0.017, 0.036, 2.6},
                      {0.735, 0.735 * x, 0.107, -0.029, 0.016, 0.038, 3.0},
                      {0.768, 0.768 * x, 0.106, -0.029, 0.014, 0.037, 3.2}};
    const std::vector<double> stations =
        ring_stations({{0.185, 0.365, 6}, {0.365, 0.455, 4}, {0.455, 0.665, 8}, {0.665, 0.697, 2}, {0.697, 0.768, 6}});
    std::vector<double> lambda;
    for (double s : stations) lambda.push_back(smoothstep((s - 0.45) / 0.23));
    // The thumb's block: palm rows from |x| = 0.697 to 0.721, on the palm edge facing +Z, which is
    // layout side 3 (U = -1) for the left arm and side 1 (U = +1) for the right (e_u is -Z on the
    // left, +Z on the right).
    const int thumb_row = 1 + static_cast<int>(std::find_if(stations.begin(), stations.end(),
                                                            [](double s) { return s > 0.69; }) - stations.begin());
    const Block thumb_block{thumb_row, x > 0 ? 24 : 11, 2, 2};
    const std::vector<int> rim = torso_->rim(x > 0 ? left_arm_block_ : right_arm_block_);
    Grid grid = child_tube(mesh(), arm_part, rim, {5, 8}, {2, 11}, lambda, sections(arm, stations), Vector3d::UnitY(),
                           Vector3d(x, 0.0, 0.0), {thumb_block});
    grid.emit_quads(mesh());
    body_.bone_ends[side.collar] = body_.joints[side.shoulder];
    body_.bone_ends[side.shoulder] = body_.joints[side.elbow];
    body_.bone_ends[side.elbow] = body_.joints[side.wrist];

    // Lid columns run along e_u: from the thumb side (+Z) on the left hand, from the little-finger
    // side on the right. Fingers take columns [0,2), [3,5), [6,8), [9,11) in that order.
    const std::array<int, 4> order = x > 0 ? std::array<int, 4>{kIndex, kMiddle, kRing, kPinky}
                                           : std::array<int, 4>{kPinky, kRing, kMiddle, kIndex};
    std::array<Block, 4> finger_blocks;
    for (int i = 0; i < 4; ++i) finger_blocks[i] = {0, 3 * i, 2, 2};
    const Vector3d along(x, 0.0, 0.0);
    const Grid palm = lid(mesh(), arm_part, grid.row(grid.rows() - 1), {2, 11}, along, 0.004,
                          {finger_blocks.begin(), finger_blocks.end()});
    for (int i = 0; i < 4; ++i) build_finger(side, order[i], palm.rim(finger_blocks[i]));
    build_thumb(side, grid.rim(thumb_block));
    body_.bone_ends[side.wrist] = body_.joints[side.finger_joint(kMiddle, 0)];
  }

  // A finger: straight along the arm from its lid block; the knuckle (joint 1) sits 6 mm inside
  // the palm behind the block's centre, then segments of the given lengths; rings about 7.5 mm
  // apart and a pole at the tip.
  void build_finger(const Side& side, int finger, const std::vector<int>& rim) {
    // Segment lengths (knuckle to middle joint, to end joint, to tip) and radius scale.
    constexpr std::array<std::array<double, 4>, 4> kFingers = {{{0.038, 0.024, 0.022, 1.00},
                                                                {0.042, 0.027, 0.024, 1.03},
                                                                {0.030, 0.019, 0.020, 0.85},
                                                                {0.038, 0.026, 0.023, 0.96}}};
    const auto& [l1, l2, l3, scale] = kFingers[finger];
    const int j1 = side.finger_joint(finger, 0);
    const int part = add_part({side.wrist, j1, j1 + 1, j1 + 2});
    const Vector3d along(side.sign, 0.0, 0.0);
    const Vector3d base = centroid(mesh(), rim);
    body_.joints[j1] = base - 0.006 * along;
    body_.joints[j1 + 1] = body_.joints[j1] + l1 * along;
    body_.joints[j1 + 2] = body_.joints[j1 + 1] + l2 * along;
    const Vector3d tip = body_.joints[j1 + 2] + l3 * along;
    const double length = (tip - base).dot(along);
    // s along the finger from the block, centre x, y, z, radius (both ways), exponent.
    // scale is captured by copy: clang 14 cannot capture a structured binding implicitly.
    const auto key = [&, scale = scale](double s, double radius) {
      Eigen::VectorXd row(6);
      row << base + s * along, radius * scale, radius * scale, 2.0;
      return row;
    };
    const Profile profile(
        {0.0, l1 - 0.006, l1 + l2 - 0.006, length - 0.004},
        {key(0.0, 0.0080), key(l1 - 0.006, 0.0070), key(l1 + l2 - 0.006, 0.0063), key(length - 0.004, 0.0052)});
    const int ring_count = static_cast<int>(std::round((length - 0.004) / 0.0075));
    std::vector<double> stations;
    for (int k = 1; k <= ring_count; ++k) stations.push_back((length - 0.004) * k / ring_count);
    const std::vector<double> lambda(stations.size(), 0.0);
    Grid grid = child_tube(mesh(), part, rim, {2, 2}, {2, 2}, lambda, sections(profile, stations), Vector3d::UnitY(),
                           along, {});
    grid.emit_quads(mesh());
    const int pole = mesh().add(tip, part);
    cap_with_pole(mesh(), grid.row(grid.rows() - 1), pole);
    body_.bone_ends[j1] = body_.joints[j1 + 1];
    body_.bone_ends[j1 + 1] = body_.joints[j1 + 2];
    body_.bone_ends[j1 + 2] = tip;
    // smplx/vertex_ids.py fingertips, in kIndex, kMiddle, kPinky, kRing order.
    constexpr std::array<int, 4> kLeftTips = {4933, 5058, 5286, 5169}, kRightTips = {7669, 7794, 8022, 7905};
    body_.keypoints.push_back({(side.sign > 0 ? kLeftTips : kRightTips)[finger], pole});
  }

  // The thumb leaves the palm's front edge, turns from the edge normal (+Z) toward its own
  // direction (forward, outward and a little down) and has three segments; its first joint (the
  // base of the thumb) lies 8 mm inside the palm edge.
  void build_thumb(const Side& side, const std::vector<int>& rim) {
    const int j1 = side.finger_joint(kThumb, 0);
    const int part = add_part({side.wrist, j1, j1 + 1, j1 + 2});
    const Vector3d base = centroid(mesh(), rim);
    const Vector3d direction = Vector3d(0.75 * side.sign, -0.22, 0.62).normalized();
    const Vector3d out = (direction + Vector3d::UnitZ()).normalized();
    body_.joints[j1] = base - 0.008 * Vector3d::UnitZ();
    body_.joints[j1 + 1] = base + 0.022 * out;
    body_.joints[j1 + 2] = body_.joints[j1 + 1] + 0.031 * direction;
    const Vector3d tip = body_.joints[j1 + 2] + 0.027 * direction;
    const Vector3d before_tip = tip - 0.004 * direction;
    const std::array<Vector3d, 4> path = {base, body_.joints[j1 + 1], body_.joints[j1 + 2], before_tip};
    const std::array<double, 4> radius = {0.0105, 0.0095, 0.0085, 0.0070};
    std::vector<double> s{0.0};
    std::vector<Eigen::VectorXd> keys;
    for (int i = 0; i < 4; ++i) {
      if (i > 0) s.push_back(s.back() + (path[i] - path[i - 1]).norm());
      Eigen::VectorXd row(6);
      row << path[i], radius[i], radius[i], 2.0;
      keys.push_back(row);
    }
    const Profile profile(s, keys);
    const int ring_count = static_cast<int>(std::round(s.back() / 0.0075));
    std::vector<double> stations;
    for (int k = 1; k <= ring_count; ++k) stations.push_back(s.back() * k / ring_count);
    const std::vector<double> lambda(stations.size(), 0.0);
    Grid grid = child_tube(mesh(), part, rim, {2, 2}, {2, 2}, lambda, sections(profile, stations), Vector3d::UnitY(),
                           std::nullopt, {});
    grid.emit_quads(mesh());
    const int pole = mesh().add(tip, part);
    cap_with_pole(mesh(), grid.row(grid.rows() - 1), pole);
    body_.bone_ends[j1] = body_.joints[j1 + 1];
    body_.bone_ends[j1 + 1] = body_.joints[j1 + 2];
    body_.bone_ends[j1 + 2] = tip;
    body_.keypoints.push_back({side.sign > 0 ? 5361 : 8079, pole});
  }

  // An eyeball: a sphere of radius 11.5 mm (11 rings of 15 between poles on the Z axis) behind the
  // eye opening, its front 1 mm behind the opening's rim; the eye joint is its centre.
  void build_eye(const Side& side, int side_index) {
    constexpr double kRadius = 0.0115;
    constexpr int kRings = 11, kColumns = 15;
    const int part = add_part({side.eye}, side.eye);
    const Vector3d centre = centroid(mesh(), body_.eye_rims[side_index]) - (kRadius + 0.001) * Vector3d::UnitZ();
    std::vector<Section> rings;
    for (int i = 1; i <= kRings; ++i) {
      const double polar = kPi * i / (kRings + 1);
      const double r = kRadius * std::sin(polar);
      rings.push_back({centre - kRadius * std::cos(polar) * Vector3d::UnitZ(), r, r, 2.0});
    }
    const Grid grid = root_tube(mesh(), part, rings, Vector3d::UnitY(), kColumns, Vector3d::UnitZ(), {});
    grid.emit_quads(mesh());
    const int back = mesh().add(centre - kRadius * Vector3d::UnitZ(), part);
    const int front = mesh().add(centre + kRadius * Vector3d::UnitZ(), part);
    cap_with_pole(mesh(), reversed(grid.row(0)), back);
    cap_with_pole(mesh(), grid.row(grid.rows() - 1), front);
    body_.joints[side.eye] = centre;
    body_.bone_ends[side.eye] = centre;
    body_.keypoints.push_back({side.sign > 0 ? 9448 : 9929, front});
  }

  // The nose tip and the ears (the sides of the head at ear height; there are no ear shells).
  void add_head_keypoints() {
    int nose = -1;
    for (int v = torso_tube_first_; v < torso_tube_end_; ++v) {
      const Vector3d& p = mesh().points[v];
      if (p.y() > 0.2 && p.y() < 0.3 && (nose < 0 || p.z() > mesh().points[nose].z())) nose = v;
    }
    body_.keypoints.push_back({9120, nose});
    for (const Side& side : kSides) {
      body_.keypoints.push_back(
          {side.sign > 0 ? 6 : 616, nearest({0.09 * side.sign, 0.275, -0.010}, body_.torso_part)});
    }
  }

  int nearest(const Vector3d& point, int part) const {
    int best = -1;
    double best_distance = std::numeric_limits<double>::infinity();
    for (std::size_t v = 0; v < body_.mesh.points.size(); ++v) {
      if (body_.mesh.part[v] != part) continue;
      const double d = (body_.mesh.points[v] - point).squaredNorm();
      if (d < best_distance) best_distance = d, best = static_cast<int>(v);
    }
    return best;
  }

  BodyMesh body_;
  std::vector<double> torso_heights_;
  std::unique_ptr<Grid> torso_, hip_lid_;
  Block left_arm_block_{}, right_arm_block_{}, mouth_block_{};
  int torso_tube_first_ = 0, torso_tube_end_ = 0;  // the torso tube's vertices (before limbs)
};


// Moves the vertices the smplx package reads as keypoints to the indices it reads, each swapped
// with the vertex that held that index; every other vertex keeps its place.
void place_keypoints(BodyMesh& body) {
  const int n = static_cast<int>(body.mesh.points.size());
  std::vector<int> new_of(n), old_of(n);
  for (int v = 0; v < n; ++v) new_of[v] = old_of[v] = v;
  for (const KeypointVertex& keypoint : body.keypoints) {
    const int source_slot = new_of[keypoint.vertex];
    const int displaced = old_of[keypoint.smplx_index];
    std::swap(new_of[keypoint.vertex], new_of[displaced]);
    old_of[keypoint.smplx_index] = keypoint.vertex;
    old_of[source_slot] = displaced;
  }
  Mesh relabelled;
  relabelled.points.resize(n);
  relabelled.part.resize(n);
  for (int v = 0; v < n; ++v) {
    relabelled.points[new_of[v]] = body.mesh.points[v];
    relabelled.part[new_of[v]] = body.mesh.part[v];
  }
  relabelled.triangles = body.mesh.triangles;
  for (Vector3i& t : relabelled.triangles) t = Vector3i(new_of[t[0]], new_of[t[1]], new_of[t[2]]);
  body.mesh = std::move(relabelled);
  for (std::vector<int>* rim : {&body.eye_rims[0], &body.eye_rims[1], &body.mouth_rim}) {
    for (int& v : *rim) v = new_of[v];
  }
  for (KeypointVertex& keypoint : body.keypoints) keypoint.vertex = keypoint.smplx_index;
}

using SparseRows = Eigen::SparseMatrix<double, Eigen::RowMajor>;

// How far each bone's influence reaches: `across` from the bone's line (about 1.6 times the
// radius of the body around it, so the whole cross-section follows), and `beyond` past either
// end along it (the half-width of the blend zone at a joint). Trunk bones reach far across but
// only a hand's breadth beyond their ends, so the spine never reaches into the head.
struct Reach {
  double across, beyond;
};
Reach bone_reach(int joint) {
  switch (joint) {
    case kPelvis: return {0.22, 0.10};
    case kSpine1: return {0.20, 0.10};
    case kSpine2: case kSpine3: return {0.20, 0.08};
    case kNeck: return {0.08, 0.04};
    case kHead: return {0.16, 0.05};
    case kJaw: return {0.06, 0.06};
    default: break;
  }
  for (const Side& side : kSides) {
    if (joint == side.hip) return {0.14, 0.08};
    if (joint == side.knee) return {0.10, 0.08};
    if (joint == side.ankle) return {0.08, 0.06};
    if (joint == side.foot) return {0.06, 0.06};
    if (joint == side.collar) return {0.10, 0.06};
    if (joint == side.shoulder) return {0.09, 0.08};
    if (joint == side.elbow) return {0.08, 0.07};
    if (joint == side.wrist) return {0.06, 0.02};
    if (joint == side.eye) return {0.02, 0.02};
    if (joint >= side.finger_joint(kThumb, 0) && joint < side.hand + 15) return {0.025, 0.014};
    if (joint >= side.hand && joint < side.hand + 15) return {0.022, 0.012};
  }
  throw std::logic_error("synthetic body: no reach for joint " + std::to_string(joint));
}

// The normalised distance from p to the bone a-b: with rho the distance from the bone's line and
// o how far p lies past the nearer end along it (0 between the ends),
//   q = sqrt((rho / across)^2 + (o / beyond)^2),
// so q < 1 is the bone's reach, a capsule stretched or squashed along the bone.
// (An eye's bone is a point: q = |p - a| / beyond.)
double bone_distance(const Vector3d& p, const Vector3d& a, const Vector3d& b, const Reach& reach) {
  const double length = (b - a).norm();
  if (length == 0.0) return (p - a).norm() / reach.beyond;
  const Vector3d axis = (b - a) / length;
  const double along = (p - a).dot(axis);
  const double rho = (p - a - along * axis).norm();
  const double past = std::max({0.0, -along, along - length});
  return std::hypot(rho / reach.across, past / reach.beyond);
}

// 1 below the mouth line, 0 above it: the jaw moves the lower lip and chin, never the upper
// lip. The step is 4 mm wide between the lips (which sit 2.8 mm either side of the line) and
// widens past the mouth corners so the cheeks stretch instead of tearing.
double lower_face(const Vector3d& p) {
  const double half_width = 0.002 + 0.5 * std::max(0.0, std::abs(p.x()) - 0.025);
  return smoothstep((kMouthY + half_width - p.y()) / (2.0 * half_width));
}

// Skinning weights. Each bone j (joint j to its bone end) draws a vertex with affinity
//   a_j(v) = bump(q_j(v) / s),  q_j the normalised distance to the bone (bone_distance),
// over the bones the vertex's part may follow; the jaw's affinity is multiplied by lower_face().
// Keeping the K largest affinities without a jump where the K-th and (K+1)-th trade places:
//   w_j = max(0, a_j - a_(K+1)) / sum_i max(0, a_i - a_(K+1)),
// which goes to zero continuously as a_j falls to the (K+1)-th largest value. The model uses
// K = 4 and s = 1. The dense variant, for benchmarks, spreads weights the way the licensed model
// does: K = 8, s = 3, and each part may also follow the parents and children of its bones.
SparseRows skinning_weights(const BodyMesh& body, bool dense) {
  const int max_influences = dense ? 8 : 4;
  const double reach_scale = dense ? 3.0 : 1.0;
  std::vector<std::vector<int>> bones_of_part;
  for (const Part& part : body.parts) {
    std::vector<int> bones = part.bones;
    if (dense) {
      for (int j : part.bones) {
        if (kParents[j] >= 0) bones.push_back(kParents[j]);
        for (int child = 0; child < kJoints; ++child) {
          if (kParents[child] == j) bones.push_back(child);
        }
      }
      std::sort(bones.begin(), bones.end());
      bones.erase(std::unique(bones.begin(), bones.end()), bones.end());
    }
    bones_of_part.push_back(std::move(bones));
  }
  const int n = static_cast<int>(body.mesh.points.size());
  std::vector<Eigen::Triplet<double>> entries;
  std::vector<std::pair<double, int>> affinity;
  for (int v = 0; v < n; ++v) {
    const Part& part = body.parts[body.mesh.part[v]];
    if (part.rigid_joint >= 0) {
      entries.emplace_back(v, part.rigid_joint, 1.0);
      continue;
    }
    const Vector3d& p = body.mesh.points[v];
    affinity.clear();
    for (int j : bones_of_part[body.mesh.part[v]]) {
      double a = bump(bone_distance(p, body.joints[j], body.bone_ends[j], bone_reach(j)) / reach_scale);
      if (j == kJaw) a *= lower_face(p);
      affinity.emplace_back(a, j);
    }
    std::sort(affinity.begin(), affinity.end(), std::greater<>());
    const int kept = std::min(max_influences, static_cast<int>(affinity.size()));
    const double floor = kept < static_cast<int>(affinity.size()) ? affinity[kept].first : 0.0;
    double total = 0.0;
    for (int i = 0; i < kept; ++i) total += std::max(0.0, affinity[i].first - floor);
    if (!(total > 0.0)) {
      throw std::logic_error("synthetic body: vertex " + std::to_string(v) + " is out of reach of its part's bones");
    }
    for (int i = 0; i < kept; ++i) {
      const double w = std::max(0.0, affinity[i].first - floor) / total;
      if (w > 0.0) entries.emplace_back(v, affinity[i].second, w);
    }
  }
  SparseRows weights(n, kJoints);
  weights.setFromTriplets(entries.begin(), entries.end());
  return weights;
}

// Maximum-entropy convex weights reproducing `target`: w_i = b_i exp(l.(v_i - J)) / Z, with l
// minimising the convex f(l) = log sum_i b_i exp(l.(v_i - J)). At the minimum the gradient
// sum_i w_i (v_i - J) is zero, so sum_i w_i v_i = J exactly with every w_i > 0 and sum 1. A
// minimum exists exactly when J lies strictly inside the convex hull of the points; Newton's
// method (Hessian = the weighted covariance of v_i - J) with backtracking finds it in a few
// steps. Returns false when it does not converge (J outside or on the hull).
bool max_entropy_weights(const std::vector<Vector3d>& points, const std::vector<double>& prior, const Vector3d& target,
                         std::vector<double>& weights) {
  const std::size_t n = points.size();
  weights.assign(n, 0.0);
  const auto evaluate = [&](const Vector3d& lambda, std::vector<double>& w) {
    double top = -std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < n; ++i) top = std::max(top, lambda.dot(points[i] - target));
    double z = 0.0;
    for (std::size_t i = 0; i < n; ++i) z += (w[i] = prior[i] * std::exp(lambda.dot(points[i] - target) - top));
    for (double& wi : w) wi /= z;
    return std::log(z) + top;
  };
  Vector3d lambda = Vector3d::Zero();
  double f = evaluate(lambda, weights);
  std::vector<double> trial(n);
  for (int iteration = 0; iteration < 100; ++iteration) {
    Vector3d gradient = Vector3d::Zero();
    Matrix3d second = Matrix3d::Zero();
    for (std::size_t i = 0; i < n; ++i) {
      const Vector3d d = points[i] - target;
      gradient += weights[i] * d;
      second += weights[i] * d * d.transpose();
    }
    if (gradient.norm() < 1e-13) return true;
    const Matrix3d hessian = second - gradient * gradient.transpose();
    const Vector3d step = hessian.ldlt().solve(gradient);
    double scale = 1.0;
    for (; scale > 1e-6; scale *= 0.5) {
      const double f_trial = evaluate(lambda - scale * step, trial);
      if (f_trial < f) {
        lambda -= scale * step;
        f = f_trial;
        weights.swap(trial);
        break;
      }
    }
    if (scale <= 1e-6) return false;
  }
  return false;
}

// J_regressor: for each joint, the maximum-entropy weights of the vertices around it (of the
// parts that follow that joint) with prior bump(distance / rho). rho starts at 1.3 times the
// distance to the nearest such vertex and grows by 15% until the joint lies inside their hull,
// so each row is a ring or shell of vertices hugging the joint.
SparseRows joint_regressor(const BodyMesh& body) {
  const int n = static_cast<int>(body.mesh.points.size());
  std::vector<Eigen::Triplet<double>> entries;
  for (int j = 0; j < kJoints; ++j) {
    std::vector<std::pair<double, int>> candidates;
    for (int v = 0; v < n; ++v) {
      const Part& part = body.parts[body.mesh.part[v]];
      if (part.rigid_joint == j || std::find(part.bones.begin(), part.bones.end(), j) != part.bones.end()) {
        candidates.emplace_back((body.mesh.points[v] - body.joints[j]).norm(), v);
      }
    }
    std::sort(candidates.begin(), candidates.end());
    bool solved = false;
    std::vector<Vector3d> points;
    std::vector<double> prior, weights;
    std::vector<int> ids;
    for (double rho = 1.3 * std::max(candidates.front().first, 0.004); !solved && rho < 0.6; rho *= 1.15) {
      points.clear();
      prior.clear();
      ids.clear();
      for (const auto& [distance, v] : candidates) {
        if (distance >= rho) break;
        points.push_back(body.mesh.points[v]);
        prior.push_back(bump(distance / rho));
        ids.push_back(v);
      }
      solved = points.size() >= 8 && max_entropy_weights(points, prior, body.joints[j], weights);
    }
    if (!solved)
      throw std::logic_error("synthetic body: joint " + kJointNames[j] + " is outside its vertices");
    for (std::size_t i = 0; i < ids.size(); ++i) entries.emplace_back(j, ids[i], weights[i]);
  }
  SparseRows regressor(kJoints, n);
  regressor.setFromTriplets(entries.begin(), entries.end());
  return regressor;
}

std::vector<Vector3d> vertex_normals(const Mesh& mesh) {
  std::vector<Vector3d> normals(mesh.points.size(), Vector3d::Zero());
  for (const Vector3i& t : mesh.triangles) {
    // The cross product's length is twice the area: area-weighted face normals.
    const Vector3d n = (mesh.points[t[1]] - mesh.points[t[0]]).cross(mesh.points[t[2]] - mesh.points[t[0]]);
    for (int c = 0; c < 3; ++c) normals[t[c]] += n;
  }
  for (Vector3d& n : normals) n.normalize();
  return normals;
}

// Shape and expression directions: 3V x 400, row 3v + c, shape columns 0-299 then expression.
class ShapeSpace {
 public:
  ShapeSpace(const BodyMesh& body, const SparseRows& weights, Random& random)
      : body_(body), weights_(weights), normals_(vertex_normals(body.mesh)), random_(random),
        dirs_(RowMatrixXd::Zero(3 * body.mesh.points.size(), kShapeCount + kExpressionCount)) {
    for (int j = 0; j < kJoints; ++j) {
      const Vector3d bone = body.bone_ends[j] - body.joints[j];
      axis_[j] = bone.norm() > 0.0 ? bone.normalized() : Vector3d::Zero();
    }
    skeletal_directions();
    for (int k = kMeaningfulShapes; k < kShapeCount; ++k) bulge(k);
    expressions();
  }
  RowMatrixXd take() { return std::move(dirs_); }

 private:
  using JointMaps = std::array<Matrix3d, kJoints>;

  // A skeletal deformation: joint j's neighbourhood moves by x -> x + t_j + M_j (x - J_j), with
  // t_0 = 0 and t_j = t_p + M_p (J_j - J_p) (each joint rides on its parent's deformation), and a
  // vertex moves by the skinning blend of these maps:
  //   d(v) = sum_j w_vj (t_j + M_j (v - J_j)).
  // Blending by the weights keeps the field smooth across joints; with M_j = s I for all j it is
  // exactly the uniform scale s (v - J_0), since the weights sum to 1.
  void skeletal(int column, const JointMaps& maps) {
    std::array<Vector3d, kJoints> translation;
    translation[0].setZero();
    for (int j = 1; j < kJoints; ++j) {
      const int p = kParents[j];
      translation[j] = translation[p] + maps[p] * (body_.joints[j] - body_.joints[p]);
    }
    for (int v = 0; v < weights_.rows(); ++v) {
      Vector3d d = Vector3d::Zero();
      const Vector3d& x = body_.mesh.points[v];
      for (SparseRows::InnerIterator it(weights_, v); it; ++it) {
        const int j = static_cast<int>(it.col());
        d += it.value() * (translation[j] + maps[j] * (x - body_.joints[j]));
      }
      dirs_.block<3, 1>(3 * v, column) = d;
    }
  }

  Matrix3d along(int j, double s) const { return s * axis_[j] * axis_[j].transpose(); }
  Matrix3d across(int j, double s) const { return s * (Matrix3d::Identity() - axis_[j] * axis_[j].transpose()); }
  static Matrix3d axis(int a, double s) {
    Matrix3d m = Matrix3d::Zero();
    m(a, a) = s;
    return m;
  }

  // Shape directions 0-9 (per unit of beta): 0 size (4% uniform scale about the pelvis, 7 cm of
  // height), 1 girth (trunk 10-13%, limbs 5-10% radially), 2 limb length (thighs, shins, upper
  // arms and forearms 6% longer), 3 shoulder width (collar bones 15% longer), 4 hip width
  // (pelvis 15% wider), 5 torso length (spine 8% longer), 6 head size (6%), 7 torso depth
  // (chest and belly 6-12% deeper), 8 arm versus leg girth (arms 7-8% thicker, legs 4-5%
  // thinner), 9 hand and foot size (8% and 6%).
  void skeletal_directions() {
    JointMaps maps;
    const auto reset = [&] { maps.fill(Matrix3d::Zero()); };
    reset();
    for (Matrix3d& m : maps) m = 0.04 * Matrix3d::Identity();
    skeletal(0, maps);

    reset();
    maps[kPelvis] = across(kPelvis, 0.12);
    maps[kSpine1] = across(kSpine1, 0.13);
    maps[kSpine2] = across(kSpine2, 0.12);
    maps[kSpine3] = across(kSpine3, 0.10);
    maps[kNeck] = across(kNeck, 0.06);
    maps[kHead] = across(kHead, 0.02);
    maps[kJaw] = across(kJaw, 0.02);
    for (const Side& side : kSides) {
      maps[side.hip] = across(side.hip, 0.10);
      maps[side.knee] = across(side.knee, 0.06);
      maps[side.ankle] = across(side.ankle, 0.03);
      maps[side.foot] = across(side.foot, 0.02);
      maps[side.collar] = across(side.collar, 0.05);
      maps[side.shoulder] = across(side.shoulder, 0.07);
      maps[side.elbow] = across(side.elbow, 0.05);
      maps[side.wrist] = across(side.wrist, 0.02);
      for (int j = side.hand; j < side.hand + 15; ++j) maps[j] = across(j, 0.02);
    }
    skeletal(1, maps);

    reset();
    for (const Side& side : kSides) {
      for (int j : {side.hip, side.knee, side.shoulder, side.elbow}) maps[j] = along(j, 0.06);
    }
    skeletal(2, maps);

    reset();
    for (const Side& side : kSides) maps[side.collar] = along(side.collar, 0.15);
    skeletal(3, maps);

    reset();
    maps[kPelvis] = axis(0, 0.15);
    skeletal(4, maps);

    reset();
    for (int j : {kSpine1, kSpine2, kSpine3}) maps[j] = along(j, 0.08);
    skeletal(5, maps);

    reset();
    maps[kHead] = maps[kJaw] = 0.06 * Matrix3d::Identity();
    skeletal(6, maps);

    reset();
    maps[kPelvis] = axis(2, 0.06);
    maps[kSpine1] = maps[kSpine2] = axis(2, 0.12);
    maps[kSpine3] = axis(2, 0.08);
    skeletal(7, maps);

    reset();
    for (const Side& side : kSides) {
      maps[side.shoulder] = across(side.shoulder, 0.08);
      maps[side.elbow] = across(side.elbow, 0.07);
      maps[side.hip] = across(side.hip, -0.05);
      maps[side.knee] = across(side.knee, -0.04);
    }
    skeletal(8, maps);

    reset();
    for (const Side& side : kSides) {
      for (int j = side.hand; j < side.hand + 15; ++j) maps[j] = 0.08 * Matrix3d::Identity();
      maps[side.wrist] = 0.08 * Matrix3d::Identity();
      maps[side.ankle] = maps[side.foot] = 0.06 * Matrix3d::Identity();
    }
    skeletal(9, maps);
  }

  // Shape directions 10-299: a bulge along the surface normal, bump(distance / r) with r in
  // 4-10 cm around a random vertex (eyeballs excluded), its amplitude falling with the index
  // like a PCA spectrum: 5 mm / (1 + (k - 10) / 25).
  void bulge(int column) {
    int centre;
    do centre = random_.index(static_cast<int>(body_.mesh.points.size()));
    while (body_.parts[body_.mesh.part[centre]].rigid_joint >= 0);
    const double radius = random_.uniform(0.04, 0.10);
    const double amplitude = 0.005 / (1.0 + (column - kMeaningfulShapes) / 25.0);
    const Vector3d c = body_.mesh.points[centre];
    for (std::size_t v = 0; v < body_.mesh.points.size(); ++v) {
      if (body_.parts[body_.mesh.part[v]].rigid_joint >= 0) continue;
      const double b = bump((body_.mesh.points[v] - c).norm() / radius);
      if (b > 0.0) dirs_.block<3, 1>(3 * v, column) = amplitude * b * normals_[v];
    }
  }

  // Where the face is: the front of the head (z > 1 cm, smoothly), within an ellipse 16 cm wide
  // and 18 cm tall around the nose. Every expression direction is multiplied by it, so they are
  // exactly zero off the face.
  double face(int v) const {
    const Vector3d& p = body_.mesh.points[v];
    if (body_.parts[body_.mesh.part[v]].rigid_joint >= 0 || p.y() < 0.15) return 0.0;
    return bump(std::hypot(p.x() / 0.08, (p.y() - 0.262) / 0.09)) * smoothstep((p.z() - 0.01) / 0.04);
  }
  static double near(const Vector3d& p, const Vector2d& centre, double radius) {
    return bump(std::hypot(p.x() - centre.x(), p.y() - centre.y()) / radius);
  }

  // Expression directions 0-9 (columns 300-309), displacements per unit: 0 mouth open (lower
  // face 8 mm down), 1 smile (corners 4 mm up and 3 mm out), 2 brows up 5 mm, 3 frown (inner
  // brows down and in), 4 pucker (lips 5 mm forward, mouth 25% narrower), 5 cheeks puffed 6 mm,
  // 6 eyes closed (upper lids 6 mm down), 7 mouth corners down 4 mm, 8 nose wrinkle, 9 jaw 6 mm
  // sideways; then 90 small bulges (1-3 cm across, 2 mm falling with the index) on the face.
  void expressions() {
    const Vector2d left_corner = body_.mesh.points[body_.mouth_rim[7]].head<2>();
    const Vector2d right_corner = body_.mesh.points[body_.mouth_rim[15]].head<2>();
    const std::array<Vector2d, 2> corners = {left_corner, right_corner};
    std::array<Vector2d, 2> upper_lids;
    for (int s = 0; s < 2; ++s) upper_lids[s] = body_.mesh.points[body_.eye_rims[s][7]].head<2>();
    std::vector<int> face_vertices;
    const int first = kShapeCount;
    for (int v = 0; v < static_cast<int>(body_.mesh.points.size()); ++v) {
      const double mask = face(v);
      if (mask <= 0.0) continue;
      if (mask > 0.3) face_vertices.push_back(v);
      const Vector3d& p = body_.mesh.points[v];
      const auto set = [&](int e, const Vector3d& d) { dirs_.block<3, 1>(3 * v, first + e) = mask * d; };
      set(0, lower_face(p) * Vector3d(0.0, -0.008, -0.002));
      Vector3d smile = Vector3d::Zero(), frown = Vector3d::Zero(), cheeks = Vector3d::Zero(), lids = Vector3d::Zero(),
               down = Vector3d::Zero();
      for (int s = 0; s < 2; ++s) {
        const double sign = kSides[s].sign;
        smile += near(p, corners[s], 0.022) * Vector3d(0.003 * sign, 0.004, -0.002);
        frown += near(p, {0.016 * sign, 0.316}, 0.018) * Vector3d(-0.002 * sign, -0.003, 0.001);
        cheeks += near(p, {0.048 * sign, 0.240}, 0.025) * 0.006 * normals_[v];
        lids += near(p, upper_lids[s], 0.012) * Vector3d(0.0, -0.006, 0.001);
        down += near(p, corners[s], 0.020) * Vector3d(0.0, -0.004, 0.0);
      }
      set(1, smile);
      set(2, bump(std::hypot(p.x() / 0.055, (p.y() - 0.318) / 0.018)) * Vector3d(0.0, 0.005, 0.0));
      set(3, frown);
      set(4, near(p, {0.0, kMouthY}, 0.030) * Vector3d(-0.25 * p.x(), 0.0, 0.005));
      set(5, cheeks);
      set(6, lids);
      set(7, down);
      set(8, near(p, {0.0, 0.285}, 0.018) * Vector3d(0.0, 0.003, -0.001));
      set(9, lower_face(p) * Vector3d(0.006, 0.0, 0.0));
    }
    for (int e = 10; e < kExpressionCount; ++e) {
      const Vector3d c = body_.mesh.points[face_vertices[random_.index(static_cast<int>(face_vertices.size()))]];
      const double radius = random_.uniform(0.01, 0.03);
      const double amplitude = 0.002 / (1.0 + (e - 10) / 30.0);
      for (int v = 0; v < static_cast<int>(body_.mesh.points.size()); ++v) {
        const double mask = face(v);
        const double b = bump((body_.mesh.points[v] - c).norm() / radius);
        if (mask > 0.0 && b > 0.0) dirs_.block<3, 1>(3 * v, first + e) = amplitude * mask * b * normals_[v];
      }
    }
  }

  const BodyMesh& body_;
  const SparseRows& weights_;
  std::vector<Vector3d> normals_;
  Random& random_;
  RowMatrixXd dirs_;
  std::array<Vector3d, kJoints> axis_;
};

// Pose correctives. Linear blend skinning averages the transforms of a blend zone's joints, so a
// bending joint collapses there; the corrective rotates those vertices a little further with the
// joint, about the joint:
//   offset(v) = c(v) (R_j - I)(v - J_j),  c(v) = 0.15 * 4 w (1 - w) * bump(|v - J_j| / across_j),
// w = w_vj, which is linear in the pose feature R_j - I as the model requires:
//   posedirs[3v + a, 9 (j - 1) + 3 a + b] = c(v) (v - J_j)_b.
// c vanishes where w is 0 or 1 and beyond the bone's reach from the joint, so rows away from
// the joints are exactly zero. The dense variant adds 0.0075 exp(-|v - J_j|^2 / (0.3 m)^2) for
// every joint, so every entry is filled.
RowMatrixXf pose_correctives(const RowMatrixXd& vertices, const RowMatrixXd& joints, const SparseRows& weights,
                             bool dense) {
  const int n = static_cast<int>(vertices.rows());
  RowMatrixXf posedirs = RowMatrixXf::Zero(3 * n, 9 * (kJoints - 1));
  for (int v = 0; v < n; ++v) {
    std::array<double, kJoints> w{};
    for (SparseRows::InnerIterator it(weights, v); it; ++it) w[it.col()] = it.value();
    for (int j = 1; j < kJoints; ++j) {
      const Eigen::RowVector3d offset = vertices.row(v) - joints.row(j);
      double c = 0.15 * 4.0 * w[j] * (1.0 - w[j]) * bump(offset.norm() / bone_reach(j).across);
      if (dense) c += 0.0075 * std::exp(-offset.squaredNorm() / 0.09);
      if (c == 0.0) continue;
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) posedirs(3 * v + a, 9 * (j - 1) + 3 * a + b) = static_cast<float>(c * offset[b]);
      }
    }
  }
  return posedirs;
}

// Hand pose PCA in the smplx layout: 45 numbers a hand (15 joints x axis-angle, joints in model
// order index, middle, pinky, ring, thumb). Components are orthonormal rows: the first five are
// designed (curl of all fingers, spread, thumb opposition, curl toward the index versus toward the
// little finger, knuckles versus finger ends), the rest complete them by Gram-Schmidt from random
// vectors. The mean is a relaxed, gently curled hand. The right hand mirrors the left through
// the X = 0 plane, which maps an axis-angle (x, y, z) to (x, -y, -z).
struct HandPca {
  RowMatrixXd left_components, right_components;
  Eigen::VectorXd left_mean, right_mean;
};

using HandPose = Eigen::Matrix<double, 45, 1>;

HandPca hand_pca(const std::array<Vector3d, kJoints>& joints, Random& random) {
  // Flexion axes of the left hand: fingers point along +X with the palm down, so curling toward
  // the palm turns about -Z; the thumb curls about (its direction) x (-Y).
  const Vector3d finger_flexion(0.0, 0.0, -1.0);
  const int thumb = kLeft.finger_joint(kThumb, 0);
  const Vector3d thumb_direction = (joints[thumb + 2] - joints[thumb + 1]).normalized();
  const Vector3d thumb_flexion = thumb_direction.cross(-Vector3d::UnitY()).normalized();
  const auto pose = [](std::initializer_list<std::pair<int, Vector3d>> rotations) {
    HandPose p = HandPose::Zero();
    for (const auto& [joint, r] : rotations) p.segment<3>(3 * joint) += r;
    return p;
  };
  const auto segment = [](int finger, int s) { return 3 * finger + s; };
  std::vector<HandPose> design;
  HandPose curl = HandPose::Zero(), radial = HandPose::Zero(), proximal = HandPose::Zero();
  constexpr std::array<double, 3> kCurl = {1.0, 1.1, 0.8};
  constexpr std::array<double, 4> kRadial = {1.0, 0.5, -1.0, -0.5};  // index, middle, pinky, ring
  constexpr std::array<double, 3> kProximal = {1.0, -0.5, -1.0};
  for (int f = kIndex; f <= kRing; ++f) {
    for (int s = 0; s < 3; ++s) {
      curl.segment<3>(3 * segment(f, s)) = kCurl[s] * finger_flexion;
      radial.segment<3>(3 * segment(f, s)) = kRadial[f] * finger_flexion;
      proximal.segment<3>(3 * segment(f, s)) = kProximal[s] * finger_flexion;
    }
  }
  for (int s = 0; s < 3; ++s) curl.segment<3>(3 * segment(kThumb, s)) = 0.5 * thumb_flexion;
  design.push_back(curl);
  design.push_back(pose({{segment(kIndex, 0), {0, -1.0, 0}}, {segment(kMiddle, 0), {0, -0.3, 0}},
                         {segment(kRing, 0), {0, 0.4, 0}}, {segment(kPinky, 0), {0, 1.0, 0}}}));
  design.push_back(pose({{segment(kThumb, 0), Vector3d(0.2, 1.0, 0.3)},
                         {segment(kThumb, 1), 0.5 * thumb_flexion},
                         {segment(kThumb, 2), 0.3 * thumb_flexion}}));
  design.push_back(radial);
  design.push_back(proximal);

  Eigen::Matrix<double, 45, 45, Eigen::RowMajor> components;
  int rank = 0;
  const auto orthonormal_add = [&](HandPose v) {
    // Modified Gram-Schmidt, twice: one pass leaves errors of order eps * cond; the second
    // brings them to eps.
    for (int pass = 0; pass < 2; ++pass) {
      for (int i = 0; i < rank; ++i) v -= components.row(i).dot(v) * components.row(i).transpose();
    }
    if (v.norm() < 1e-6) return;
    components.row(rank++) = v.normalized().transpose();
  };
  for (const HandPose& d : design) orthonormal_add(d);
  while (rank < 45) {
    HandPose v;
    for (int i = 0; i < 45; ++i) v[i] = random.normal();
    orthonormal_add(v);
  }

  HandPose mean = HandPose::Zero();
  constexpr std::array<double, 3> kMeanCurl = {0.15, 0.25, 0.18};
  constexpr std::array<double, 4> kFingerCurl = {1.0, 1.05, 1.2, 1.1};  // index, middle, pinky, ring
  for (int f = kIndex; f <= kRing; ++f) {
    for (int s = 0; s < 3; ++s) mean.segment<3>(3 * segment(f, s)) = kMeanCurl[s] * kFingerCurl[f] * finger_flexion;
  }
  constexpr std::array<double, 3> kThumbCurl = {0.10, 0.15, 0.10};
  for (int s = 0; s < 3; ++s) mean.segment<3>(3 * segment(kThumb, s)) = kThumbCurl[s] * thumb_flexion;

  const auto mirror = [](HandPose p) {
    for (int j = 0; j < 15; ++j) p.segment<2>(3 * j + 1) *= -1.0;
    return p;
  };
  HandPca pca;
  pca.left_components = components;
  pca.right_components.resize(45, 45);
  for (int i = 0; i < 45; ++i) pca.right_components.row(i) = mirror(components.row(i).transpose()).transpose();
  pca.left_mean = mean;
  pca.right_mean = mirror(mean);
  return pca;
}

// Ray casting onto the head's skin (torso triangles above the neck; eyeballs excluded).
class HeadSkin {
 public:
  HeadSkin(const RowMatrixXd& vertices, const RowMatrixXi& faces, const std::vector<int>& part, int torso_part)
      : vertices_(vertices), faces_(faces) {
    for (int f = 0; f < faces.rows(); ++f) {
      bool head = true;
      for (int c = 0; c < 3; ++c) head = head && part[faces(f, c)] == torso_part && vertices(faces(f, c), 1) > 0.17;
      if (head) triangles_.push_back(f);
    }
  }

  // The nearest hit of origin + t direction (t > 0): triangle and barycentric coordinates of
  // its corners (Moller-Trumbore).
  std::pair<int, Vector3d> cast(const Vector3d& origin, const Vector3d& direction) const {
    std::pair<int, Vector3d> best{-1, Vector3d::Zero()};
    double best_t = std::numeric_limits<double>::infinity();
    for (int f : triangles_) {
      const Vector3d a = vertices_.row(faces_(f, 0)).transpose(), b = vertices_.row(faces_(f, 1)).transpose(),
                     c = vertices_.row(faces_(f, 2)).transpose();
      const Vector3d e1 = b - a, e2 = c - a;
      const Vector3d h = direction.cross(e2);
      const double det = e1.dot(h);
      if (std::abs(det) < 1e-14) continue;
      const Vector3d s = origin - a;
      const double u = s.dot(h) / det;
      const Vector3d q = s.cross(e1);
      const double w = direction.dot(q) / det;
      const double t = e2.dot(q) / det;
      if (u < -1e-9 || w < -1e-9 || u + w > 1.0 + 1e-9 || t <= 0.0 || t >= best_t) continue;
      best_t = t;
      best = {f, Vector3d(1.0 - u - w, u, w)};
    }
    if (best.first < 0) throw std::logic_error("synthetic body: a landmark ray missed the head");
    best.second = best.second.cwiseMax(0.0);
    best.second /= best.second.sum();
    return best;
  }
  // The head seen from the front: the first hit of a ray along -Z through (x, y).
  std::pair<int, Vector3d> front(double x, double y) const { return cast({x, y, 1.0}, -Vector3d::UnitZ()); }
  // The point (1 - t) a + t b on the edge a-b: a triangle holding both, and its barycentric
  // coordinates.
  std::pair<int, Vector3d> on_edge(int a, int b, double t) const {
    for (int f : triangles_) {
      Vector3d bary = Vector3d::Zero();
      int found = 0;
      for (int c = 0; c < 3; ++c) {
        if (faces_(f, c) == a) bary[c] = 1.0 - t, ++found;
        if (faces_(f, c) == b) bary[c] = t, ++found;
      }
      if (found == 2) return {f, bary};
    }
    throw std::logic_error("synthetic body: no triangle on a landmark edge");
  }
  // Vertex v itself: a triangle holding it, with barycentric coordinates 1 there.
  std::pair<int, Vector3d> at_vertex(int v) const {
    for (int f : triangles_) {
      for (int c = 0; c < 3; ++c) {
        if (faces_(f, c) == v) return {f, Vector3d::Unit(c)};
      }
    }
    throw std::logic_error("synthetic body: no triangle at a landmark vertex");
  }

 private:
  const RowMatrixXd& vertices_;
  const RowMatrixXi& faces_;
  std::vector<int> triangles_;
};

// Landmarks after the iBUG 68-point layout (subject's right first, i.e. image left to right).
// Brows and nose are the front view's hits at designed (x, y); eye and inner lip points lie on
// the rims of the openings (corners at the rim's ends, lids at thirds); the outer lip contour
// runs 8-10 mm outside the slit. The jaw-line contour point k (k = 0 at the right ear, 8 the
// chin, 16 the left ear) lies on the skin at height 0.196 + 0.066 |u|^3 m and azimuth
// 78 u + a(b) degrees (from +Z toward +X, u = (k - 8) / 8, clamped to +-100 degrees), cast from
// the head's axis: as the head turns by a, the outline a camera in front sees moves by a over the
// face, which is what the smplx package's lookup by yaw expects.
FaceLandmarks face_landmarks(const HeadSkin& skin, const BodyMesh& body, const RowMatrixXd& vertices) {
  FaceLandmarks out;
  out.faces.reserve(FaceLandmarks::kStaticCount);
  out.barycentric.resize(FaceLandmarks::kStaticCount, 3);
  const auto add = [&](const std::pair<int, Vector3d>& hit) {
    for (int c = 0; c < 3; ++c) out.barycentric(static_cast<Eigen::Index>(out.faces.size()), c) = hit.second[c];
    out.faces.push_back(hit.first);
  };
  for (double x : {-0.052, -0.043, -0.033, -0.022, -0.011}) add(skin.front(x, 0.323 - 12.0 * std::pow(x + 0.03, 2)));
  for (double x : {0.011, 0.022, 0.033, 0.043, 0.052}) add(skin.front(x, 0.323 - 12.0 * std::pow(x - 0.03, 2)));
  for (double y : {0.300, 0.287, 0.274, 0.261}) add(skin.front(0.0, y));
  for (double x : {-0.013, -0.0065, 0.0, 0.0065, 0.013}) add(skin.front(x, 0.243 - 20.0 * x * x));
  // Eye rims (Layout order of a 1 x 4 block): lower row 0-4 from the block's first column, upper
  // row 5-9 back. Right eye (block at columns 58-62, outer corner first), then left (2-6, inner
  // corner first); both listed from the subject's right.
  const std::vector<int>& right = body.eye_rims[1];
  const std::vector<int>& left = body.eye_rims[0];
  add(skin.on_edge(right[9], right[0], 0.5));   // 36 outer corner
  add(skin.on_edge(right[8], right[7], 1.0 / 3));  // 37, 38 upper lid
  add(skin.on_edge(right[7], right[6], 2.0 / 3));
  add(skin.on_edge(right[4], right[5], 0.5));   // 39 inner corner
  add(skin.on_edge(right[2], right[3], 2.0 / 3));  // 40, 41 lower lid, inner to outer
  add(skin.on_edge(right[1], right[2], 1.0 / 3));
  add(skin.on_edge(left[9], left[0], 0.5));     // 42 inner corner
  add(skin.on_edge(left[8], left[7], 1.0 / 3));    // 43, 44 upper lid
  add(skin.on_edge(left[7], left[6], 2.0 / 3));
  add(skin.on_edge(left[4], left[5], 0.5));     // 45 outer corner
  add(skin.on_edge(left[2], left[3], 2.0 / 3));    // 46, 47 lower lid, outer to inner
  add(skin.on_edge(left[1], left[2], 1.0 / 3));
  // Mouth rim (Layout order of a 2 x 6 block from its right lower corner): lower lip 0-6 right
  // to left, left corner 7, upper lip 8-14 left to right, right corner 15.
  const std::vector<int>& mouth = body.mouth_rim;
  const Vector2d right_corner = vertices.row(mouth[15]).head<2>().transpose();
  const Vector2d left_corner = vertices.row(mouth[7]).head<2>().transpose();
  add(skin.front(right_corner.x() - 0.003, right_corner.y()));  // 48
  for (double x : {-0.020, -0.010, 0.0, 0.010, 0.020})
    add(skin.front(x, kMouthY + 0.008 + 0.003 * (1 - x * x / 6.25e-4)));
  add(skin.front(left_corner.x() + 0.003, left_corner.y()));  // 54
  for (double x : {0.020, 0.010, 0.0, -0.010, -0.020})
    add(skin.front(x, kMouthY - 0.009 - 0.004 * (1 - x * x / 6.25e-4)));
  add(skin.at_vertex(mouth[15]));  // 60 right corner
  for (int k : {13, 11, 9}) add(skin.at_vertex(mouth[k]));  // 61-63 upper inner lip, right to left
  add(skin.at_vertex(mouth[7]));  // 64 left corner
  for (int k : {5, 3, 1}) add(skin.at_vertex(mouth[k]));  // 65-67 lower inner lip, left to right

  out.contour_faces.resize(FaceLandmarks::kYawBins, FaceLandmarks::kContourCount);
  out.contour_barycentric.resize(FaceLandmarks::kYawBins * FaceLandmarks::kContourCount, 3);
  for (int b = 0; b < FaceLandmarks::kYawBins; ++b) {
    const double yaw = b <= 39 ? b : 39 - b;
    for (int k = 0; k < FaceLandmarks::kContourCount; ++k) {
      const double u = (k - 8) / 8.0;
      const double y = 0.196 + 0.066 * std::pow(std::abs(u), 3.0);
      const double azimuth = std::clamp(78.0 * u + yaw, -100.0, 100.0) * kPi / 180.0;
      const auto [face, bary] = skin.cast({0.0, y, 0.0}, {std::sin(azimuth), 0.0, std::cos(azimuth)});
      out.contour_faces(b, k) = face;
      for (int c = 0; c < 3; ++c) out.contour_barycentric(b * FaceLandmarks::kContourCount + k, c) = bary[c];
    }
  }
  return out;
}

template <class Matrix>
void round_to_float(Matrix& m) {
  m = m.template cast<float>().template cast<double>();
}
void round_to_float(SparseRows& m) {
  for (int k = 0; k < m.outerSize(); ++k) {
    for (SparseRows::InnerIterator it(m, k); it; ++it) it.valueRef() = static_cast<float>(it.value());
  }
}

}  // namespace

SyntheticBody make_synthetic_body(unsigned seed, bool dense) {
  BodyMesh body = BodyBuilder().build();
  place_keypoints(body);
  const int n = static_cast<int>(body.mesh.points.size());
  SyntheticBody out;
  BodyModel& model = out.model;
  model.kind = BodyModelKind::SMPLX;
  model.joint_names = kJointNames;
  model.parents = kParents;
  RowMatrixXd vertices(n, 3);
  for (int v = 0; v < n; ++v) vertices.row(v) = body.mesh.points[v].transpose();
  model.faces.resize(static_cast<Eigen::Index>(body.mesh.triangles.size()), 3);
  for (std::size_t f = 0; f < body.mesh.triangles.size(); ++f) model.faces.row(f) = body.mesh.triangles[f].transpose();
  // Landmarks are placed on the design geometry, so they are the same for every seed.
  out.landmarks = face_landmarks(HeadSkin(vertices, model.faces, body.mesh.part, body.torso_part), body, vertices);
  round_to_float(out.landmarks.barycentric);
  round_to_float(out.landmarks.contour_barycentric);

  Random random(seed);
  const SparseRows weights = skinning_weights(body, false);
  model.j_regressor = joint_regressor(body);
  round_to_float(model.j_regressor);
  model.shapedirs = ShapeSpace(body, weights, random).take();
  round_to_float(model.shapedirs);
  model.shape_count = kShapeCount;
  model.expression_count = kExpressionCount;

  // The seed's proportions: a random mix of shape directions 1-9 (|beta| <= 0.5; limb and torso
  // length, which change the height most, <= 0.15), then direction 0 (a 4% uniform scale about
  // the pelvis per unit) sets the height to 1.70 m +- 8 mm: it multiplies the height by
  // 1 + 0.04 beta_0, up to 0.04 beta_0 times what the mix itself added (well under 0.1 mm).
  std::array<double, kMeaningfulShapes> betas{};
  for (int k = 1; k < kMeaningfulShapes; ++k) betas[k] = random.uniform(-1.0, 1.0) * (k == 2 || k == 5 ? 0.15 : 0.5);
  const auto shaped = [&] {
    RowMatrixXd result = vertices;
    for (int v = 0; v < n; ++v) {
      for (int c = 0; c < 3; ++c) {
        for (int k = 0; k < kMeaningfulShapes; ++k) result(v, c) += model.shapedirs(3 * v + c, k) * betas[k];
      }
    }
    return result;
  };
  const RowMatrixXd unscaled = shaped();
  const double height = unscaled.col(1).maxCoeff() - unscaled.col(1).minCoeff();
  betas[0] = ((1.70 + random.uniform(-0.008, 0.008)) / height - 1.0) / 0.04;
  model.v_template = shaped();
  round_to_float(model.v_template);

  model.weights = dense ? skinning_weights(body, true) : weights;
  round_to_float(model.weights);
  const RowMatrixXd joints = model.j_regressor * model.v_template;
  model.posedirs = pose_correctives(model.v_template, joints, model.weights, dense);
  HandPca hands = hand_pca(body.joints, random);
  model.hands_components_left = std::move(hands.left_components);
  model.hands_components_right = std::move(hands.right_components);
  model.hands_mean_left = std::move(hands.left_mean);
  model.hands_mean_right = std::move(hands.right_mean);
  round_to_float(model.hands_components_left);
  round_to_float(model.hands_components_right);
  round_to_float(model.hands_mean_left);
  round_to_float(model.hands_mean_right);
  return out;
}

}  // namespace odyssey
