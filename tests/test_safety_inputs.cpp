// Every reader of a path it was given checks that the path is a regular file before opening it and
// reads under a size cap: a FIFO does not block it, /dev/zero does not grow it, a folder is named
// as a folder, "no such file" is said only when there is none, and a file past the cap fails with
// its size. The FIFOs, folders and oversized (sparse) files are the test's own, in its scratch
// folder; /dev/zero is only opened for reading.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "batch/job.h"
#include "mocap_io/anime_file.h"
#include "mocap_io/bone_map_file.h"
#include "mocap_io/camera_import.h"
#include "mocap_io/camera_path_file.h"
#include "mocap_io/gltf_character.h"
#include "mocap_io/input_error.h"
#include "mocap_io/input_file.h"
#include "mocap_io/motion_file.h"
#include "mocap_io/obj_mesh.h"
#include "scene_layouts/scene_file.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;

struct Reader {
  const char* what;
  const char* name;  // the file name the reader expects (extension, COLMAP's cameras.txt)
  std::uint64_t cap;  // 0: read in pieces, no whole-file cap
  std::function<void(const std::string&)> read;
};

const std::vector<Reader>& readers() {
  static const std::vector<Reader> all = {
      {"camera path", "camera.json", io::kMaxJsonInputBytes, [](const std::string& p) { io::read_camera_path_json(p); }},
      {"OBJ prop", "table.obj", io::kMaxTextInputBytes, [](const std::string& p) { io::load_obj(p); }},
      {"bone map", "map.json", io::kMaxJsonInputBytes, [](const std::string& p) { io::load_bone_map_file(p); }},
      {"RealEstate10K", "track.txt", io::kMaxTextInputBytes, [](const std::string& p) { io::read_realestate10k(p); }},
      {"COLMAP", "cameras.txt", io::kMaxTextInputBytes, [](const std::string& p) { io::read_colmap_text(p, 30); }},
      {"scene", "scene.json", io::kMaxJsonInputBytes, [](const std::string& p) { scene::read_scene_file(p); }},
      {"CSV manifest", "jobs.csv", io::kMaxTextInputBytes, [](const std::string& p) { batch::read_manifest(p, {}); }},
      {"JSON manifest", "jobs.json", io::kMaxJsonInputBytes, [](const std::string& p) { batch::read_manifest(p, {}); }},
      {"motion", "walk.bvh", 0, [](const std::string& p) { io::detect_motion_file(p); }},
      {"character", "figure.glb", 0, [](const std::string& p) { io::load_character(p); }},
      {"anime", "fox.anime", 0, [](const std::string& p) { io::read_anime_file(p); }},
  };
  return all;
}

std::string message_of_reading(const Reader& reader, const fs::path& path) {
  return test_support::message_of<io::InputError>([&] { reader.read(path.string()); });
}

TEST(ReadersTest, AFifoIsRefusedWithoutBlocking) {
  const fs::path dir = test_support::scratch_dir("safety_inputs");
  for (const Reader& reader : readers()) {
    const fs::path folder = dir / reader.what;
    fs::create_directories(folder);
    const fs::path fifo = folder / reader.name;
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
    const std::string message = message_of_reading(reader, fifo);
    EXPECT_TRUE(contains(message, fifo.string() + ": is a FIFO, not a regular file")) << reader.what << ": " << message;
    EXPECT_TRUE(fs::is_fifo(fifo));
  }
}

TEST(ReadersTest, ADeviceIsRefusedBeforeItIsRead) {
  for (const Reader& reader : readers()) {
    // COLMAP reads cameras.txt beside the path, a manifest needs its extension: tried below.
    if (!std::filesystem::path(reader.name).has_extension() || std::string(reader.what) == "COLMAP" ||
        contains(reader.what, "manifest")) {
      continue;
    }
    const std::string message = message_of_reading(reader, "/dev/zero");
    EXPECT_TRUE(contains(message, "/dev/zero: is a device, not a regular file")) << reader.what << ": " << message;
  }
  // A link to the device, named as the reader expects.
  const fs::path dir = test_support::scratch_dir("safety_inputs");
  for (const Reader& reader : readers()) {
    const fs::path folder = dir / reader.what;
    fs::create_directories(folder);
    fs::create_symlink("/dev/zero", folder / reader.name);
    const std::string message = message_of_reading(reader, folder / reader.name);
    EXPECT_TRUE(contains(message, "is a device, not a regular file")) << reader.what << ": " << message;
  }
}

TEST(ReadersTest, AFolderIsCalledAFolderAndOnlyAMissingFileIsMissing) {
  const fs::path dir = test_support::scratch_dir("safety_inputs");
  for (const Reader& reader : readers()) {
    const fs::path folder = dir / reader.what;
    fs::create_directories(folder / reader.name / "inside");
    std::string message;
    if (std::string(reader.what) != "COLMAP") {  // a COLMAP model may be named by its folder
      message = message_of_reading(reader, folder / reader.name);
      EXPECT_TRUE(contains(message, (folder / reader.name).string() + ": is a folder, not a regular file"))
          << reader.what << ": " << message;
    }
    fs::remove_all(folder / reader.name);
    message = message_of_reading(reader, folder / reader.name);
    EXPECT_TRUE(contains(message, (folder / reader.name).string() + ": no such file")) << reader.what << ": " << message;
  }
}

TEST(ReadersTest, AFilePastTheCapFailsWithItsSize) {
  const fs::path dir = test_support::scratch_dir("safety_inputs");
  for (const Reader& reader : readers()) {
    if (reader.cap == 0) continue;
    const fs::path folder = dir / reader.what;
    fs::create_directories(folder);
    const fs::path big = folder / reader.name;
    std::ofstream(big) << "{";
    fs::resize_file(big, reader.cap + 1);  // sparse: no disk used
    const std::string message = message_of_reading(reader, big);
    EXPECT_TRUE(contains(message, big.string() + ": is " + std::to_string(reader.cap + 1) + " bytes, more than the " +
                                      std::to_string(reader.cap >> 20) + " MiB this reader accepts"))
        << reader.what << ": " << message;
  }
}

TEST(ReadersTest, ReadInputFileReadsWhatIsThere) {
  const fs::path dir = test_support::scratch_dir("safety_inputs");
  std::ofstream(dir / "a.txt") << "line one\nline two";
  EXPECT_EQ(io::read_input_file((dir / "a.txt").string(), 100), "line one\nline two");
  EXPECT_EQ(io::read_input_file((dir / "a.txt").string(), 17), "line one\nline two");
  EXPECT_TRUE(contains(test_support::message_of<io::InputError>([&] { io::read_input_file((dir / "a.txt").string(), 16); }),
                       "is 17 bytes, more than the 16 bytes this reader accepts"));
  std::ofstream(dir / "empty.txt").flush();
  EXPECT_EQ(io::read_input_file((dir / "empty.txt").string(), 16), "");
}

}  // namespace
}  // namespace odyssey
