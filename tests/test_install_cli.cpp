// `cmake --install` gives a binary that works without the source tree's help: installed into a
// scratch prefix and run from `/`, it reads its bone-map presets and bundled data from
// PREFIX/share/odyssey (mocap_io/install_layout.h), says so in `demo --help`, and runs a scene
// file whose actors name bundled files ("data:...") onto bundled characters. The Python module,
// when the build made one, installs under PREFIX/lib/python3.X/dist-packages, where Debian's
// python3 imports it, and reads the bundled data from PREFIX/share/odyssey.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "cli_runner.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;

std::string quoted(const fs::path& path) { return "'" + path.string() + "'"; }

TEST(InstalledBinary, RunsFromAnyFolderOnItsOwnPresetsAndData) {
  const fs::path prefix = test_support::scratch_dir("install") / "prefix";
  const fs::path log = prefix.parent_path() / "install.txt";
  const int status = std::system(("cmake --install " + quoted(ODYSSEY_BUILD_DIR) + " --prefix " + quoted(prefix) + " > " +
                                  quoted(log) + " 2>&1").c_str());
  ASSERT_EQ(status, 0) << std::ifstream(log).rdbuf();
  const fs::path binary = prefix / "bin/odyssey", share = prefix / "share/odyssey";
  ASSERT_TRUE(fs::exists(binary));
  for (const char* file : {"presets/mixamo.json", "presets/cmu_bvh.json", "data/CREDITS.md", "data/scenes/indoor.json",
                           "data/characters/RiggedFigure.glb", "data/mocap/cmu_walk_cgspeed.bvh"}) {
    EXPECT_TRUE(fs::exists(share / file)) << file;
  }

  const auto run = [&](const std::string& arguments) {
    const std::string command = "cd / && env -u ODYSSEY_DATA_DIR " + quoted(binary) + " " + arguments + " 2>&1";
    FILE* pipe = ::popen(command.c_str(), "r");
    std::string output;
    char buffer[4096];
    while (pipe && std::fgets(buffer, sizeof buffer, pipe)) output += buffer;
    const int code = pipe ? ::pclose(pipe) : -1;
    return std::make_pair(WIFEXITED(code) ? WEXITSTATUS(code) : -1, output);
  };
  const auto [help_code, help] = run("demo --help");
  EXPECT_EQ(help_code, 0) << help;
  EXPECT_TRUE(contains(help, (share / "data").string())) << help;

  // A one-second shot of the bundled walk on the bundled figure, written next to the scene file.
  const fs::path scene = prefix.parent_path() / "shot.json";
  std::ofstream(scene) << R"({"version": 1, "name": "installed", "fps": 30,
    "actors": [{"name": "walker", "motion": "data:mocap/cmu_walk_cgspeed.bvh", "character": "data:characters/RiggedFigure.glb",
                "quality": "fast", "trim": [0.1, 1.1]}],
    "cameras": [{"name": "front", "type": "static", "position": [0, -4, 1.5], "target": [0, 0, 1]}],
    "outputs": {"glb": true, "report": true}})";
  const fs::path out = prefix.parent_path() / "out";
  const auto [scene_code, scene_output] = run("scene " + quoted(scene) + " --out " + quoted(out));
  ASSERT_EQ(scene_code, 0) << scene_output;
  bool glb = false;
  for (const auto& entry : fs::directory_iterator(out)) glb = glb || entry.path().extension() == ".glb";
  EXPECT_TRUE(glb) << scene_output;
}

TEST(InstalledPythonModule, ImportsFromThePrefixAndRunsABundledScene) {
  REQUIRE_NUMPY();
  if (!fs::exists(fs::path(ODYSSEY_BUILD_DIR) / "python" / "odyssey" / "__init__.py")) {
    GTEST_SKIP() << "the Python module is not built (pybind11-dev, python3-dev or python3-numpy missing)";
  }
  const fs::path prefix = test_support::scratch_dir("install_python") / "prefix";
  const fs::path log = prefix.parent_path() / "install.txt";
  const int status = std::system(("cmake --install " + quoted(ODYSSEY_BUILD_DIR) + " --prefix " + quoted(prefix) + " > " +
                                  quoted(log) + " 2>&1").c_str());
  ASSERT_EQ(status, 0) << std::ifstream(log).rdbuf();
  fs::path site;
  for (const auto& entry : fs::directory_iterator(prefix / "lib")) {
    if (entry.path().filename().string().rfind("python3.", 0) == 0) site = entry.path() / "dist-packages";
  }
  ASSERT_TRUE(fs::exists(site / "odyssey" / "__init__.py")) << site;
  EXPECT_TRUE(fs::exists(site / "odyssey" / "data.py"));
  EXPECT_TRUE(fs::exists(site / "odyssey" / "_odyssey.pyi"));

  // From `/`, without the build tree on the path: the installed package, and a shot on bundled files.
  const fs::path script = prefix.parent_path() / "check.py";
  std::ofstream(script) << R"(import odyssey, os, sys
assert odyssey.__file__.startswith(sys.argv[1]), odyssey.__file__
assert os.environ["ODYSSEY_DATA_DIR"] == os.path.join(sys.argv[2], "share", "odyssey", "data")
scene = {"version": 1, "name": "installed", "fps": 30,
         "actors": [{"name": "walker", "motion": "data:mocap/cmu_walk_cgspeed.bvh",
                     "character": "data:characters/RiggedFigure.glb", "trim": [0.1, 0.5], "points": 100}],
         "cameras": [{"name": "front", "type": "static", "position": [0, -4, 1.5], "target": [0, 0, 1]}]}
arrays = odyssey.scene_arrays(scene)["cameras"]["front"]
print("frames", arrays["trajs_3d"].shape[0], "visible", int(arrays["visibs"].sum()))
)";
  const std::string command = "cd / && env -u ODYSSEY_DATA_DIR PYTHONPATH=" + quoted(site) + " " +
                              test_support::numpy_python() + " " + quoted(script) + " " + quoted(site) + " " +
                              quoted(prefix) + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  std::string output;
  char buffer[4096];
  while (pipe && std::fgets(buffer, sizeof buffer, pipe)) output += buffer;
  const int code = pipe ? ::pclose(pipe) : -1;
  ASSERT_TRUE(WIFEXITED(code) && WEXITSTATUS(code) == 0) << output;
  EXPECT_TRUE(contains(output, "frames 13 visible ")) << output;
}

}  // namespace
}  // namespace odyssey
