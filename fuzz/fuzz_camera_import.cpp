// Camera tracks from real video: RealEstate10K / Mannequin Challenge files (read_realestate10k)
// and COLMAP text models (read_colmap_text). The first byte picks the reader; for COLMAP the rest
// is cameras.txt, a NUL byte, then images.txt, written into a per-process scratch folder.
#include <filesystem>

#include "fuzz/fuzz_input.h"
#include "mocap_io/camera_import.h"

namespace {

namespace fs = std::filesystem;

// The COLMAP model folder, removed at exit.
class ScratchModel {
 public:
  ScratchModel() : folder_(odyssey::fuzz::scratch_folder() + "/odyssey-fuzz-" + std::to_string(::getpid()) + "-colmap") {
    fs::create_directories(folder_);
  }
  ~ScratchModel() {
    std::error_code ignored;
    fs::remove_all(folder_, ignored);
  }
  void write(const char* name, const std::string& content) const {
    std::FILE* file = std::fopen((folder_ / name).c_str(), "wb");
    if (file == nullptr || std::fwrite(content.data(), 1, content.size(), file) != content.size() || std::fclose(file) != 0) {
      std::fprintf(stderr, "odyssey fuzz: cannot write %s\n", (folder_ / name).c_str());
      std::abort();
    }
  }
  std::string path() const { return folder_.string(); }

 private:
  fs::path folder_;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static odyssey::fuzz::ScratchFile track("track.txt");
  static const ScratchModel model;
  if (size == 0) return 0;
  if (data[0] % 2 == 0) {
    const std::string& path = track.write(data + 1, size - 1);
    odyssey::fuzz::expect_input_errors([&] { (void)odyssey::io::read_realestate10k(path); });
    return 0;
  }
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  const std::size_t split = std::min(text.find('\0'), text.size());
  model.write("cameras.txt", text.substr(0, split));
  model.write("images.txt", split < text.size() ? text.substr(split + 1) : std::string());
  odyssey::fuzz::expect_input_errors([&] { (void)odyssey::io::read_colmap_text(model.path(), 30); });
  return 0;
}
