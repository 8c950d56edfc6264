#include "mocap_io/input_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "mocap_io/input_error.h"

namespace odyssey::io {
namespace {

std::string not_regular(mode_t mode) {
  const char* what = S_ISDIR(mode)                    ? "a folder"
                     : S_ISFIFO(mode)                 ? "a FIFO"
                     : S_ISCHR(mode) || S_ISBLK(mode) ? "a device"
                     : S_ISSOCK(mode)                 ? "a socket"
                                                      : "something else";
  return std::string("is ") + what + ", not a regular file";
}

std::string megabytes(std::uint64_t bytes) {
  return bytes % (1u << 20) == 0 ? std::to_string(bytes >> 20) + " MiB" : std::to_string(bytes) + " bytes";
}

// Closes a descriptor on every way out.
struct Descriptor {
  int fd;
  ~Descriptor() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

void require_input_file(const std::string& path) {
  struct stat status {};
  if (::stat(path.c_str(), &status) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) throw InputError(path, "no such file");
    throw InputError(path, std::string("cannot be read: ") + std::strerror(errno));
  }
  if (!S_ISREG(status.st_mode)) throw InputError(path, not_regular(status.st_mode));
}

std::string image_size_problem(long long width, long long height) {
  if (width <= kMaxImageSide && height <= kMaxImageSide && width * height <= kMaxImagePixels) return {};
  return std::to_string(width) + " x " + std::to_string(height) + " pixels is larger than the cap of " +
         std::to_string(kMaxImageSide) + " a side and " + std::to_string(kMaxImagePixels) + " pixels in all";
}

void require_frames_within_cap(const std::string& path, long long frames, double fps, double target_fps) {
  const double duration = frames > 1 ? static_cast<double>(frames - 1) / fps : 0;
  const double resampled = std::floor(duration * target_fps) + 1;
  if (!(resampled <= kMaxFrames)) {
    char text[256];
    std::snprintf(text, sizeof text, "%lld frames at %.6g fps resampled to %.6g fps make %.6g frames, more than the cap of %.0f",
                  frames, fps, target_fps, resampled, kMaxFrames);
    throw InputError(path, text);
  }
}

std::string read_input_file(const std::string& path, std::uint64_t max_bytes) {
  const Descriptor file{::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)};
  if (file.fd < 0) {
    const int error = errno;
    require_input_file(path);  // names what is there (a socket cannot be opened)
    throw InputError(path, std::string("cannot open: ") + std::strerror(error));
  }
  struct stat status {};
  if (::fstat(file.fd, &status) != 0) throw InputError(path, std::string("cannot be read: ") + std::strerror(errno));
  if (!S_ISREG(status.st_mode)) throw InputError(path, not_regular(status.st_mode));
  const std::uint64_t size = static_cast<std::uint64_t>(status.st_size);
  if (size > max_bytes) {
    throw InputError(path, "is " + std::to_string(size) + " bytes, more than the " + megabytes(max_bytes) + " this reader accepts");
  }
  std::string text(static_cast<std::size_t>(size), '\0');
  std::size_t got = 0;
  // The file may grow while read: the cap holds for what is read, not only for the size first seen.
  for (;;) {
    if (got == text.size()) {
      if (text.size() >= max_bytes + 1) {
        throw InputError(path, "grew past the " + megabytes(max_bytes) + " this reader accepts while being read");
      }
      text.resize(std::min<std::uint64_t>(max_bytes + 1, text.size() + (1u << 16)));
    }
    const ssize_t n = ::read(file.fd, text.data() + got, text.size() - got);
    if (n == 0) break;
    if (n < 0) {
      if (errno == EINTR) continue;
      throw InputError(path, std::string("read failed: ") + std::strerror(errno));
    }
    got += static_cast<std::size_t>(n);
  }
  text.resize(got);
  return text;
}

}  // namespace odyssey::io
