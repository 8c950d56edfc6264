// The betas policy (skeleton/betas.h): AMASS-style sequences of 10, 16 and 300 betas on SMPL-X
// models of 10 shape directions (the smplx package's 10 + 10 layout, made here by slicing the
// synthetic model's shapedirs) and 300 (the synthetic model itself, 300 + 100).
//
// The default (fit) drops extra betas with a warning giving the count and the largest magnitude
// and pads missing ones with zeros; truncate only drops, pad only pads, error refuses any
// mismatch naming both counts. Dropped betas are never read as expression directions: the body
// posed from 16 betas on a 10 + 10 model is the body posed from the first 10. Retargeting applies
// the same function and reports it under inputs.betas; scene files carry it as actors[].betas.
// The command-line side is tests/test_betas_cli.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "mocap_io/amass.h"
#include "mocap_io/body_model_file.h"
#include "mocap_io/body_model_writer.h"
#include "mocap_io/input_error.h"
#include "scene_layouts/actor.h"
#include "scene_layouts/scene_file.h"
#include "skeleton/betas.h"
#include "skeleton/body_clip.h"
#include "skeleton/body_sequence.h"
#include "synthetic/synthetic_body.h"
#include "synthetic/synthetic_walk.h"
#include "test_support.h"

namespace odyssey {
namespace {

namespace fs = std::filesystem;
using test_support::contains;
using test_support::message_of;

const std::string kCesiumMan = std::string(ODYSSEY_SHARED_DIR) + "/assets/characters/CesiumMan.glb";

// The synthetic SMPL-X model: 300 shape then 100 expression directions.
const BodyModel& model300() {
  static const BodyModel model = make_synthetic_body(0).model;
  return model;
}

// The smplx package's older layout: 10 shape then 10 expression directions, the synthetic
// model's first 10 of each.
BodyModel sliced_model(int shape, int expression) {
  BodyModel model = model300();
  RowMatrixXd shapedirs(model.shapedirs.rows(), shape + expression);
  shapedirs.leftCols(shape) = model300().shapedirs.leftCols(shape);
  shapedirs.rightCols(expression) = model300().shapedirs.middleCols(model300().shape_count, expression);
  model.shapedirs = std::move(shapedirs);
  model.shape_count = shape;
  model.expression_count = expression;
  return model;
}
const BodyModel& model10() {
  static const BodyModel model = sliced_model(10, 10);
  return model;
}

// n betas, 0.1-ish values, with -2.5 at index 12 (dropped on a 10-direction model) when n > 12.
std::vector<double> betas_of(int n) {
  std::vector<double> betas(n);
  for (int i = 0; i < n; ++i) betas[i] = 0.05 * ((i * 7) % 11) - 0.25;
  if (n > 12) betas[12] = -2.5;
  return betas;
}

fs::path scratch(const std::string& name) {
  const fs::path dir = test_support::scratch_root() / "betas";
  fs::create_directories(dir);
  return dir / name;
}

// An AMASS-style SMPL-X walk with `n` betas, written once per count.
std::string walk_file(int n) {
  const fs::path path = scratch("walk_" + std::to_string(n) + ".npz");
  if (!fs::exists(path)) {
    BodySequence walk = synthetic_walk(12, 30, BodyModelKind::SMPLX, 5);
    walk.betas = betas_of(n);
    io::write_amass(path.string(), walk);
  }
  return path.string();
}

std::string model10_file() {
  const fs::path path = scratch("model10.npz");
  if (!fs::exists(path)) io::write_body_model(path.string(), model10());
  return path.string();
}

// The rest joints and shaped vertices of `betas` on `model`, flattened.
std::vector<double> shaped(const BodyModel& model, std::span<const double> betas) {
  BodyModelEvaluator evaluator(model);
  evaluator.set_shape(betas);
  std::vector<double> out(evaluator.shaped_vertices().data(),
                          evaluator.shaped_vertices().data() + evaluator.shaped_vertices().size());
  out.insert(out.end(), evaluator.rest_joints().data(), evaluator.rest_joints().data() + evaluator.rest_joints().size());
  return out;
}

TEST(BetasPolicy, NamesParseBack) {
  for (BetasPolicy policy : {BetasPolicy::fit, BetasPolicy::truncate, BetasPolicy::pad, BetasPolicy::error}) {
    EXPECT_EQ(parse_betas_policy(betas_policy_name(policy)), policy);
  }
  EXPECT_FALSE(parse_betas_policy("clip"));
  EXPECT_FALSE(parse_betas_policy(""));
  EXPECT_FALSE(parse_betas_policy("Fit"));
}

TEST(BetasPolicy, ShapeCountComesFromTheModelFileLayout) {
  // 20 columns in an SMPL-X file are 10 shape then 10 expression directions, however many betas
  // a sequence carries.
  const BodyModel loaded = io::load_body_model(model10_file());
  EXPECT_EQ(loaded.shape_count, 10);
  EXPECT_EQ(loaded.expression_count, 10);
  EXPECT_EQ(model300().shape_count, 300);
  EXPECT_EQ(model300().expression_count, 100);
}

TEST(BetasPolicy, DefaultDropsExtrasWithAWarningOfCountAndMagnitude) {
  for (int n : {16, 300}) {
    const std::vector<double> betas = betas_of(n);
    const BetasFit fit = fit_betas(model10(), betas);
    EXPECT_EQ(fit.policy, BetasPolicy::fit);
    EXPECT_EQ(fit.file_count, n);
    EXPECT_EQ(fit.model_count, 10);
    EXPECT_EQ(fit.dropped, n - 10);
    EXPECT_EQ(fit.padded, 0);
    EXPECT_DOUBLE_EQ(fit.largest_dropped, 2.5);
    EXPECT_EQ(fit.betas, std::vector<double>(betas.begin(), betas.begin() + 10));
    const std::string warning = fit.warning();
    EXPECT_TRUE(contains(warning, "dropped " + std::to_string(n - 10) + " betas")) << warning;
    EXPECT_TRUE(contains(warning, "10 shape directions")) << warning;
    EXPECT_TRUE(contains(warning, "largest magnitude dropped 2.5")) << warning;
    EXPECT_TRUE(contains(fit.summary(), "policy fit: dropped " + std::to_string(n - 10))) << fit.summary();
  }
}

TEST(BetasPolicy, DefaultPadsMissingBetasWithZeros) {
  for (int n : {10, 16}) {
    const std::vector<double> betas = betas_of(n);
    const BetasFit fit = fit_betas(model300(), betas);
    EXPECT_EQ(fit.dropped, 0);
    EXPECT_EQ(fit.padded, 300 - n);
    EXPECT_EQ(fit.largest_dropped, 0);
    EXPECT_TRUE(fit.warning().empty());
    ASSERT_EQ(fit.betas.size(), 300u);
    std::vector<double> explicit_zeros = betas;
    explicit_zeros.resize(300, 0.0);
    EXPECT_EQ(fit.betas, explicit_zeros);
    // The padded body is the body of explicit zeros, and (to rounding: the product sums in
    // another order) of the short vector itself.
    const std::vector<double> padded = shaped(model300(), fit.betas), short_vector = shaped(model300(), betas);
    EXPECT_EQ(padded, shaped(model300(), explicit_zeros));
    ASSERT_EQ(padded.size(), short_vector.size());
    for (std::size_t i = 0; i < padded.size(); ++i) ASSERT_NEAR(padded[i], short_vector[i], 1e-12) << i;
  }
}

TEST(BetasPolicy, MatchingCountsPassUnchangedUnderEveryPolicy) {
  for (BetasPolicy policy : {BetasPolicy::fit, BetasPolicy::truncate, BetasPolicy::pad, BetasPolicy::error}) {
    const BetasFit on10 = fit_betas(model10(), betas_of(10), policy);
    EXPECT_EQ(on10.betas, betas_of(10));
    EXPECT_EQ(on10.dropped + on10.padded, 0);
    const BetasFit on300 = fit_betas(model300(), betas_of(300), policy);
    EXPECT_EQ(on300.betas, betas_of(300));
    // No betas at all is the mean shape, not a mismatch.
    const BetasFit none = fit_betas(model10(), {}, policy);
    EXPECT_EQ(none.betas, std::vector<double>(10, 0.0));
    EXPECT_EQ(none.padded, 10);
  }
}

TEST(BetasPolicy, TruncateDropsAndRefusesFewer) {
  const std::vector<double> sixteen = betas_of(16);
  const BetasFit fit = fit_betas(model10(), sixteen, BetasPolicy::truncate);
  EXPECT_EQ(fit.dropped, 6);
  EXPECT_EQ(fit.betas, std::vector<double>(sixteen.begin(), sixteen.begin() + 10));
  const std::string message =
      message_of<std::invalid_argument>([] { fit_betas(model300(), betas_of(16), BetasPolicy::truncate); });
  EXPECT_TRUE(contains(message, "16 betas")) << message;
  EXPECT_TRUE(contains(message, "300 shape directions")) << message;
  EXPECT_TRUE(contains(message, "'truncate'")) << message;
}

TEST(BetasPolicy, PadPadsAndRefusesExtras) {
  const BetasFit fit = fit_betas(model300(), betas_of(16), BetasPolicy::pad);
  EXPECT_EQ(fit.padded, 284);
  const std::string message = message_of<std::invalid_argument>([] { fit_betas(model10(), betas_of(16), BetasPolicy::pad); });
  EXPECT_TRUE(contains(message, "16 betas")) << message;
  EXPECT_TRUE(contains(message, "10 shape directions")) << message;
  EXPECT_TRUE(contains(message, "'pad'")) << message;
}

TEST(BetasPolicy, ErrorRefusesAnyMismatchNamingBothCounts) {
  for (const auto& [n, model, directions] :
       {std::tuple{16, &model10(), 10}, std::tuple{300, &model10(), 10}, std::tuple{10, &model300(), 300},
        std::tuple{16, &model300(), 300}}) {
    const BodyModel* m = model;
    const int count = n;
    const std::string message =
        message_of<std::invalid_argument>([&] { fit_betas(*m, betas_of(count), BetasPolicy::error); });
    EXPECT_TRUE(contains(message, std::to_string(n) + " betas in the sequence")) << message;
    EXPECT_TRUE(contains(message, std::to_string(directions) + " shape directions")) << message;
  }
}

TEST(BetasPolicy, ExtraBetasAreNeverReadAsExpression) {
  // On the 10 + 10 model, betas 10-15 would land on expression directions if they were read as
  // such; the fitted body is the body of the first 10 betas.
  const BetasFit fit = fit_betas(model10(), betas_of(16));
  const std::vector<double> sixteen = betas_of(16);
  EXPECT_EQ(shaped(model10(), fit.betas), shaped(model10(), std::span(sixteen).first(10)));
}

// Retargeting: the request's policy, the report's inputs.betas, the file in the error.
scene::RetargetedActor retarget(int n, const std::string& model_file, BetasPolicy policy) {
  scene::RetargetRequest request = scene::retarget_request(walk_file(n), kCesiumMan);
  request.model_path = model_file;
  request.betas = policy;
  return scene::retarget_actor(request);
}

TEST(BetasPolicy, RetargetingReportsWhatItDid) {
  std::vector<std::string> messages;
  scene::RetargetRequest request = scene::retarget_request(walk_file(16), kCesiumMan);
  request.model_path = model10_file();
  const scene::RetargetedActor actor =
      scene::retarget_actor(request, [&](const scene::ProgressEvent& event) { messages.push_back(event.stage + ": " + event.message); });
  ASSERT_TRUE(actor.betas);
  const nlohmann::ordered_json report = scene::actor_report_json(actor);
  const nlohmann::ordered_json& betas = report["inputs"]["betas"];
  EXPECT_EQ(betas["policy"], "fit");
  EXPECT_EQ(betas["file_count"], 16);
  EXPECT_EQ(betas["model_count"], 10);
  EXPECT_EQ(betas["dropped"], 6);
  EXPECT_DOUBLE_EQ(betas["largest_dropped_magnitude"].get<double>(), 2.5);
  EXPECT_EQ(betas["padded"], 0);
  bool warned = false;
  for (const std::string& message : messages) {
    warned |= message.starts_with("warning: ") && contains(message, walk_file(16)) && contains(message, "dropped 6 betas") &&
              contains(message, "2.5");
  }
  EXPECT_TRUE(warned) << ::testing::PrintToString(messages);

  // The dropped betas change nothing: the source skeleton is the one of the first 10.
  const scene::RetargetedActor ten = retarget(10, model10_file(), BetasPolicy::error);
  EXPECT_EQ(actor.source.skeleton.rest_offsets(), ten.source.skeleton.rest_offsets());
  EXPECT_EQ(actor.source.translations, ten.source.translations);
  EXPECT_EQ(scene::actor_report_json(ten)["inputs"]["betas"]["dropped"], 0);

  // Padding on the synthetic default model (300 directions).
  request.model_path.reset();
  const nlohmann::ordered_json padded = scene::actor_report_json(scene::retarget_actor(request))["inputs"]["betas"];
  EXPECT_EQ(padded["model_count"], 300);
  EXPECT_EQ(padded["padded"], 284);
}

TEST(BetasPolicy, RetargetingRefusesNamingTheFileAndCounts) {
  const std::string message =
      message_of<io::InputError>([] { retarget(16, model10_file(), BetasPolicy::error); });
  EXPECT_TRUE(contains(message, walk_file(16))) << message;
  EXPECT_TRUE(contains(message, model10_file())) << message;
  EXPECT_TRUE(contains(message, "16 betas")) << message;
  EXPECT_TRUE(contains(message, "10 shape directions")) << message;
}

TEST(BetasPolicy, SceneFilesCarryThePolicyPerActor) {
  const auto scene_with = [](const std::string& betas) {
    return std::string(R"({"version": 1, "actors": [{"motion": "walk.npz", "character": "c.glb"},
                                         {"name": "b", "motion": "walk.npz", "character": "c.glb", "betas": )") +
           betas + "}]}";
  };
  for (BetasPolicy policy : {BetasPolicy::fit, BetasPolicy::truncate, BetasPolicy::pad, BetasPolicy::error}) {
    const scene::SceneFile file = scene::parse_scene(scene_with(std::string("\"") + betas_policy_name(policy) + "\""), "shot.json");
    EXPECT_EQ(std::get<scene::RetargetRequest>(file.scene.actors[0].source).betas, BetasPolicy::fit);
    EXPECT_EQ(std::get<scene::RetargetRequest>(file.scene.actors[1].source).betas, policy);
  }
  const std::string bad = message_of<io::InputError>([&] { scene::parse_scene(scene_with("\"clip\""), "shot.json"); });
  EXPECT_TRUE(contains(bad, "shot.json")) << bad;
  EXPECT_TRUE(contains(bad, "actors[1].betas")) << bad;
  EXPECT_TRUE(contains(bad, "fit, truncate, pad or error")) << bad;
  const std::string number = message_of<io::InputError>([&] { scene::parse_scene(scene_with("10"), "shot.json"); });
  EXPECT_TRUE(contains(number, "actors[1].betas")) << number;
}

}  // namespace
}  // namespace odyssey
