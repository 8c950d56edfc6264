#include "mocap_io/bvh.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string_view>
#include <unordered_set>
#include <vector>

#include "mocap_io/input_error.h"
#include "skeleton/rotation.h"

namespace odyssey::io {
namespace {

std::string read_whole_file(const std::string& path) {
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (!file) throw InputError(path, std::string("cannot open: ") + std::strerror(errno));
  std::string text;
  char buffer[1 << 16];
  std::size_t got = 0;
  while ((got = std::fread(buffer, 1, sizeof buffer, file)) > 0) text.append(buffer, got);
  const int error = std::ferror(file) ? errno : 0;
  std::fclose(file);
  if (error != 0) throw InputError(path, std::string("cannot read: ") + std::strerror(error));
  return text;
}

Eigen::Matrix3d bvh_basis(BvhUp up) { return up == BvhUp::y ? y_up_to_z_up() : Eigen::Matrix3d::Identity(); }

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }
bool is_line_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// A token as it may appear in a one-line message: at most 32 characters, non-printable bytes
// shown as '?', so a binary file cannot garble the report.
std::string quoted(std::string_view token) {
  std::string out = "'";
  for (std::size_t i = 0; i < token.size() && i < 32; ++i) {
    const unsigned char c = static_cast<unsigned char>(token[i]);
    out += (c >= 0x20 && c < 0x7f) ? char(c) : '?';
  }
  if (token.size() > 32) out += "...";
  return out + "'";
}

// What was found where something else was expected: the quoted token, or the end of the file.
std::string found(std::string_view token) { return token.empty() ? std::string("the end of the file") : quoted(token); }

struct Channel {
  bool rotation = false;
  int axis = 0;  // 0, 1, 2 for X, Y, Z of the BVH (Y-up) joint frame
};

// "Xposition" .. "Zrotation", case-insensitively.
bool parse_channel(std::string_view token, Channel& channel) {
  if (token.size() != 9) return false;
  const char axis = char(token[0] | 0x20);
  if (axis < 'x' || axis > 'z') return false;
  std::string rest(token.substr(1));
  for (char& c : rest) c = char(c | 0x20);
  if (rest != "position" && rest != "rotation") return false;
  channel = {rest == "rotation", axis - 'x'};
  return true;
}

struct Joint {
  std::string name;
  int parent = -1;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // BVH units, Y-up parent frame
  int first_channel = 0;                             // index of its first number on a frame line
  std::vector<Channel> channels;
  bool translated = false;  // has at least one position channel
};

class BvhParser {
 public:
  BvhParser(const std::string& path, std::string_view text) : path_(path), text_(text) {
    // A UTF-8 byte order mark is not part of the first keyword.
    if (text_.substr(0, 3) == "\xEF\xBB\xBF") position_ = 3;
  }

  Clip parse(double metres_per_unit, const Eigen::Matrix3d& basis) {
    parse_hierarchy();
    const auto [frame_count, frame_time, frame_time_token] = parse_motion_header();
    Clip clip = make_clip(metres_per_unit, basis, frame_rate(frame_time, frame_time_token));
    parse_frames(frame_count, metres_per_unit, basis, clip);
    try {
      clip.validate();
    } catch (const std::invalid_argument& error) {
      throw InputError(path_, error.what());
    }
    return clip;
  }

 private:
  [[noreturn]] void fail(int line, const std::string& problem) const {
    throw InputError(path_, "line " + std::to_string(line) + ": " + problem);
  }

  // The next whitespace-separated token (empty at the end of the text); token_line_ is its line.
  std::string_view next_token() {
    while (position_ < text_.size() && is_space(text_[position_])) {
      if (text_[position_] == '\n') ++line_;
      ++position_;
    }
    token_line_ = line_;
    const std::size_t start = position_;
    while (position_ < text_.size() && !is_space(text_[position_])) ++position_;
    return text_.substr(start, position_ - start);
  }

  // The token as a finite number, or why it is not one (empty when it is). A leading '+' is allowed
  // (from_chars alone rejects it); ".0083333" style values without a leading zero parse as is.
  static std::string parse_number(std::string_view token, double& value) {
    std::string_view digits = token;
    if (digits.size() > 1 && digits[0] == '+' && digits[1] != '-') digits.remove_prefix(1);
    const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
    if (error == std::errc::result_out_of_range) return "number " + quoted(token) + " is out of range";
    if (error != std::errc() || end != digits.data() + digits.size()) return quoted(token) + " is not a number";
    if (!std::isfinite(value)) return "value " + quoted(token) + " is not finite";
    return "";
  }

  double to_number(std::string_view token, int line) const {
    double value = 0;
    if (const std::string problem = parse_number(token, value); !problem.empty()) fail(line, problem);
    return value;
  }

  // A number of a frame line; a bad one is named by its frame and channel as well as its line, since
  // a person finds a frame in an animation tool rather than a line in the file.
  double frame_number(std::string_view token, int line, int frame, std::size_t channel) const {
    double value = 0;
    const std::string problem = parse_number(token, value);
    if (problem.empty()) return value;
    std::string where = "frame " + std::to_string(frame) + ", channel " + std::to_string(channel);
    for (const Joint& joint : joints_) {
      const std::size_t first = static_cast<std::size_t>(joint.first_channel);
      if (channel >= first && channel < first + joint.channels.size()) {
        const Channel& c = joint.channels[channel - first];
        where += std::string(" (") + joint.name + " " + char('X' + c.axis) + (c.rotation ? "rotation)" : "position)");
      }
    }
    fail(line, where + ": " + problem);
  }

  double next_number(const char* what) {
    const std::string_view token = next_token();
    if (token.empty()) fail(token_line_, std::string("file ends where ") + what + " should be");
    return to_number(token, token_line_);
  }

  std::string describe_block(int joint) const {
    return joint < 0 ? std::string("End Site") : "joint " + quoted(joints_[joint].name);
  }

  // Opens a ROOT or JOINT block: name, '{'. Blocks are tracked on an explicit stack rather than
  // by recursion, so nesting depth is bounded by memory, not by the call stack.
  // The name is every word on the keyword's line before the '{' (3ds Max writes "Bip01 L Thigh"),
  // joined by single spaces.
  void open_joint(int parent, const char* keyword) {
    const std::string_view first = next_token();
    if (first.empty()) fail(token_line_, std::string("file ends after ") + keyword);
    if (first == "{" || first == "}") fail(token_line_, std::string(keyword) + " has no name");
    const int name_line = token_line_;
    std::string name(first);
    std::string_view brace = next_token();
    while (!brace.empty() && brace != "{" && brace != "}" && token_line_ == name_line) {
      name += ' ';
      name += brace;
      brace = next_token();
    }
    if (!names_.insert(name).second) fail(name_line, "joint name " + quoted(name) + " is used twice");
    if (brace != "{")
      fail(token_line_, "expected '{' after " + std::string(keyword) + " " + quoted(name) + ", found " + found(brace));
    joints_.push_back({name, parent, Eigen::Vector3d::Zero(), 0, {}, false});
    open_.push_back({static_cast<int>(joints_.size()) - 1, false, false});
  }

  void parse_hierarchy() {
    const std::string_view first = next_token();
    if (first != "HIERARCHY")
      fail(token_line_, "expected HIERARCHY, found " + (first.empty() ? "an empty file" : quoted(first)));
    for (;;) {
      const std::string_view token = next_token();
      if (token.empty()) {
        if (open_.empty()) fail(token_line_, "file ends before MOTION");
        fail(token_line_, "file ends inside " + describe_block(open_.back().joint) + " (missing '}')");
      }
      if (open_.empty()) {
        if (token == "ROOT") {
          open_joint(-1, "ROOT");
        } else if (token == "MOTION") {
          if (joints_.empty()) fail(token_line_, "MOTION before any ROOT");
          return;
        } else if (token == "}") {
          fail(token_line_, "'}' closes no joint");
        } else {
          fail(token_line_, "expected ROOT or MOTION, found " + found(token));
        }
        continue;
      }
      Block& block = open_.back();
      const bool end_site = block.joint < 0;
      if (token == "OFFSET") {
        if (block.has_offset) fail(token_line_, describe_block(block.joint) + " has a second OFFSET");
        block.has_offset = true;
        Eigen::Vector3d offset;
        for (int axis = 0; axis < 3; ++axis) offset[axis] = next_number("an OFFSET value");
        if (!end_site) joints_[block.joint].offset = offset;
      } else if (token == "CHANNELS" && !end_site) {
        if (block.has_channels) fail(token_line_, describe_block(block.joint) + " has a second CHANNELS line");
        block.has_channels = true;
        parse_channels(joints_[block.joint]);
      } else if (token == "JOINT" && !end_site) {
        open_joint(block.joint, "JOINT");
      } else if (token == "End" && !end_site) {
        const std::string_view site = next_token();
        if (site != "Site") fail(token_line_, "expected 'Site' after 'End', found " + found(site));
        const std::string_view brace = next_token();
        if (brace != "{") fail(token_line_, "expected '{' after End Site, found " + found(brace));
        open_.push_back({-1, false, false});
      } else if (token == "}") {
        if (!block.has_offset) fail(token_line_, describe_block(block.joint) + " has no OFFSET");
        open_.pop_back();
      } else if (token == "ROOT" || token == "MOTION") {
        fail(token_line_, quoted(token) + " inside " + describe_block(block.joint) + " (missing '}')");
      } else {
        fail(token_line_, "unexpected " + quoted(token) + " inside " + describe_block(block.joint));
      }
    }
  }

  void parse_channels(Joint& joint) {
    const std::string_view count_token = next_token();
    const int count_line = token_line_;
    int count = -1;
    const auto [end, error] = std::from_chars(count_token.data(), count_token.data() + count_token.size(), count);
    // Six is the most a joint can have with every channel at most once.
    if (error != std::errc() || end != count_token.data() + count_token.size() || count < 0 || count > 6) {
      fail(count_line, "CHANNELS count " + found(count_token) + " is not a number from 0 to 6");
    }
    joint.first_channel = channel_count_;
    for (int k = 0; k < count; ++k) {
      const std::string_view name = next_token();
      Channel channel;
      if (name.empty()) fail(token_line_, "file ends inside the CHANNELS list of joint " + quoted(joint.name));
      if (!parse_channel(name, channel)) {
        fail(token_line_, "unknown channel " + quoted(name) + " in joint " + quoted(joint.name) +
                              " (expected Xposition, Yposition, Zposition, Xrotation, Yrotation or Zrotation)");
      }
      for (const Channel& seen : joint.channels) {
        if (seen.rotation == channel.rotation && seen.axis == channel.axis) {
          fail(token_line_, "channel " + quoted(name) + " appears twice in joint " + quoted(joint.name));
        }
      }
      joint.channels.push_back(channel);
      joint.translated = joint.translated || !channel.rotation;
    }
    channel_count_ += count;
  }

  struct MotionHeader {
    int frame_count;
    double frame_time;
    std::string_view frame_time_token;
  };

  MotionHeader parse_motion_header() {
    if (channel_count_ == 0) fail(token_line_, "the hierarchy declares no channels, so there is no motion to read");
    const std::string_view frames_label = next_token();
    if (frames_label != "Frames:") fail(token_line_, "expected 'Frames:', found " + found(frames_label));
    const std::string_view frames_token = next_token();
    long long frames = -1;
    const auto [end, error] = std::from_chars(frames_token.data(), frames_token.data() + frames_token.size(), frames);
    if (error != std::errc() || end != frames_token.data() + frames_token.size() || frames < 1 ||
        frames > std::numeric_limits<int>::max()) {
      fail(token_line_, "frame count " + found(frames_token) + " is not a positive integer");
    }
    const std::string_view frame_label = next_token();
    const std::string_view time_label = next_token();
    if (frame_label != "Frame" || time_label != "Time:") {
      fail(token_line_, "expected 'Frame Time:', found " +
                            (frame_label.empty() ? found(frame_label)
                                                 : quoted(std::string(frame_label) + " " + std::string(time_label))));
    }
    const std::string_view time_token = next_token();
    if (time_token.empty()) fail(token_line_, "file ends where the frame time should be");
    const double frame_time = to_number(time_token, token_line_);
    if (!(frame_time > 0)) fail(token_line_, "frame time " + quoted(time_token) + " is not positive");
    return {static_cast<int>(frames), frame_time, time_token};
  }

  // See the header: the unique integer rate n with |1/n - t| <= h, h = half a unit of the last
  // written digit of t; 1/t when no integer or several integers fit. The integers that fit are
  // those in [1/(t + h), 1/(t - h)].
  double frame_rate(double frame_time, std::string_view written) const {
    int decimals = 0, exponent = 0;
    const std::size_t point = written.find('.');
    const std::size_t e = written.find_first_of("eE");
    if (point != std::string_view::npos) decimals = static_cast<int>(std::min(e, written.size()) - point - 1);
    if (e != std::string_view::npos) {
      std::string_view exponent_text = written.substr(e + 1);
      if (!exponent_text.empty() && exponent_text[0] == '+') exponent_text.remove_prefix(1);
      std::from_chars(exponent_text.data(), exponent_text.data() + exponent_text.size(), exponent);
    }
    const double half_unit = 0.5 * std::pow(10.0, exponent - decimals);
    if (frame_time > half_unit) {
      const double lowest = std::ceil(1 / (frame_time + half_unit));
      const double highest = std::floor(1 / (frame_time - half_unit));
      if (lowest == highest) return lowest;
    }
    const double fps = 1 / frame_time;
    if (!std::isfinite(fps)) fail(token_line_, "frame time " + quoted(written) + " gives no finite frame rate");
    return fps;
  }

  Clip make_clip(double metres_per_unit, const Eigen::Matrix3d& c, double fps) const {
    std::vector<std::string> names;
    std::vector<int> parents;
    std::vector<Eigen::Vector3d> offsets;
    Clip clip;
    for (std::size_t j = 0; j < joints_.size(); ++j) {
      names.push_back(joints_[j].name);
      parents.push_back(joints_[j].parent);
      offsets.push_back(metres_per_unit * (c * joints_[j].offset));
      if (joints_[j].translated) clip.translated_joints.push_back(static_cast<int>(j));
    }
    try {
      clip.skeleton = Skeleton(std::move(names), std::move(parents), std::move(offsets));
    } catch (const std::invalid_argument& error) {
      throw InputError(path_, error.what());
    }
    clip.fps = fps;
    return clip;
  }

  // The clip stores a rotation for every joint every frame, channels or not, so joints without
  // channels cost memory their frames do not pay for (4,000 of them over 20,000 one-number
  // frames: 2.5 GB from a 137 KB file). The clip may take at most kStoragePerFileByte times the
  // file's size plus kStorageSlack; a dense file needs at most 16 times (a one-digit rotation
  // channel, 2 bytes, becomes a 32-byte quaternion). Checked before anything is reserved.
  static constexpr std::size_t kStoragePerFileByte = 32;
  static constexpr std::size_t kStorageSlack = std::size_t{64} << 20;

  void check_clip_storage(std::size_t frames, std::size_t translated_joints) const {
    const std::size_t joints = joints_.size();
    const std::size_t frame_bytes = joints * sizeof(Eigen::Quaterniond) + translated_joints * sizeof(Eigen::Vector3d);
    const double storage = double(frames) * double(frame_bytes);
    const double limit = double(kStoragePerFileByte) * double(text_.size()) + double(kStorageSlack);
    if (storage <= limit) return;
    const auto mib = [](double bytes) { return std::to_string(static_cast<long long>(std::ceil(bytes / (1 << 20)))); };
    throw InputError(path_, std::to_string(joints) + " joints x " + std::to_string(frames) + " frames would take " +
                                mib(storage) + " MiB as a clip, more than the " + mib(limit) + " MiB allowed for a " +
                                std::to_string(text_.size()) +
                                "-byte file: too many joints without channels for its frames");
  }

  // One line of numbers a frame. Blank lines between frames are skipped; a frame line with fewer
  // or more numbers than channels, fewer frame lines than declared, or anything after the last
  // declared frame is an error.
  void parse_frames(int frame_count, double metres_per_unit, const Eigen::Matrix3d& c, Clip& clip) {
    const std::size_t channels = static_cast<std::size_t>(channel_count_);
    const std::size_t joints = joints_.size();
    const char* p = text_.data() + position_;
    const char* const end = text_.data() + text_.size();
    int line = line_;

    // The rest of the "Frame Time:" line must be empty.
    while (p < end && is_line_space(*p)) ++p;
    if (p < end && *p != '\n') {
      const char* start = p;
      while (p < end && !is_space(*p)) ++p;
      fail(line, "unexpected " + quoted(std::string_view(start, p - start)) + " after the frame time");
    }

    // Every number takes at least two bytes (a digit and a separator), so a frame needs 2 *
    // channels bytes: reserve no more frames than the rest of the file can hold.
    const std::size_t backed_frames = static_cast<std::size_t>(end - p) / (2 * channels) + 1;
    const std::size_t reserved = std::min<std::size_t>(frame_count, backed_frames);
    check_clip_storage(reserved, clip.translated_joints.size());
    clip.rotations.reserve(reserved * joints);
    clip.translations.reserve(reserved * clip.translated_joints.size());

    // A rotation of angle theta about BVH axis a is, conjugated by C, the rotation of theta about
    // C a: q = (cos(theta/2), sin(theta/2) C a).
    const double half_radians_per_degree = std::numbers::pi / 360.0;
    std::vector<double> values(channels);
    int frame = 0;
    while (frame < frame_count) {
      if (p < end && *p == '\n') {
        ++p;
        ++line;
      }
      std::size_t count = 0;
      for (;;) {
        while (p < end && is_line_space(*p)) ++p;
        if (p == end || *p == '\n') break;
        const char* start = p;
        while (p < end && !is_space(*p)) ++p;
        const std::string_view token(start, p - start);
        if (count == channels) {
          fail(line, "frame " + std::to_string(frame) + " has more than " + std::to_string(channels) +
                         " numbers (the hierarchy declares " + std::to_string(channels) + " channels)");
        }
        values[count] = frame_number(token, line, frame, count);
        ++count;
      }
      if (count == 0) {
        if (p == end) {
          fail(line, "file ends after " + std::to_string(frame) + " of the " + std::to_string(frame_count) +
                         " frames declared in 'Frames:'");
        }
        continue;  // a blank line
      }
      if (count < channels) {
        fail(line, "frame " + std::to_string(frame) + " has " + std::to_string(count) + " numbers, expected " +
                       std::to_string(channels) + " (one per channel)");
      }
      for (std::size_t j = 0; j < joints; ++j) {
        const Joint& joint = joints_[j];
        Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
        Eigen::Vector3d translation = joint.offset;
        const double* joint_values = values.data() + joint.first_channel;
        for (std::size_t k = 0; k < joint.channels.size(); ++k) {
          const Channel& channel = joint.channels[k];
          if (channel.rotation) {
            const double half_angle = joint_values[k] * half_radians_per_degree;
            const Eigen::Vector3d axis = std::sin(half_angle) * c.col(channel.axis);
            rotation = rotation * Eigen::Quaterniond(std::cos(half_angle), axis.x(), axis.y(), axis.z());
          } else {
            translation[channel.axis] = joint_values[k];
          }
        }
        clip.rotations.push_back(rotation);
        if (joint.translated) clip.translations.push_back(metres_per_unit * (c * translation));
      }
      ++frame;
    }
    while (p < end && is_space(*p)) {
      if (*p == '\n') ++line;
      ++p;
    }
    if (p < end) fail(line, "more frame lines than the " + std::to_string(frame_count) + " declared in 'Frames:'");
  }

  struct Block {
    int joint;  // index into joints_, or -1 for an End Site
    bool has_offset;
    bool has_channels;
  };

  const std::string& path_;
  std::string_view text_;
  std::size_t position_ = 0;
  int line_ = 1;
  int token_line_ = 1;
  std::vector<Joint> joints_;
  std::unordered_set<std::string> names_;
  std::vector<Block> open_;
  int channel_count_ = 0;
};

}  // namespace

Clip load_bvh(const std::string& path, const BvhOptions& options) {
  if (!(options.metres_per_unit > 0) || !std::isfinite(options.metres_per_unit)) {
    throw std::invalid_argument("BVH metres_per_unit " + std::to_string(options.metres_per_unit) +
                                " is not a positive finite number");
  }
  return naming_out_of_memory(path, [&] {
    const std::string text = read_whole_file(path);
    return BvhParser(path, text).parse(options.metres_per_unit, bvh_basis(options.up));
  });
}

namespace {

// A human's head-joint-to-sole span, and the heights taken as a human's (see bvh.h).
constexpr double kTypicalHeight = 1.6, kLowestHeight = 1.0, kHighestHeight = 2.2;
// How many frames, spread over the clip, are tried for one that stands when the rest pose does not.
constexpr int kStandingFrameProbes = 200;

struct Stance {
  double height = 0;  // file units, along `up`
  BvhUp up = BvhUp::y;
  bool upright = false;
};

// `positions` are in the raw clip's world: C p with p in the file's axes, so the file's Y is z
// and the file's Z is -y.
Stance stance_of(const std::vector<Eigen::Vector3d>& positions) {
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& p : positions) box.extend(p);
  Stance stance;
  if (box.isEmpty()) return stance;
  const Eigen::Vector3d spread = box.sizes();
  stance.up = spread.y() > 1.5 * spread.z() ? BvhUp::z : BvhUp::y;
  stance.height = stance.up == BvhUp::z ? spread.y() : spread.z();
  const double diagonal = spread.norm();
  stance.upright = diagonal > 0 && stance.height >= 0.25 * diagonal;
  return stance;
}

std::string number_text(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*g", digits, value);
  return text;
}

}  // namespace

std::string BvhFrameGuess::description() const {
  std::string text = unit + " (" + number_text(metres_per_unit, 6) + " m per unit, " + (unit_inferred ? "inferred: " : "as given: ");
  if (measured_on.empty()) {
    text += "no pose stands up to measure";
  } else {
    text += number_text(height_units, 4) + " units tall in the " + measured_on + ", " + number_text(height_m(), 3) + " m";
  }
  text += std::string("), ") + (up == BvhUp::y ? "Y up" : "Z up");
  if (reference_frame >= 0) text += "; the rest pose does not stand up, so the " + measured_on + " is the rest pose";
  return text;
}

std::string BvhFrameGuess::warning(const std::string& path) const {
  if (plausible) return {};
  if (measured_on.empty()) {
    return path + ": neither the rest pose nor any frame stands up, so the BVH unit cannot be inferred; read as " +
           unit + " (" + number_text(metres_per_unit, 6) + " m per unit): give --bvh-units if that is wrong";
  }
  return path + ": the skeleton is " + number_text(height_units, 4) + " units tall in the " + measured_on +
         ", a human's " + number_text(kLowestHeight, 2) + "-" + number_text(kHighestHeight, 2) + " m in no known unit (" +
         (unit_inferred ? "nearest: " : "given: ") + unit + ", " + number_text(height_m(), 3) +
         " m): give --bvh-units if the unit is wrong";
}

BvhFrameGuess guess_bvh_frame(const Clip& raw, std::optional<double> metres_per_unit) {
  BvhFrameGuess guess;
  Stance stance;
  {
    std::vector<Eigen::Vector3d> positions;
    for (const RigidTransform<double>& joint : raw.skeleton.rest_world()) positions.push_back(joint.translation);
    stance = stance_of(positions);
    if (stance.upright) guess.measured_on = "rest pose";
  }
  // The first frame, then up to kStandingFrameProbes frames spread evenly over the clip.
  if (!stance.upright && raw.frame_count() > 0) {
    std::vector<RigidTransform<double>> world(raw.joint_count());
    const int frames = raw.frame_count();
    const int step = std::max(1, frames / kStandingFrameProbes);
    for (int frame = 0; frame < frames; frame += step) {
      raw.world_pose(frame, world);
      std::vector<Eigen::Vector3d> positions;
      for (const RigidTransform<double>& joint : world) positions.push_back(joint.translation);
      const Stance posed = stance_of(positions);
      if (posed.upright) {
        stance = posed;
        guess.reference_frame = frame;
        guess.measured_on = frame == 0 ? "first frame" : "frame " + std::to_string(frame);
        break;
      }
    }
  }
  guess.up = stance.upright ? stance.up : BvhUp::y;
  guess.height_units = stance.height;
  if (metres_per_unit) {
    guess.metres_per_unit = *metres_per_unit;
    guess.unit = number_text(*metres_per_unit, 6);
    for (const BvhUnit& unit : kBvhUnits) {
      if (unit.metres == *metres_per_unit) guess.unit = unit.name;
    }
  } else if (stance.upright) {
    guess.unit_inferred = true;
    double best = std::numeric_limits<double>::infinity();
    for (const BvhUnit& unit : kBvhUnits) {
      const double misfit = std::abs(std::log(stance.height * unit.metres / kTypicalHeight));
      if (misfit < best) {
        best = misfit;
        guess.metres_per_unit = unit.metres;
        guess.unit = unit.name;
      }
    }
  } else {
    guess.unit_inferred = true;
    guess.metres_per_unit = 0.01;
    guess.unit = "cm";
  }
  guess.plausible = stance.upright && guess.height_m() >= kLowestHeight && guess.height_m() <= kHighestHeight;
  return guess;
}

Clip with_rest_from_frame(Clip clip, int frame) {
  if (frame < 0 || frame >= clip.frame_count()) {
    throw std::invalid_argument("frame " + std::to_string(frame) + " of a " + std::to_string(clip.frame_count()) +
                                "-frame clip");
  }
  std::vector<RigidTransform<double>> local(clip.joint_count());
  clip.local_pose(frame, local);
  std::vector<Eigen::Vector3d> offsets;
  std::vector<Eigen::Quaterniond> rotations;
  for (int j = 0; j < clip.joint_count(); ++j) {
    offsets.push_back(local[j].translation);
    rotations.push_back(clip.rotation(frame, j).normalized());
  }
  clip.skeleton = Skeleton(clip.skeleton.names(), clip.skeleton.parents(), std::move(offsets), std::move(rotations));
  return clip;
}

Clip with_bvh_frame(Clip raw, double metres_per_unit, BvhUp up) {
  if (!(metres_per_unit > 0) || !std::isfinite(metres_per_unit)) {
    throw std::invalid_argument("BVH metres_per_unit " + std::to_string(metres_per_unit) + " is not a positive finite number");
  }
  // raw holds C_y p (positions) and rotations about C_y a; the wanted frame holds C p and C a,
  // so every vector is mapped by M = C C_y^T (a signed permutation, a proper rotation) and scaled.
  const Eigen::Matrix3d m = bvh_basis(up) * y_up_to_z_up().transpose();
  std::vector<Eigen::Vector3d> offsets;
  for (const Eigen::Vector3d& offset : raw.skeleton.rest_offsets()) offsets.push_back(metres_per_unit * (m * offset));
  std::vector<Eigen::Quaterniond> rotations = raw.skeleton.rest_rotations();
  for (Eigen::Quaterniond& rotation : rotations) rotation.vec() = m * rotation.vec();
  raw.skeleton = Skeleton(raw.skeleton.names(), raw.skeleton.parents(), std::move(offsets), std::move(rotations));
  for (Eigen::Vector3d& translation : raw.translations) translation = metres_per_unit * (m * translation);
  for (Eigen::Quaterniond& rotation : raw.rotations) rotation.vec() = m * rotation.vec();
  return raw;
}

LoadedBvh load_bvh_inferring_frame(const std::string& path, std::optional<double> metres_per_unit) {
  Clip raw = load_bvh(path, BvhOptions{1.0, BvhUp::y});
  LoadedBvh loaded;
  loaded.frame = guess_bvh_frame(raw, metres_per_unit);
  if (loaded.frame.reference_frame >= 0) raw = with_rest_from_frame(std::move(raw), loaded.frame.reference_frame);
  loaded.clip = with_bvh_frame(std::move(raw), loaded.frame.metres_per_unit, loaded.frame.up);
  return loaded;
}

}  // namespace odyssey::io
