// Speed and accuracy of retargeting, quality by quality, on one core: every clip onto every
// character at every setting below, prepared as `odyssey retarget` prepares it (clip resampled
// to 30 fps, bone maps from presets or names restricted to --parts body, default
// RetargetOptions), so the numbers are those of what users run.
//
// Clips: the CMU walk (344 frames at 120 fps, 86 at 30), the CMU jump (2,752 at 120, 688 at 30),
// both at kCmuMetresPerUnit, and a synthetic SMPL-X walk (synthetic_walk, seed 1, 120 frames at
// 30 fps) posed on the synthetic SMPL-X body (seed 0), as the CLI poses an AMASS sequence without
// --model. Characters: the Mixamo-named test rig (reference_rig.h, A-pose) and every shared
// humanoid: RiggedFigure, CesiumMan, RobotExpressive (IK-style one-joint feet), the Rigify
// male_base_mesh (A-pose) and the KayKit mannequin (stylised: big head, short legs).
//
// Settings: fast; balanced and accurate with refine.h's defaults; and two accurate variants
// between them: 3 span iterations instead of 10 (cheaper), and spans of 64 frames instead of
// 1,024 (the jump cut into 11 problems, where the defaults solve every clip here as one).
// Refinement runs on one thread (threads = 1; Ceres is single-threaded there too).
//
// What a frames/s figure counts:
//   fast      the transfer stage of retarget_fast (FastTransfer's plan and run, what
//             RetargetTimings::transfer times): no rig pairing or Ceres rest alignment, no
//             contact detection, no metrics;
//   refined   the whole refine() call, as the CLI times it: its model setup and motion plan, the
//             solvers and the result's metrics; not the fast retarget it starts from (copied,
//             untimed, before each call). "solvers" counts RefineSummary::solve_seconds alone.
// The per-clip setup that every quality pays first (retarget_fast whole: rig, contacts,
// transfer, metrics) is timed apart and printed in its own table.
//
// Times are wall clock (manual time, so the copy before each refine is left out); each figure is
// the best mean over one run of iterations, among the repetitions (--benchmark_repetitions, 3 by
// default) and Google Benchmark's own sizing runs: on a shared machine interference only ever
// slows a run down. Metrics are deterministic and taken once per row.
// Options: --svg FILE writes the trade as an SVG plot (default: none); Google Benchmark's own
// flags pass through (--benchmark_filter keeps the table to the rows run).
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/machine.h"
#include "mocap_io/bvh.h"
#include "mocap_io/gltf_character.h"
#include "retarget/bone_map.h"
#include "retarget/parts.h"
#include "retarget/reference_rig.h"
#include "retarget/refine.h"
#include "retarget/retarget.h"
#include "skeleton/body_clip.h"
#include "skeleton/body_sequence.h"
#include "skeleton/pose_layout.h"
#include "synthetic/synthetic_body.h"
#include "synthetic/synthetic_walk.h"

namespace odyssey::retarget {
namespace {

using Clock = std::chrono::steady_clock;

const std::string kAssets = ODYSSEY_SHARED_DIR "/assets";
constexpr double kFps = 30.0;         // odyssey retarget's default --fps
constexpr int kSmplxFrames = 120;     // 4 s of synthetic walk
constexpr int kSetupRepetitions = 3;  // best of, for the per-clip setup table

// The aims of the retargeting issue.
constexpr double kFastAimFps = 50000, kBalancedAimFps = 3000, kAccurateAimFps = 500;
constexpr double kLimbAimDeg = 2.0, kContactAimCm = 1.0;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

struct Setting {
  std::string name;   // table
  std::string label;  // plot
  RefineOptions options;
};

std::vector<Setting> make_settings() {
  std::vector<Setting> settings;
  settings.push_back({"fast", "fast", default_refine_options(Quality::fast)});
  settings.push_back({"balanced", "bal", default_refine_options(Quality::balanced)});
  RefineOptions options = default_refine_options(Quality::accurate);
  options.span_iterations = 3;
  settings.push_back({"accurate, 3 span iterations", "acc 3it", options});
  options = default_refine_options(Quality::accurate);
  options.span_frames = 64;
  settings.push_back({"accurate, 64-frame spans", "acc 64f", options});
  settings.push_back({"accurate", "acc", default_refine_options(Quality::accurate)});
  for (Setting& setting : settings) setting.options.threads = 1;
  return settings;
}

struct Motion {
  std::string name;
  Clip clip;  // at kFps
  BoneMap map;
};

struct Target {
  std::string name;
  Character character;
  BoneMap map;
};

// One clip on one character: the fast result every setting starts from, and the best time of
// the whole retarget_fast call with its stages.
struct Job {
  const Motion* motion;
  const Target* target;
  RetargetResult fast;
  RetargetTimings best;  // each stage's best over kSetupRepetitions
  double best_total = std::numeric_limits<double>::infinity();
};

struct Row {
  Row(const Job* job, const Setting* setting) : job(job), setting(setting) {}
  const Job* job;
  const Setting* setting;
  double seconds = std::numeric_limits<double>::infinity();        // timed stage, best repetition's mean
  double solve_seconds = std::numeric_limits<double>::infinity();  // refined: the solvers alone
  bool measured = false;
  RetargetMetrics metrics;
  double fps() const { return job->fast.report.frames / seconds; }
};

// The body map of a rig or a character (which may declare its humanoid bones), as
// `odyssey retarget --parts body` makes it.
BoneMap body_map(const Skeleton& skeleton, const std::string& label) {
  return restrict_bone_map(humanoid_bone_map(skeleton, label), Parts::body);
}
BoneMap body_map(const Character& character, const std::string& label) {
  return restrict_bone_map(humanoid_bone_map(character, label), Parts::body);
}

std::vector<Motion> load_motions() {
  std::vector<Motion> motions;
  for (const char* name : {"walk", "jump"}) {
    const std::string path = kAssets + "/mocap/cmu_" + name + "_cgspeed.bvh";
    Clip clip = io::load_bvh(path, io::BvhOptions{io::kCmuMetresPerUnit}).resampled(kFps);
    BoneMap map = body_map(clip.skeleton, path);
    motions.push_back({std::string("CMU ") + name, std::move(clip), std::move(map)});
  }
  const BodyModel model = make_synthetic_body(0).model;
  const BodySequence walk = sequence_for_model(synthetic_walk(kSmplxFrames, kFps, BodyModelKind::SMPLX, 1), model.kind);
  Clip clip = clip_from_body_sequence(model, walk).resampled(kFps);
  BoneMap map = body_map(clip.skeleton, "synthetic SMPL-X walk");
  motions.push_back({"SMPL-X walk", std::move(clip), std::move(map)});
  return motions;
}

std::vector<Target> load_targets() {
  std::vector<Target> targets;
  Character mixamo = mixamo_reference_character(45.0);
  BoneMap mixamo_map = body_map(mixamo.skeleton, "Mixamo test rig");
  targets.push_back({"Mixamo rig", std::move(mixamo), std::move(mixamo_map)});
  const std::pair<const char*, const char*> shared[] = {{"RiggedFigure", "RiggedFigure.glb"},
                                                        {"CesiumMan", "CesiumMan.glb"},
                                                        {"RobotExpressive", "RobotExpressive.glb"},
                                                        {"Rigify base mesh", "male_base_mesh.glb"},
                                                        {"KayKit mannequin", "kaykit_mannequin/manny_med_mod.gltf"}};
  for (const auto& [name, file] : shared) {
    const std::string path = kAssets + "/characters/" + file;
    Character character = io::load_character(path);
    BoneMap map = body_map(character, path);
    targets.push_back({name, std::move(character), std::move(map)});
  }
  return targets;
}

Job prepare_job(const Motion& motion, const Target& target) {
  Job job{&motion, &target, {}, {}, std::numeric_limits<double>::infinity()};
  for (int repetition = 0; repetition < kSetupRepetitions; ++repetition) {
    const Clock::time_point start = Clock::now();
    RetargetResult result = retarget_fast(motion.clip, motion.map, target.character, target.map, {}, motion.name);
    const double total = seconds_since(start);
    const RetargetTimings& t = result.report.timings;
    if (repetition == 0) {
      job.best = t;
    } else {
      job.best.rig = std::min(job.best.rig, t.rig);
      job.best.contacts = std::min(job.best.contacts, t.contacts);
      job.best.transfer = std::min(job.best.transfer, t.transfer);
      job.best.metrics = std::min(job.best.metrics, t.metrics);
    }
    job.best_total = std::min(job.best_total, total);
    job.fast = std::move(result);
  }
  return job;
}

// fast: the transfer stage alone, on the rig, feet and contacts retarget_fast found.
void time_transfer(benchmark::State& state, Row& row) {
  const RetargetResult& fast = row.job->fast;
  const Clip& source = row.job->motion->clip;
  double total = 0;
  for (auto _ : state) {
    const Clock::time_point start = Clock::now();
    TransferResult transfer = FastTransfer(fast.rig, fast.target_feet).run(source, fast.source_feet, fast.contacts);
    const double seconds = seconds_since(start);
    benchmark::DoNotOptimize(transfer.clip.rotations.data());
    state.SetIterationTime(seconds);
    total += seconds;
  }
  row.seconds = std::min(row.seconds, total / double(state.iterations()));
  if (!row.measured) {
    row.metrics = fast.report.result_metrics;
    row.measured = true;
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()) * fast.report.frames);
}

// balanced, accurate and the settings between: the refine() call on a fresh copy of the fast
// result (refine works in place).
void time_refine(benchmark::State& state, Row& row) {
  const Clip& source = row.job->motion->clip;
  double total = 0, solve = 0;
  for (auto _ : state) {
    RetargetResult result = row.job->fast;
    const Clock::time_point start = Clock::now();
    const RefineSummary summary = refine(result, source, row.setting->options);
    const double seconds = seconds_since(start);
    state.SetIterationTime(seconds);
    total += seconds;
    solve += summary.solve_seconds;
    if (!row.measured) {
      row.metrics = result.report.result_metrics;
      row.measured = true;
    }
  }
  const double iterations = double(state.iterations());
  if (total / iterations < row.seconds) {
    row.seconds = total / iterations;
    row.solve_seconds = solve / iterations;
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()) * row.job->fast.report.frames);
}

// Jitter (mean joint jerk, m/s^2: metrics.h) over the source's on the same clip.
double jitter_ratio(const Row& row) {
  const double source = row.job->fast.report.source_metrics.jitter;
  return source > 0 ? row.metrics.jitter / source : 0;
}

const NamedDirectionError& worst_limb(const RetargetMetrics& metrics) {
  return *std::max_element(metrics.limbs.begin(), metrics.limbs.end(),
                           [](const auto& a, const auto& b) { return a.error.mean_deg < b.error.mean_deg; });
}

std::string thousands(double value) {
  const long long n = std::llround(value);
  std::string digits = std::to_string(n), out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

void print_setup_table(const std::vector<Job>& jobs) {
  std::printf("\nSetup every quality pays first: retarget_fast whole (best of %d), ms\n\n", kSetupRepetitions);
  std::printf("| clip | character | frames | rig (pairing, Ceres rest alignment) | contacts | transfer | metrics | total |\n");
  std::printf("|---|---|---:|---:|---:|---:|---:|---:|\n");
  for (const Job& job : jobs) {
    const RetargetTimings& t = job.best;
    std::printf("| %s | %s | %d | %.1f | %.2f | %.2f | %.2f | %.1f |\n", job.motion->name.c_str(), job.target->name.c_str(),
                job.fast.report.frames, 1e3 * t.rig, 1e3 * t.contacts, 1e3 * t.transfer, 1e3 * t.metrics, 1e3 * job.best_total);
  }
}

void print_table(const std::vector<Row>& rows) {
  std::printf("\nframes/s on one core (fast: the transfer stage; refined: the refine() call, its setup and metrics "
              "included, \"solvers\": its solvers alone); bone direction over the mapped chain bones; "
              "source values in brackets\n\n");
  std::printf("| clip | character | setting | frames/s | solvers frames/s | bone dir. mean / max (deg) | worst limb mean (deg) "
              "| hip line mean (deg) | end effector mean (cm) | skate, scale-aware | skate, GMD | penetration (cm) "
              "| floating (cm) | jitter (m/s²) | jitter / source's |\n");
  std::printf("|---|---|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const Row& row : rows) {
    if (!row.measured) continue;  // filtered out of this run
    const RetargetMetrics& m = row.metrics;
    const RetargetMetrics& s = row.job->fast.report.source_metrics;
    const NamedDirectionError& limb = worst_limb(m);
    const std::string solvers =
        row.setting->options.quality == Quality::fast ? "-" : thousands(row.job->fast.report.frames / row.solve_seconds);
    std::printf("| %s | %s | %s | %s | %s | %.2f / %.1f | %.2f %s | %.2f | %.1f | %.3f (%.3f) | %.3f (%.3f) | %.2f (%.2f) "
                "| %.2f (%.2f) | %.1f (%.1f) | %.2f |\n",
                row.job->motion->name.c_str(), row.job->target->name.c_str(), row.setting->name.c_str(),
                thousands(row.fps()).c_str(), solvers.c_str(), m.bone_direction.mean_deg, m.bone_direction.max_deg,
                limb.error.mean_deg, limb.name.c_str(), m.hip_line.mean_deg, 1e2 * m.end_effector_mean_m, m.foot_skate_ratio,
                s.foot_skate_ratio, m.foot_skate_ratio_gmd, s.foot_skate_ratio_gmd, m.penetration_cm, s.penetration_cm, m.floating_cm,
                s.floating_cm, m.jitter, s.jitter, jitter_ratio(row));
  }
}

constexpr std::size_t kMeasureCount = 4;

// One point of the plot: a setting on a character, over every clip run. Accuracy values are the
// worst clip's: the aims hold for every clip.
struct PlotPoint {
  double fps = 0;  // all clips' frames over all clips' best times
  std::array<double, kMeasureCount> values = {-1e9, -1e9, -1e9, -1e9};  // one per plotted measure (kMeasures)
};

struct Measure {
  const char* axis;  // the y axis title
  const char* aim;   // the aim line's label
  double aim_value;
  double (*of)(const Row& row);
};

// What the plot's rows show: the bone direction aim, the contact aim, the skating aim (skate with
// thresholds scaled by the character's size, metrics.h) and the smoothness aim (balanced's 1.3;
// accurate's is 1.1).
const std::array<Measure, kMeasureCount> kMeasures = {{
    {"worst limb, mean error (deg)", "aim < 2 deg", kLimbAimDeg,
     [](const Row& row) { return worst_limb(row.metrics).error.mean_deg; }},
    {"penetration | floating (cm)", "aim < 1 cm", kContactAimCm,
     [](const Row& row) { return std::max(row.metrics.penetration_cm, row.metrics.floating_cm); }},
    {"skate ratio - source's", "aim <= 0 (no worse than the source)", 0.0,
     [](const Row& row) { return row.metrics.foot_skate_ratio - row.job->fast.report.source_metrics.foot_skate_ratio; }},
    {"jitter / source's", "aim <= 1.3 (balanced; accurate 1.1)", 1.3, jitter_ratio},
}};

// Text as SVG character data.
std::string escaped(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '<') {
      out += "&lt;";
    } else if (c == '>') {
      out += "&gt;";
    } else if (c == '&') {
      out += "&amp;";
    } else {
      out += c;
    }
  }
  return out;
}

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", std::abs(value) < 1e-12 ? 0.0 : value);
  return text;
}

std::string compact_rate(double value) {  // 100, 1k, 10k, 100k, 1M
  if (value >= 1e6) return number(value / 1e6) + "M";
  if (value >= 1e3) return number(value / 1e3) + "k";
  return number(value);
}

// A tick step of 1, 2 or 5 times a power of ten giving at most 6 intervals over `span`.
double tick_step(double span) {
  const double power = std::pow(10.0, std::floor(std::log10(span / 6)));
  for (const double factor : {1.0, 2.0, 5.0, 10.0}) {
    if (span / (factor * power) <= 6) return factor * power;
  }
  return 10 * power;
}

// The trade as an SVG: one column of panels per character, x = frames/s on one core (log scale,
// the speed aims as dashed verticals), one row per measure (kMeasures, its aim dashed); one
// labelled marker per setting. Labels that would overlap are moved up or down in steps of a line,
// with a leader line back to their marker.
std::string trade_svg(const std::vector<Row>& rows, const std::vector<Setting>& settings, const std::vector<Target>& targets,
                      const std::string& machine) {
  std::map<std::pair<const Target*, const Setting*>, PlotPoint> points;
  std::map<std::pair<const Target*, const Setting*>, std::pair<double, double>> frames_seconds;
  for (const Row& row : rows) {
    if (!row.measured) continue;
    const auto key = std::pair{row.job->target, row.setting};
    PlotPoint& point = points[key];
    auto& [frames, seconds] = frames_seconds[key];
    frames += row.job->fast.report.frames;
    seconds += row.seconds;
    point.fps = frames / seconds;
    for (std::size_t m = 0; m < kMeasures.size(); ++m) point.values[m] = std::max(point.values[m], kMeasures[m].of(row));
  }
  if (points.empty()) return {};

  // x: whole decades around the data and the speed aims; y: the data, the aim and zero.
  double low = kAccurateAimFps, high = kFastAimFps;
  std::array<double, kMeasureCount> y_low, y_high;
  for (std::size_t m = 0; m < kMeasures.size(); ++m) {
    y_low[m] = std::min(0.0, kMeasures[m].aim_value);
    y_high[m] = std::max(kMeasures[m].aim_value * 1.5, 1e-6);
  }
  for (const auto& [key, point] : points) {
    low = std::min(low, point.fps);
    high = std::max(high, point.fps);
    for (std::size_t m = 0; m < kMeasures.size(); ++m) {
      y_low[m] = std::min(y_low[m], point.values[m]);
      y_high[m] = std::max(y_high[m], point.values[m]);
    }
  }
  std::array<double, kMeasureCount> y_step;
  for (std::size_t m = 0; m < kMeasures.size(); ++m) {
    y_step[m] = tick_step(y_high[m] - y_low[m]);
    y_low[m] = std::floor(y_low[m] / y_step[m] + 1e-9) * y_step[m];
    y_high[m] = std::ceil(y_high[m] / y_step[m] * 1.05) * y_step[m];
  }
  const double first_decade = std::floor(std::log10(low)), last_decade = std::ceil(std::log10(high));

  const double panel_w = 300, panel_h = 170, left = 80, top = 112, gap_x = 45, gap_y = 42, line = 13;
  const double width = left + targets.size() * panel_w + (targets.size() - 1) * gap_x + 20;
  const double height = top + kMeasures.size() * (panel_h + gap_y) + 60;
  const char* colours[] = {"#d62728", "#1f77b4", "#2ca02c", "#17becf", "#9467bd", "#8c564b"};

  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height << "\" viewBox=\"0 0 " << width
      << ' ' << height << "\" font-family=\"Helvetica, Arial, sans-serif\" font-size=\"12\">\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      << "<text x=\"" << left << "\" y=\"24\" font-size=\"17\" font-weight=\"bold\">Retargeting: speed against accuracy "
      << "(one core, 30 fps clips, --parts body)</text>\n"
      << "<text x=\"" << left << "\" y=\"42\" fill=\"#444\">x: frames/s on one core, log scale (fast: the transfer stage; "
      << "the others: the refine() call), pooled over the CMU walk, CMU jump and SMPL-X walk.</text>\n"
      << "<text x=\"" << left << "\" y=\"56\" fill=\"#444\">y, the worst clip's: the worst limb's mean bone direction "
      << "error; the larger of mean penetration and floating during contact;</text>\n"
      << "<text x=\"" << left << "\" y=\"70\" fill=\"#444\">the foot skate ratio (scale-aware) minus the source's; the jitter "
      << "over the source's. Dashed: the aims (verticals: speed per quality; horizontals: accuracy). Better is down and "
      << "right.</text>\n";

  for (std::size_t c = 0; c < targets.size(); ++c) {
    const double x0 = left + c * (panel_w + gap_x);
    const auto x_of = [&](double fps) {
      return x0 + panel_w * (std::log10(fps) - first_decade) / (last_decade - first_decade);
    };
    for (std::size_t m = 0; m < kMeasures.size(); ++m) {
      const Measure& measure = kMeasures[m];
      const double y0 = top + m * (panel_h + gap_y);
      const auto y_of = [&](double value) { return y0 + panel_h * (y_high[m] - value) / (y_high[m] - y_low[m]); };
      svg << "<rect x=\"" << x0 << "\" y=\"" << y0 << "\" width=\"" << panel_w << "\" height=\"" << panel_h
          << "\" fill=\"#fafafa\" stroke=\"#888\"/>\n";
      if (m == 0) {
        svg << "<text x=\"" << x0 + panel_w / 2 << "\" y=\"" << y0 - 20 << "\" text-anchor=\"middle\" font-size=\"14\" "
            << "font-weight=\"bold\">" << escaped(targets[c].name) << "</text>\n";
      }
      for (double d = first_decade; d <= last_decade; ++d) {
        const double x = x_of(std::pow(10.0, d));
        svg << "<line x1=\"" << x << "\" y1=\"" << y0 << "\" x2=\"" << x << "\" y2=\"" << y0 + panel_h
            << "\" stroke=\"#e4e4e4\"/>\n<text x=\"" << x << "\" y=\"" << y0 + panel_h + 14 << "\" text-anchor=\"middle\">"
            << compact_rate(std::pow(10.0, d)) << "</text>\n";
      }
      for (double v = y_low[m]; v <= y_high[m] + y_step[m] / 2; v += y_step[m]) {
        svg << "<line x1=\"" << x0 << "\" y1=\"" << y_of(v) << "\" x2=\"" << x0 + panel_w << "\" y2=\"" << y_of(v)
            << "\" stroke=\"#e4e4e4\"/>\n<text x=\"" << x0 - 5 << "\" y=\"" << y_of(v) + 4 << "\" text-anchor=\"end\">"
            << number(v) << "</text>\n";
      }
      if (c == 0) {
        svg << "<text transform=\"translate(" << left - 45 << ',' << y0 + panel_h / 2 << ") rotate(-90)\" "
            << "text-anchor=\"middle\" font-size=\"11\">" << escaped(measure.axis) << "</text>\n";
      }
      // The speed aims, tagged above the top row.
      for (const auto& [fps, name] : {std::pair{kAccurateAimFps, "acc 500/s"}, std::pair{kBalancedAimFps, "bal 3k/s"},
                                      std::pair{kFastAimFps, "fast 50k/s"}}) {
        const double x = x_of(fps);
        svg << "<line x1=\"" << x << "\" y1=\"" << y0 << "\" x2=\"" << x << "\" y2=\"" << y0 + panel_h
            << "\" stroke=\"#666\" stroke-dasharray=\"4 3\"/>\n";
        if (m == 0) {
          svg << "<text x=\"" << x << "\" y=\"" << y0 - 4 << "\" text-anchor=\"middle\" font-size=\"10\" fill=\"#666\">"
              << name << "</text>\n";
        }
      }
      const double aim_y = y_of(measure.aim_value);
      svg << "<line x1=\"" << x0 << "\" y1=\"" << aim_y << "\" x2=\"" << x0 + panel_w << "\" y2=\"" << aim_y
          << "\" stroke=\"#666\" stroke-dasharray=\"4 3\"/>\n<text x=\"" << x0 + panel_w - 4 << "\" y=\"" << aim_y - 4
          << "\" text-anchor=\"end\" font-size=\"10\" fill=\"#666\">" << escaped(measure.aim) << "</text>\n";

      // Markers first, then their labels: right of the marker (left of it in the panel's right
      // third), moved by whole lines until clear of every marker and of the labels already placed,
      // and inside the panel.
      struct Box {
        double x_min, x_max, y_min, y_max;
        bool overlaps(const Box& other) const {
          return x_min < other.x_max && other.x_min < x_max && y_min < other.y_max && other.y_min < y_max;
        }
      };
      struct Marker {
        std::size_t setting;
        double x, y;
      };
      std::vector<Marker> markers;
      std::vector<Box> taken;
      for (std::size_t s = 0; s < settings.size(); ++s) {
        const auto found = points.find(std::pair{&targets[c], &settings[s]});
        if (found == points.end()) continue;
        const Marker marker{s, x_of(found->second.fps), y_of(found->second.values[m])};
        markers.push_back(marker);
        taken.push_back({marker.x - 5, marker.x + 5, marker.y - 5, marker.y + 5});
        svg << "<circle cx=\"" << marker.x << "\" cy=\"" << marker.y << "\" r=\"4.5\" fill=\"" << colours[s % 6]
            << "\" stroke=\"black\" stroke-width=\"0.6\"/>\n";
      }
      for (const Marker& marker : markers) {
        const std::string& label = settings[marker.setting].label;
        const bool to_left = marker.x > x0 + panel_w * 0.67;
        const double text_w = 6.2 * label.size();
        const double x_min = to_left ? marker.x - 8 - text_w : marker.x + 8;
        double label_y = marker.y;
        for (int k = 0; k < 40; ++k) {
          const double candidate = marker.y + line * ((k + 1) / 2) * (k % 2 == 1 ? -1 : 1);
          if (candidate < y0 + line / 2 || candidate > y0 + panel_h - line / 2) continue;
          const Box box{x_min, x_min + text_w, candidate - line / 2, candidate + line / 2};
          if (std::none_of(taken.begin(), taken.end(), [&](const Box& other) { return box.overlaps(other); })) {
            label_y = candidate;
            break;
          }
        }
        taken.push_back({x_min, x_min + text_w, label_y - line / 2, label_y + line / 2});
        const char* colour = colours[marker.setting % 6];
        if (std::abs(label_y - marker.y) > 1) {
          svg << "<line x1=\"" << marker.x << "\" y1=\"" << marker.y << "\" x2=\"" << (to_left ? x_min + text_w : x_min - 1)
              << "\" y2=\"" << label_y << "\" stroke=\"" << colour << "\" stroke-width=\"0.6\"/>\n";
        }
        svg << "<text x=\"" << x_min << "\" y=\"" << label_y + 4 << "\" font-size=\"11\" fill=\"" << colour << "\">"
            << escaped(label) << "</text>\n";
      }
      if (m + 1 == kMeasures.size()) {
        svg << "<text x=\"" << x0 + panel_w / 2 << "\" y=\"" << y0 + panel_h + 29 << "\" text-anchor=\"middle\" fill=\"#444\">"
            << "frames/s on one core</text>\n";
      }
    }
  }
  // Legend: the settings' full names, and the machine.
  const double legend_y = top + kMeasures.size() * (panel_h + gap_y) + 8;
  for (std::size_t s = 0; s < settings.size(); ++s) {
    const double x = left + (s % 3) * 320, y = legend_y + (s / 3) * 16;
    svg << "<circle cx=\"" << x << "\" cy=\"" << y - 4 << "\" r=\"4.5\" fill=\"" << colours[s % 6]
        << "\" stroke=\"black\" stroke-width=\"0.6\"/>\n<text x=\"" << x + 9 << "\" y=\"" << y << "\">" << escaped(settings[s].label)
        << ": " << escaped(settings[s].name) << "</text>\n";
  }
  svg << "<text x=\"" << left << "\" y=\"" << legend_y + 38 << "\" font-size=\"10\" fill=\"#666\">" << escaped(machine) << "</text>\n</svg>\n";
  return svg.str();
}

std::string load_average() {
  std::ifstream file("/proc/loadavg");
  std::string one_minute;
  file >> one_minute;
  return one_minute.empty() ? "unknown" : one_minute;
}

}  // namespace
}  // namespace odyssey::retarget

int main(int argc, char** argv) {
  using namespace odyssey::retarget;
  // Our defaults go first, so that the same flags given on the command line override them.
  std::string svg_path;
  std::vector<char*> arguments = {argv[0]};
  std::string repetitions = "--benchmark_repetitions=3", aggregates = "--benchmark_display_aggregates_only=true";
  arguments.push_back(repetitions.data());
  arguments.push_back(aggregates.data());
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--svg") == 0 && i + 1 < argc) {
      svg_path = argv[++i];
    } else if (std::strncmp(argv[i], "--svg=", 6) == 0) {
      svg_path = argv[i] + 6;
    } else {
      arguments.push_back(argv[i]);
    }
  }
  int count = int(arguments.size());
  benchmark::Initialize(&count, arguments.data());
  if (benchmark::ReportUnrecognizedArguments(count, arguments.data())) return 1;
  const std::string load_before = load_average();

  const std::vector<Setting> settings = make_settings();
  const std::vector<Motion> motions = load_motions();
  const std::vector<Target> targets = load_targets();
  std::vector<Job> jobs;
  jobs.reserve(motions.size() * targets.size());  // rows point into it
  for (const Motion& motion : motions) {
    for (const Target& target : targets) jobs.push_back(prepare_job(motion, target));
  }
  std::vector<Row> rows;
  rows.reserve(jobs.size() * settings.size());  // benchmarks hold references to rows
  for (const Job& job : jobs) {
    for (const Setting& setting : settings) {
      Row& row = rows.emplace_back(&job, &setting);
      std::string name = job.motion->name + "/" + job.target->name + "/" + setting.name;
      std::replace(name.begin(), name.end(), ' ', '_');
      benchmark::RegisterBenchmark(name.c_str(), [&row](benchmark::State& state) {
        if (row.setting->options.quality == Quality::fast) {
          time_transfer(state, row);
        } else {
          time_refine(state, row);
        }
      })->UseManualTime()->Unit(benchmark::kMillisecond);
    }
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();

  print_setup_table(jobs);
  print_table(rows);
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  char machine[512];
  std::snprintf(machine, sizeof machine, "machine: %s, %u cores; load average %s before, %s after; peak RSS %.0f MiB",
                odyssey::bench::cpu_model().c_str(), std::thread::hardware_concurrency(), load_before.c_str(),
                load_average().c_str(), usage.ru_maxrss / 1024.0);
  std::printf("%s\n", machine);
  if (!svg_path.empty()) {
    std::ofstream out(svg_path);
    out << trade_svg(rows, settings, targets, machine);
    if (!out) {
      std::fprintf(stderr, "cannot write %s\n", svg_path.c_str());
      return 1;
    }
    std::printf("wrote %s\n", svg_path.c_str());
  }
  return 0;
}
