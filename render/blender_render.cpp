#include "render/blender_render.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <vector>

#include "mocap_io/input_error.h"
#include "mocap_io/input_file.h"
#include "mocap_io/install_layout.h"
#include "mocap_io/json_reader.h"
#include "mocap_io/npy.h"
#include "mocap_io/output_file.h"

extern char** environ;

namespace odyssey::render {
namespace {

namespace fs = std::filesystem;

constexpr const char* kNotASequence = "not a sequence folder (odyssey scene --layout pointodyssey writes them)";

// The first [T, rows, cols] member `key` of anno.npz, checked.
std::size_t frame_axis(const io::NpzReader& anno, const std::string& key, std::size_t rows, std::size_t cols) {
  if (!anno.contains(key)) throw io::InputError(anno.path(), "no '" + key + "' array: " + kNotASequence);
  const std::vector<std::size_t> shape = anno.header(key).shape;
  if (shape.size() != 3 || shape[1] != rows || shape[2] != cols || shape[0] == 0) {
    throw io::InputError(anno.path(), "'" + key + "' is not [T, " + std::to_string(rows) + ", " + std::to_string(cols) +
                                          "] with T >= 1");
  }
  return shape[0];
}

// Width and height of a baseline or progressive JPEG: the SOFn segment's fields (after the
// 2-byte length and 1-byte precision, height then width, big-endian 16-bit). Markers are 0xFF
// followed by the code; every segment but SOI/EOI/RSTn carries a 2-byte length that counts
// itself. Returns false when the file is not a JPEG with a frame header.
bool jpeg_size(const fs::path& path, int& width, int& height) {
  std::ifstream in(path, std::ios::binary);
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < 4 || bytes[0] != 0xFF || bytes[1] != 0xD8) return false;
  std::size_t at = 2;
  while (at + 4 <= bytes.size()) {
    if (bytes[at] != 0xFF) return false;
    const unsigned char code = bytes[at + 1];
    if (code == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    const std::size_t length = std::size_t{bytes[at + 2]} << 8 | bytes[at + 3];
    const bool frame_header = code >= 0xC0 && code <= 0xCF && code != 0xC4 && code != 0xC8 && code != 0xCC;
    if (frame_header) {
      if (at + 9 > bytes.size()) return false;
      height = bytes[at + 5] << 8 | bytes[at + 6];
      width = bytes[at + 7] << 8 | bytes[at + 8];
      return true;
    }
    if (length < 2) return false;
    at += 2 + length;
  }
  return false;
}

// The line of Blender's output that says best why it failed: the script's own error line, else
// the last that mentions an error, else the last that is not empty.
std::string last_error_line(const std::vector<std::string>& lines) {
  const std::string own = "render_sequence: error: ";
  for (auto line = lines.rbegin(); line != lines.rend(); ++line) {
    if (line->rfind(own, 0) == 0) return line->substr(own.size());
  }
  for (auto line = lines.rbegin(); line != lines.rend(); ++line) {
    if (line->find("Error") != std::string::npos || line->find("error") != std::string::npos) return *line;
  }
  for (auto line = lines.rbegin(); line != lines.rend(); ++line) {
    if (line->find_first_not_of(" \t\r") != std::string::npos) return *line;
  }
  return "no output";
}

struct BlenderRun {
  int exit_code = -1;   // -1: killed by a signal
  int signal = 0;
  std::vector<std::string> lines;  // its last lines of output (stdout and stderr together)
};

// Runs `argv` with stdout and stderr on one pipe, calling `on_line` for each line it prints.
BlenderRun run_blender(const std::vector<std::string>& argv, const std::function<void(const std::string&)>& on_line) {
  int pipe_ends[2];
  if (::pipe2(pipe_ends, O_CLOEXEC) != 0) throw std::runtime_error("cannot create a pipe for Blender's output");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, pipe_ends[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, pipe_ends[1], STDERR_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  std::vector<char*> args;
  for (const std::string& arg : argv) args.push_back(const_cast<char*>(arg.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  const int spawned = ::posix_spawn(&pid, argv[0].c_str(), &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(pipe_ends[1]);
  if (spawned != 0) {
    ::close(pipe_ends[0]);
    throw io::InputError(argv[0], "cannot run Blender: " + std::string(std::strerror(spawned)));
  }
  BlenderRun run;
  std::string pending;
  std::array<char, 4096> buffer;
  const auto keep = [&](std::string line) {
    on_line(line);
    run.lines.push_back(std::move(line));
    if (run.lines.size() > 200) run.lines.erase(run.lines.begin(), run.lines.begin() + 100);
  };
  for (;;) {
    const ssize_t got = ::read(pipe_ends[0], buffer.data(), buffer.size());
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) break;
    pending.append(buffer.data(), static_cast<std::size_t>(got));
    for (std::size_t end; (end = pending.find('\n')) != std::string::npos; pending.erase(0, end + 1)) {
      keep(pending.substr(0, end));
    }
  }
  if (!pending.empty()) keep(pending);
  ::close(pipe_ends[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status)) run.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) run.signal = WTERMSIG(status);
  return run;
}

bool is_executable_file(const fs::path& path) {
  std::error_code error;
  return fs::is_regular_file(path, error) && ::access(path.c_str(), X_OK) == 0;
}

}  // namespace

Sequence read_sequence(const std::string& folder) {
  std::error_code error;
  if (!fs::is_directory(folder, error)) throw io::InputError(folder, fs::exists(folder, error) ? kNotASequence : "no such folder");
  Sequence sequence;
  sequence.folder = fs::absolute(folder).lexically_normal().string();
  if (sequence.folder.size() > 1 && sequence.folder.back() == '/') sequence.folder.pop_back();
  const fs::path dir(sequence.folder);

  const std::string info_path = (dir / "scene_info.json").string();
  if (!fs::exists(info_path, error)) throw io::InputError(info_path, std::string("missing: ") + kNotASequence);
  const io::JsonDocument info = io::JsonDocument::read_file(info_path);
  const io::JsonValue camera = info.root().member("camera");
  sequence.camera = camera.member("name").string();
  sequence.width = static_cast<int>(camera.member("width").integer(1, io::kMaxImageSide));
  sequence.height = static_cast<int>(camera.member("height").integer(1, io::kMaxImageSide));
  if (const std::string problem = io::image_size_problem(sequence.width, sequence.height); !problem.empty()) camera.member("width").fail(problem);
  sequence.fps = info.root().member("fps").number_in(1e-3, 1e6);
  const long long frames = info.root().member("frames").integer(1, 1LL << 31);

  const std::string anno_path = (dir / "anno.npz").string();
  if (!fs::exists(anno_path, error)) throw io::InputError(anno_path, std::string("missing: ") + kNotASequence);
  const io::NpzReader anno(anno_path);
  const std::size_t t = frame_axis(anno, "intrinsics", 3, 3);
  if (frame_axis(anno, "extrinsics", 4, 4) != t || static_cast<long long>(t) != frames) {
    throw io::InputError(anno_path, "intrinsics, extrinsics and scene_info.json's " + std::to_string(frames) +
                                        " frames disagree on the frame count");
  }
  const std::vector<double> k = anno.load("intrinsics").to_double();
  for (std::size_t f = 0; f < t; ++f) {
    const double* m = &k[9 * f];
    if (!(m[0] > 0 && m[4] > 0 && std::isfinite(m[0]) && std::isfinite(m[4]) && std::isfinite(m[2]) && std::isfinite(m[5]))) {
      throw io::InputError(anno_path, "frame " + std::to_string(f) + ": intrinsics without positive finite focal lengths");
    }
  }
  for (const double value : anno.load("extrinsics").to_double()) {
    if (!std::isfinite(value)) throw io::InputError(anno_path, "extrinsics hold a value that is not finite");
  }
  sequence.frames = static_cast<int>(t);

  const fs::path glb = (dir.parent_path() / "scene.glb").lexically_normal();
  if (!fs::is_regular_file(glb, error)) {
    throw io::InputError(glb.string(), "missing: rendering needs the shot's scene.glb beside its sequence folders; "
                                       "run the scene with \"glb\": true in its outputs");
  }
  sequence.glb = glb.string();
  return sequence;
}

FrameRange parse_frame_range(const std::string& text, int frames) {
  const std::string expected = "--frames expects A:B (frames A to B - 1; A defaults to 0, B to " + std::to_string(frames) +
                               ") or K, with 0 <= A < B <= " + std::to_string(frames) + ", got '" + text + "'";
  const auto number = [&](const std::string& part, int fallback) {
    if (part.empty()) return fallback;
    std::size_t used = 0;
    long long value = 0;
    try {
      value = std::stoll(part, &used);
    } catch (const std::exception&) {
      throw std::invalid_argument(expected);
    }
    if (used != part.size() || part.find_first_not_of("0123456789") != std::string::npos || value > frames) {
      throw std::invalid_argument(expected);
    }
    return static_cast<int>(value);
  };
  const std::size_t colon = text.find(':');
  FrameRange range;
  if (colon == std::string::npos) {
    if (text.empty()) throw std::invalid_argument(expected);
    range.first = number(text, 0);
    range.end = range.first + 1;
  } else {
    range.first = number(text.substr(0, colon), 0);
    range.end = number(text.substr(colon + 1), frames);
  }
  if (!(0 <= range.first && range.first < range.end && range.end <= frames)) throw std::invalid_argument(expected);
  return range;
}

std::string find_blender() {
  if (const char* chosen = std::getenv("ODYSSEY_BLENDER"); chosen && *chosen) {
    if (!is_executable_file(chosen)) throw io::InputError(chosen, "ODYSSEY_BLENDER names no executable file");
    return chosen;
  }
  const char* path = std::getenv("PATH");
  std::string folders = path ? path : "";
  for (std::size_t start = 0; start <= folders.size();) {
    const std::size_t end = std::min(folders.find(':', start), folders.size());
    const fs::path candidate = fs::path(end > start ? folders.substr(start, end - start) : ".") / "blender";
    if (is_executable_file(candidate)) return candidate.string();
    start = end + 1;
  }
  throw io::InputError("blender", "not found on PATH: install Blender (Debian's blender package) or set ODYSSEY_BLENDER "
                                  "to its executable");
}

std::string render_script() {
  const std::string folder = io::runtime_folder("render", ODYSSEY_RENDER_SCRIPT_DIR);
  const std::string script = (fs::path(folder) / "render_sequence.py").string();
  std::error_code error;
  if (!fs::is_regular_file(script, error)) throw io::InputError(script, "missing: the installation lacks Blender's render script");
  return script;
}

int RenderJob::width() const { return static_cast<int>(std::lround(sequence.width * scale)); }
int RenderJob::height() const { return static_cast<int>(std::lround(sequence.height * scale)); }

std::string RenderJob::validate() const {
  if (sequence.frames <= 0 || sequence.width <= 0 || sequence.height <= 0) return "no sequence read";
  if (samples < 1 || samples > 1 << 20) return "--samples must be between 1 and " + std::to_string(1 << 20);
  if (!(scale > 0 && std::isfinite(scale)) || sequence.width * scale > 16384 || sequence.height * scale > 16384) {
    return "--scale must be positive and keep the image within 16384 pixels a side";
  }
  if (width() < 1 || height() < 1) return "--scale makes the image smaller than one pixel";
  const FrameRange range = frames.end > frames.first ? frames : FrameRange{0, sequence.frames};
  if (range.first < 0 || range.end > sequence.frames) return "frames outside the sequence's " + std::to_string(sequence.frames);
  return {};
}

RenderResult RenderJob::run() const {
  if (const std::string problem = validate(); !problem.empty()) throw std::invalid_argument(problem);
  const FrameRange range = frames.end > frames.first ? frames : FrameRange{0, sequence.frames};
  const std::string executable = blender.empty() ? find_blender() : blender;
  const std::string script = render_script();

  io::StagedOutputs staged;
  const std::string target = (fs::path(sequence.folder) / "rgbs").string();
  const std::string staging = staged.stage_folder(target);
  const std::vector<std::string> argv = {executable, "-b", "--factory-startup", "--python-exit-code", "1", "--python", script,
                                         "--", "--sequence", sequence.folder, "--glb", sequence.glb, "--out", staging,
                                         "--first", std::to_string(range.first), "--end", std::to_string(range.end),
                                         "--samples", std::to_string(samples), "--width", std::to_string(width()),
                                         "--height", std::to_string(height())};
  const auto start = std::chrono::steady_clock::now();
  const std::string progress = "render_sequence: frame ";
  const BlenderRun run = run_blender(argv, [&](const std::string& line) {
    if (on_frame && line.rfind(progress, 0) == 0) on_frame(std::atoi(line.c_str() + progress.size()));
  });
  if (run.exit_code != 0) {
    const std::string how = run.signal ? "was killed by signal " + std::to_string(run.signal)
                                       : "failed (exit status " + std::to_string(run.exit_code) + ")";
    throw io::InputError(sequence.folder, "Blender (" + executable + ") " + how + ": " + last_error_line(run.lines));
  }
  for (int k = range.first; k < range.end; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "rgb_%05d.jpg", k);
    int w = 0, h = 0;
    if (!jpeg_size(fs::path(staging) / name, w, h)) {
      throw io::InputError(sequence.folder, std::string("Blender exited without writing ") + name + " (last line: " +
                                                last_error_line(run.lines) + ")");
    }
    if (w != width() || h != height()) {
      throw io::InputError(sequence.folder, std::string("Blender wrote ") + name + " at " + std::to_string(w) + "x" +
                                                std::to_string(h) + ", not " + std::to_string(width()) + "x" +
                                                std::to_string(height()));
    }
  }
  staged.commit();
  RenderResult result;
  result.folder = target;
  result.frames = range.end - range.first;
  result.width = width();
  result.height = height();
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace odyssey::render
