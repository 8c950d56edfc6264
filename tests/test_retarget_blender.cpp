// Retargeting quality as Blender sees the exported GLB (issue 10, item 2). Every shared humanoid
// (RiggedFigure, CesiumMan, the Rigify base mesh, the KayKit mannequin, RobotExpressive) is driven
// by both shared CMU clips (at 30 fps and at their recorded 120 fps) and by the synthetic SMPL-X
// walk on the synthetic body (the bench's: 120 frames, seed 1, at 30 fps) at fast, balanced and
// accurate, through `odyssey retarget` as a user runs it. Debian's blender imports each GLB with its own glTF importer and plays it
// (tests/blender/measure_retarget.py). The metrics are computed there from the definitions in
// ARCHITECTURE.md, by code that shares nothing with odyssey's, against the performer's world
// joints from `odyssey pose`.
//
// The source is levelled by the report's rotation (source.levelling, contacts.h: the CMU walk's
// floor rises 0.9 degrees and the retargeting turns it level). Unlevelled, every bone of the walk
// carries that tilt (limbs_raw).
//
// Three kinds of check:
//   agreement  Blender's per-bone mean direction errors, hip line, torso lines and spine bend
//              (metrics.h) equal the report's figures within 0.05 degrees, and its jitter the report's within 1%: the
//              file carries what odyssey measured, detached segments (below) included.
//   ladder     the item 1: at balanced and accurate, no limb's mean direction error more
//              than 0.5 degrees above fast's, nor the hip line's (kHipLine), the skate no more
//              than 0.01 above fast's, and penetration plus floating (the report's, which reads
//              the sole) below fast's. On legs short for the character (kShortLegs) the thighs
//              and shins may be 1.5 degrees above fast's: holding contacts comes first there.
//   targets    the issue's, per limb (thigh, shin, upper arm, forearm, spine, chest to neck,
//              neck): a mean direction error under 2 degrees on the walk and 3 on the jump, at
//              every quality; the torso (spine1 -> neck, metrics.h) and the spine's bend against
//              the performer's under 2 degrees at every quality. At balanced and accurate also: a skate
//              ratio no worse than the source's by more than 0.01, jitter at most 1.3 (balanced)
//              or 1.1 (accurate) times the source's, and penetration and floating under 1 cm (the
//              report's). A character whose proportions are far from the performer's (Proportions,
//              below) has its skate and jitter held to fast's instead.
// The floor. Every skate figure here is measured from z = 0, the floor the character stands on in
// the exported scene, with thresholds scaled by the character's size (5 cm * s, 0.5 m/s * s),
// the same floor for every quality, so that a foot sinking below it is judged as penetration
// (the report's, above) and cannot lower the floor its sliding is measured from. The source's
// skate is the report's (metrics.h: the lowest foot point against its ground height, at the
// performer's size). GMD's figure (each file's own lowest foot joint, fixed thresholds) is printed
// in the table for comparison with published numbers; no target uses it.
// Where today's retargeting misses a target, tests/retarget_blender_misses.inc lists it with what
// was measured: accepted trades, each with its reason in docs/retargeting.md. A listed row may not
// get worse by more than its slack. A listed row that meets its target fails the test until it is
// taken off the list, so the list stays true. With ODYSSEY_PRINT_MISSES=1 the test prints the
// list as measured.
//
// Detached segments: RobotExpressive's foot joints are not the knees' children. Both Blender and
// the report measure such a shin from the knee to the foot joint, the line a viewer sees.
// Penetration and floating need the sole (the mesh), which this check does not read: they are
// taken from the report (metrics.h), whose other figures the agreement check holds to Blender's.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <stdexcept>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_runner.h"
#include "mocap_io/amass.h"
#include "synthetic/synthetic_walk.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;

const fs::path kAssets = fs::path(ODYSSEY_SHARED_DIR) / "assets";

std::string quoted(const fs::path& path) { return "'" + path.string() + "'"; }

// Proportions decide, not names. A character's legs are short when its thigh or its shin is under
// kShortLegs times the scaled performer's; it is far from the performer's proportions when its
// legs are short or when one of its feet never clears its own skate threshold (5 cm * s above the
// floor) while the performer's foot is in the swing, so that the metric counts its swing as a
// sliding contact. Both are measured on the clip's fast run, which carries the performer's
// directions exactly, against that clip's performer (measure_retarget.py: leg_ratio,
// swing_clearance). A far character's skate and jitter are held to fast's instead of the
// source's: at fast they are the source's motion on its bones. Under the CMU performer this puts
// RobotExpressive (thighs 0.62-0.66 of the scaled performer's) and the KayKit mannequin (shins
// 0.43) there and leaves the Mixamo-proportioned Rigify base mesh, RiggedFigure and CesiumMan out
// (TheRuleIsARigProperty).
constexpr double kShortLegs = 0.7;
struct Character {
  const char* name;
  const char* file;
  bool far_under_cmu;  // what the rule must find under the CMU performer: checked, not used to judge
};
const Character kCharacters[] = {{"RiggedFigure", "RiggedFigure.glb", false},
                                 {"CesiumMan", "CesiumMan.glb", false},
                                 {"Rigify", "male_base_mesh.glb", false},
                                 {"KayKit", "kaykit_mannequin/manny_med_mod.gltf", true},
                                 {"RobotExpressive", "RobotExpressive.glb", true}};
// The clips, the rate they are exported and judged at, and the limbs' target for each: under
// 2 degrees on a walk, 3 on the jump. The CMU clips run at 30 fps (the default output rate) and
// at their recorded 120 fps (the rate the issue measured at).
struct ClipSource {
  const char* name;    // as the misses list names it
  const char* motion;  // "walk" or "jump" (the CMU clips) or "smplx_walk"
  int fps;
  double limb_limit;
};
const ClipSource kClips[] = {{"walk", "walk", 30, 2.0},
                             {"jump", "jump", 30, 3.0},
                             {"smplx_walk", "smplx_walk", 30, 2.0},
                             {"walk_120fps", "walk", 120, 2.0},
                             {"jump_120fps", "jump", 120, 3.0}};
const char* const kQualities[] = {"fast", "balanced", "accurate"};

// Limbs as the targets name them: canonical bones (parent joint -> child joint).
const std::map<std::string, std::vector<std::pair<const char*, const char*>>> kLimbs = {
    {"left_thigh", {{"left_hip", "left_knee"}}},          {"right_thigh", {{"right_hip", "right_knee"}}},
    {"left_shin", {{"left_knee", "left_ankle"}}},         {"right_shin", {{"right_knee", "right_ankle"}}},
    {"left_upper_arm", {{"left_shoulder", "left_elbow"}}}, {"right_upper_arm", {{"right_shoulder", "right_elbow"}}},
    {"left_forearm", {{"left_elbow", "left_wrist"}}},     {"right_forearm", {{"right_elbow", "right_wrist"}}},
    {"spine", {{"spine1", "spine3"}}},                    {"chest_to_neck", {{"spine3", "neck"}}},
    {"neck", {{"neck", "head"}}}};
// The torso as a whole (metrics.h): the line from the spine's base joint to the neck, held to 2
// degrees at every quality and on every clip, and the line from the pelvis, which adds the rig's
// build and is compared with the report's only.
const std::map<std::string, std::pair<const char*, const char*>> kTorso = {{"torso", {"spine1", "neck"}},
                                                                           {"pelvis_to_neck", {"pelvis", "neck"}}};
constexpr double kTorsoLimit = 2.0;
// Held to the ladder only: the line from the right hip to the left, the pelvis's roll and turn as
// a viewer sees them. It is no limb and has no absolute target: fast fits the pelvis to its
// segments and rolls it to plant both feet (transfer.h), 1-4 degrees off the performer's line on
// average. The refinement turns the pelvis further (refine.h) so that the legs bend less, and
// the ladder counts what that costs here.
const std::pair<const char*, const char*> kHipLine = {"right_hip", "left_hip"};

// A target today's retargeting misses: what Blender measured and how much worse
// it may get before the test fails.
struct KnownMiss {
  const char* character;
  const char* clip;
  const char* quality;
  const char* metric;  // a limb name, "skate" (minus the source's), "jitter" (over the source's), "ladder ..."
  double measured, slack;
};
const KnownMiss kKnownMisses[] = {
#include "retarget_blender_misses.inc"
};

// A character's proportions against a clip's performer, measured on its fast run of that clip.
struct Proportions {
  double leg_ratio = 0, swing_clearance = 0;
  bool short_legs() const { return leg_ratio < kShortLegs; }
  bool far() const { return short_legs() || swing_clearance < 1.0; }
};

struct RetargetRun {
  std::string character, clip, quality;
  double limb_limit;
  fs::path glb, report;
};

// The `retarget` and `pose` options that read a clip: a CMU BVH from the shared assets, or the
// synthetic SMPL-X walk written here with the synthetic body (`odyssey make-body`).
struct ClipOptions {
  std::string retarget, pose;
};
ClipOptions clip_options(const std::string& clip, const fs::path& dir) {
  if (clip != "smplx_walk") {
    const fs::path bvh = kAssets / "mocap" / ("cmu_" + clip + "_cgspeed.bvh");
    return {"--motion " + quoted(bvh), "--motion " + quoted(bvh) + " --bvh-units cmu"};
  }
  const fs::path body = dir / "body.npz", walk = dir / "smplx_walk.npz";
  const auto made = test_support::run_cli("make-body --out " + quoted(body));
  if (made.exit_code != 0) throw std::runtime_error(made.output);
  io::write_amass(walk.string(), synthetic_walk(120, 30, BodyModelKind::SMPLX, 1));
  const std::string options = "--motion " + quoted(walk) + " --model " + quoted(body);
  return {options, options + " --joints-only"};
}

class RetargetBlenderTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (std::system("blender --version > /dev/null 2>&1") != 0) return;
    dir_ = new fs::path(test_support::scratch_root() / "retarget_blender");
    fs::create_directories(*dir_);
    runs_ = new std::vector<RetargetRun>;
    results_ = new nlohmann::json;
    nlohmann::json jobs = nlohmann::json::array();
    for (const ClipSource& clip : kClips) {
      const ClipOptions options = clip_options(clip.motion, *dir_);
      const std::string fps = " --fps " + std::to_string(clip.fps);
      const fs::path source = *dir_ / (std::string(clip.name) + "_source.npz");
      const auto pose = test_support::run_cli("pose " + options.pose + fps + " --out " + quoted(source));
      ASSERT_EQ(pose.exit_code, 0) << pose.output;
      for (const Character& character : kCharacters) {
        for (const char* quality : kQualities) {
          RetargetRun run{character.name, clip.name, quality, clip.limb_limit, {}, {}};
          const std::string stem = run.character + "_" + clip.name + "_" + quality;
          run.glb = *dir_ / (stem + ".glb");
          run.report = *dir_ / (stem + ".json");
          const auto result = test_support::run_cli("retarget " + options.retarget + " --character " +
                                                    quoted(kAssets / "characters" / character.file) + " --quality " + quality +
                                                    fps + " --out " + quoted(run.glb) + " --report " + quoted(run.report));
          ASSERT_EQ(result.exit_code, 0) << stem << "\n" << result.output;
          const nlohmann::json report = nlohmann::json::parse(std::ifstream(run.report));
          nlohmann::json limbs = nlohmann::json::object();
          for (const auto& [limb, bones] : kLimbs) {
            for (const auto& [parent, child] : bones) limbs[limb].push_back(nlohmann::json::array({parent, child}));
          }
          limbs["hip_line"].push_back(nlohmann::json::array({kHipLine.first, kHipLine.second}));
          // The torso's top is the neck, or the head on a rig without one (metrics.h).
          bool neck = false;
          for (const auto& entry : report["map"]) neck = neck || entry["canonical"] == "neck";
          const char* top = neck ? "neck" : "head";
          for (const auto& [name, line] : kTorso) limbs[name].push_back(nlohmann::json::array({line.first, top}));
          // The spine's bend: its first segment (spine1 to the next spine joint both rigs map) against
          // its last (to the top), as metrics.h's spine_chain.
          std::vector<std::string> spine = {"spine1"};
          for (const char* joint : {"spine2", "spine3"}) {
            for (const auto& entry : report["map"]) {
              if (entry["canonical"] == joint) spine.push_back(joint);
            }
          }
          spine.push_back(top);
          // One "limb" per bone the report measures, for the agreement check.
          for (const auto& [bone, value] : report["metrics"]["result"]["bone_direction_deg_per_bone"].items()) {
            const std::size_t arrow = bone.find("->");
            limbs["bone " + bone].push_back(nlohmann::json::array({bone.substr(0, arrow), bone.substr(arrow + 2)}));
          }
          jobs.push_back({{"glb", run.glb.string()},
                          {"source_npz", source.string()},
                          {"fps", clip.fps},
                          {"scale", report["scale"]},
                          {"levelling_wxyz", report["source"]["levelling"]["quaternion_wxyz"]},
                          {"map", report["map"]},
                          {"limbs", limbs},
                          {"feet", {"left_ankle", "left_foot", "right_ankle", "right_foot"}},
                          {"legs", {{"left_hip", "left_knee", "left_ankle"}, {"right_hip", "right_knee", "right_ankle"}}},
                          {"bend", {spine[0], spine[1], spine[spine.size() - 2], spine.back()}}});
          runs_->push_back(run);
        }
      }
    }
    std::ofstream(*dir_ / "jobs.json") << jobs.dump();
    const fs::path script = fs::path(__FILE__).parent_path() / "blender" / "measure_retarget.py";
    const int status = std::system(("blender -b --factory-startup --python " + quoted(script) + " -- --jobs " +
                                    quoted(*dir_ / "jobs.json") + " --out " + quoted(*dir_ / "blender.json") + " > " +
                                    quoted(*dir_ / "blender.log") + " 2>&1").c_str());
    ASSERT_EQ(status, 0) << std::ifstream(*dir_ / "blender.log").rdbuf();
    *results_ = nlohmann::json::parse(std::ifstream(*dir_ / "blender.json"));
    ASSERT_EQ(results_->size(), runs_->size());
    proportions_ = new std::map<std::string, Proportions>;
    for (std::size_t i = 0; i < runs_->size(); ++i) {
      const RetargetRun& run = (*runs_)[i];
      const nlohmann::json& blender = (*results_)[i];
      if (run.quality != std::string("fast")) continue;
      ASSERT_FALSE(blender.contains("error")) << blender["error"].get<std::string>();
      ASSERT_TRUE(blender["swing_clearance"].is_number()) << run.character << " " << run.clip << ": the performer's feet never swing";
      (*proportions_)[run.character + " " + run.clip] = {blender["leg_ratio"].get<double>(), blender["swing_clearance"].get<double>()};
    }
    ASSERT_EQ(proportions_->size(), std::size(kCharacters) * std::size(kClips));
  }

  void SetUp() override {
    if (!runs_) GTEST_SKIP() << "blender is not installed";
  }

  static fs::path* dir_;
  static std::vector<RetargetRun>* runs_;
  static nlohmann::json* results_;
  static std::map<std::string, Proportions>* proportions_;
};
fs::path* RetargetBlenderTest::dir_ = nullptr;
std::vector<RetargetRun>* RetargetBlenderTest::runs_ = nullptr;
nlohmann::json* RetargetBlenderTest::results_ = nullptr;
std::map<std::string, Proportions>* RetargetBlenderTest::proportions_ = nullptr;

// The rule that sets skate and jitter targets relative to fast's is a measured property of the rig
// against the performer: under the CMU performer it puts RobotExpressive and the KayKit mannequin
// there, and leaves the Mixamo-proportioned characters out with a margin on every clip (legs at
// least 0.76 of the scaled performer's, feet clearing their threshold 1.8 times or more).
TEST_F(RetargetBlenderTest, TheRuleIsARigProperty) {
  for (const Character& character : kCharacters) {
    for (const ClipSource& clip : kClips) {
      const Proportions& p = proportions_->at(std::string(character.name) + " " + clip.name);
      std::printf("%s %s: legs %.3f of the scaled performer's, swing clearance %.2f of its skate threshold\n", character.name,
                  clip.name, p.leg_ratio, p.swing_clearance);
      if (clip.name != std::string("smplx_walk")) {
        EXPECT_EQ(p.far(), character.far_under_cmu) << character.name << " " << clip.name;
      }
      if (!character.far_under_cmu) {
        EXPECT_GT(p.leg_ratio, kShortLegs + 0.05) << character.name << " " << clip.name;
        EXPECT_GT(p.swing_clearance, 1.5) << character.name << " " << clip.name;
      }
    }
  }
}

TEST_F(RetargetBlenderTest, TheFileCarriesWhatTheReportMeasured) {
  for (std::size_t i = 0; i < runs_->size(); ++i) {
    const RetargetRun& run = (*runs_)[i];
    const nlohmann::json& blender = (*results_)[i];
    ASSERT_FALSE(blender.contains("error")) << blender["error"].get<std::string>();
    const nlohmann::json report = nlohmann::json::parse(std::ifstream(run.report));
    const std::string label = run.character + " " + run.clip + " " + run.quality;
    int bones = 0;
    for (const auto& [bone, value] : report["metrics"]["result"]["bone_direction_deg_per_bone"].items()) {
      const std::string key = "bone " + bone;
      if (!blender["limbs"].contains(key)) continue;  // a joint the source npz lacks
      EXPECT_NEAR(blender["limbs"][key].get<double>(), value["mean"].get<double>(), 0.05) << label << ": " << bone;
      ++bones;
    }
    EXPECT_GE(bones, 10) << label;
    const double hip_line = report["metrics"]["result"]["hip_line_deg"]["mean"].get<double>();
    EXPECT_NEAR(blender["limbs"]["hip_line"].get<double>(), hip_line, 0.05) << label << ": hip line";
    for (const std::string name : {"torso", "pelvis_to_neck", "spine_bend"}) {
      const nlohmann::json& figure = report["metrics"]["result"][name + "_deg"];
      ASSERT_GT(figure["samples"].get<long>(), 0) << label << ": " << name;
      const double measured = name == "spine_bend" ? blender["spine_bend"].get<double>() : blender["limbs"][name].get<double>();
      EXPECT_NEAR(measured, figure["mean"].get<double>(), 0.05) << label << ": " << name;
    }
    const double jitter = report["metrics"]["result"]["jitter_m_per_s2"].get<double>();
    EXPECT_NEAR(blender["jitter"].get<double>(), jitter, 0.01 * jitter) << label;
  }
}

TEST_F(RetargetBlenderTest, TargetsHoldOrAreKnownMisses) {
  std::map<std::string, const KnownMiss*> misses;
  for (const KnownMiss& miss : kKnownMisses) {
    misses[std::string(miss.character) + " " + miss.clip + " " + miss.quality + " " + miss.metric] = &miss;
  }
  std::string table =
      "character clip quality: worst limb (deg), worst torso line (deg), skate from the floor - source's (GMD's figure, "
      "source's), jitter / source's\n";
  std::string misses_measured;
  int checked = 0;
  for (std::size_t i = 0; i < runs_->size(); ++i) {
    const RetargetRun& run = (*runs_)[i];
    const nlohmann::json& blender = (*results_)[i];
    ASSERT_FALSE(blender.contains("error")) << blender["error"].get<std::string>();
    const std::string label = run.character + " " + run.clip + " " + run.quality;
    const auto check = [&](const std::string& metric, double value, double limit) {
      ++checked;
      if (value > limit) {
        // Slack: what the solvers' tolerances and a changed default may move it by.
        const bool skate = metric.find("skate") != std::string::npos;
        const bool contact = metric == "ladder contact" || metric == "penetration" || metric == "floating";
        const double slack = skate ? 0.02 : metric.rfind("jitter", 0) == 0 ? 0.1 : contact ? 0.1 : 0.25;
        char row[200];
        std::snprintf(row, sizeof row, "{\"%s\", \"%s\", \"%s\", \"%s\", %.3f, %.2f},\n", run.character.c_str(),
                      run.clip.c_str(), run.quality.c_str(), metric.c_str(), value, slack);
        misses_measured += row;
      }
      const auto found = misses.find(label + " " + metric);
      if (found == misses.end()) {
        EXPECT_LE(value, limit) << label << ": " << metric << " misses its target " << limit;
        return;
      }
      const KnownMiss& miss = *found->second;
      EXPECT_GT(value, limit) << label << ": " << metric << " = " << value << " now meets its target " << limit
                              << ": remove it from tests/retarget_blender_misses.inc";
      EXPECT_LE(value, miss.measured + miss.slack) << label << ": " << metric << " got worse than the known miss " << miss.measured;
      misses.erase(found);
    };
    // The same character and clip at fast: runs go fast, balanced, accurate.
    const bool refined = run.quality != std::string("fast");
    const std::size_t fast_index = i - (run.quality == std::string("balanced") ? 1 : run.quality == std::string("accurate") ? 2 : 0);
    const nlohmann::json& fast = (*results_)[fast_index];
    ASSERT_EQ((*runs_)[fast_index].quality, "fast");
    const Proportions& proportions = proportions_->at(run.character + " " + run.clip);
    double worst = 0;
    for (const auto& [limb, bones] : kLimbs) {
      if (!blender["limbs"].contains(limb)) continue;
      const double value = blender["limbs"][limb].get<double>();
      worst = std::max(worst, value);
      check(limb, value, run.limb_limit);
      const bool leg = limb.find("thigh") != std::string::npos || limb.find("shin") != std::string::npos;
      const double ladder = leg && proportions.short_legs() ? 1.5 : 0.5;
      if (refined) check("ladder " + limb, value - fast["limbs"][limb].get<double>(), ladder);
    }
    const double torso = blender["limbs"]["torso"].get<double>();
    check("torso", torso, kTorsoLimit);
    check("spine bend", blender["spine_bend"].get<double>(), kTorsoLimit);
    if (refined) {
      check("ladder hip_line", blender["limbs"]["hip_line"].get<double>() - fast["limbs"]["hip_line"].get<double>(), 0.5);
    }
    const auto result_metrics = [](const fs::path& path) { return nlohmann::json::parse(std::ifstream(path))["metrics"]; };
    const nlohmann::json metrics = result_metrics(run.report), fast_metrics = result_metrics((*runs_)[fast_index].report);
    const double source_skate = metrics["source"]["foot_skate_ratio"].get<double>();
    const double skate = blender["skate_floor"].get<double>() - source_skate;
    const double jitter = blender["jitter"].get<double>() / blender["source_jitter"].get<double>();
    if (refined) {
      const double jitter_limit = run.quality == std::string("balanced") ? 1.3 : 1.1;
      if (!proportions.far()) {
        check("skate", skate, 0.01);
        check("jitter", jitter, jitter_limit);
      } else {  // the skate against fast's is the ladder's check, below
        check("jitter over fast's", blender["jitter"].get<double>() / fast["jitter"].get<double>(), jitter_limit);
      }
      check("ladder skate", blender["skate_floor"].get<double>() - fast["skate_floor"].get<double>(), 0.01);
      // Contact needs the sole, which this check does not read: the report's figures (metrics.h).
      const auto contact_cm = [](const nlohmann::json& m) {
        return m["result"]["penetration_cm"].get<double>() + m["result"]["floating_cm"].get<double>();
      };
      check("penetration", metrics["result"]["penetration_cm"].get<double>(), 1.0);
      check("floating", metrics["result"]["floating_cm"].get<double>(), 1.0);
      check("ladder contact", contact_cm(metrics) - contact_cm(fast_metrics), 0.0);
    }
    char line[240];
    std::snprintf(line, sizeof line, "%s: %.2f, torso %.2f, %+.3f (GMD %.3f, source %.3f), %.2f\n", label.c_str(), worst, torso,
                  skate, blender["skate_gmd"].get<double>(), source_skate, jitter);
    table += line;
  }
  std::printf("%s", table.c_str());
  if (const char* print = std::getenv("ODYSSEY_PRINT_MISSES"); print && std::string(print) == "1") {
    std::printf("\n// tests/retarget_blender_misses.inc, as measured:\n%s", misses_measured.c_str());
  }
  // At least, per run: 9 limbs (11 but on KayKit, which has no neck), the torso and the spine's
  // bend; per refined run: 9 ladder limbs, the hip line, a jitter check, the ladder skate and 3
  // contact checks.
  EXPECT_GE(checked, 75 * 11 + 50 * 15);
  for (const auto& [key, miss] : misses) ADD_FAILURE() << "known miss never measured: " << key;
}

}  // namespace
}  // namespace odyssey
