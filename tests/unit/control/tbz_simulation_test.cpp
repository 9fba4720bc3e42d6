// The thesis simulation (section 5.6.2) regulates both errors exponentially.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "config/config.hpp"
#include "control/tbz_simulation.hpp"

namespace c = harvest::control;

namespace {
struct Thesis {
  c::ThesisScenario scenario;
  c::TbzParams params;
  c::SimOptions opt;
};
Thesis load() {
  auto doc = harvest::config::Document::load_file("config/tbz/thesis_sim.yaml");
  Thesis t;
  t.scenario = c::ThesisScenario::from_config(doc.root().child("scenario"));
  t.params = c::TbzParams::from_config(doc.root().child("controller"));
  const auto sim = doc.root().child("simulation");
  t.opt.duration = sim.get<double>("duration_s", 10.0);
  t.opt.dt = sim.get<double>("dt_s", 1e-3);
  t.opt.record_period = sim.get<double>("record_period_s", 0.01);
  t.opt.use_vanishing_points = sim.get<bool>("use_vanishing_points", true);
  doc.check_unused();
  return t;
}
}  // namespace

TEST(TbzSimulation, SceneReproducesTheDesiredImageAndReportsResiduals) {
  const auto t = load();
  const auto scene = c::fit_scene(t.scenario);
  // The desired image is reproduced exactly by construction.
  for (std::size_t i = 0; i < scene.X_d.size(); ++i)
    EXPECT_LT(((t.scenario.A * scene.X_d[i]).hnormalized() - t.scenario.p_star[i]).norm(), 1e-9);
  EXPECT_NEAR(scene.X_d[0].z(), 1.0, 1e-12);
  EXPECT_LT(scene.rms_point_px, 0.5);  // initial target pixels
  // The thesis's zoomed pixels are ~5x, not 2x, the unzoomed ones.
  EXPECT_NEAR(scene.zoom_factor_fit, 4.97, 0.01);
  EXPECT_GT(scene.zoom2_rms_px, 4.0);
}

TEST(TbzSimulation, ThesisRunRegulatesExponentially) {
  const auto t = load();
  const auto scene = c::fit_scene(t.scenario);
  const auto r = c::simulate(t.scenario, scene, t.params, t.opt);
  const auto& s = r.summary;
  EXPECT_EQ(s.failed_steps, 0);
  EXPECT_GT(s.initial_rotation_error, 1.0);
  EXPECT_LT(s.final_rotation_error, 1e-3 * s.initial_rotation_error);
  EXPECT_LT(s.final_translation_error, 1e-3 * s.initial_translation_error);
  EXPECT_LT(s.final_position_error_m, 1e-6);
  // Bounded velocities, and they vanish with the errors.
  EXPECT_TRUE(std::isfinite(s.max_linear_velocity));
  EXPECT_LT(s.max_linear_velocity, 50.0);
  EXPECT_LT(s.max_angular_velocity, 2.0 * t.params.lambda_w * M_PI);
  EXPECT_LT(r.samples.back().robot.v.norm(), 1e-6);
  // Log-linear fit of the error norms until they reach numerical noise.
  std::vector<double> time, ew, ev;
  for (const auto& smp : r.samples) {
    time.push_back(smp.t);
    ew.push_back(smp.e_w.norm());
    ev.push_back(smp.e_v.norm());
  }
  const auto fw = c::log_linear_fit(time, ew, 1e-9);
  const auto fv = c::log_linear_fit(time, ev, 1e-9);
  std::printf("rotation: slope %.3f /s R^2 %.4f; translation: slope %.3f /s R^2 %.4f\n", fw.slope, fw.r2, fv.slope,
              fv.r2);
  EXPECT_LT(fw.slope, 0.0);
  EXPECT_GT(fw.r2, 0.95);
  EXPECT_LT(fv.slope, 0.0);
  EXPECT_GT(fv.r2, 0.95);
}

TEST(TbzSimulation, WithoutVanishingPointsTheDecompositionPathAlsoConverges) {
  auto t = load();
  t.opt.use_vanishing_points = false;
  const auto scene = c::fit_scene(t.scenario);
  const auto r = c::simulate(t.scenario, scene, t.params, t.opt);
  EXPECT_EQ(r.summary.failed_steps, 0);
  EXPECT_LT(r.summary.final_rotation_error, 1e-3 * r.summary.initial_rotation_error);
  EXPECT_LT(r.summary.final_translation_error, 1e-3 * r.summary.initial_translation_error);
}

TEST(TbzSimulation, LogLinearFitOfAnExponential) {
  std::vector<double> t, y;
  for (int i = 0; i < 100; ++i) {
    t.push_back(0.1 * i);
    y.push_back(3.0 * std::exp(-1.5 * 0.1 * i));
  }
  const auto f = c::log_linear_fit(t, y);
  EXPECT_NEAR(f.slope, -1.5, 1e-9);
  EXPECT_NEAR(f.r2, 1.0, 1e-9);
}

// harvest-tbz-sim without --config: the thesis numbers, as in config/tbz/thesis_sim.yaml (it once fell back to
// a vanishing-point weight and an R_r estimate of its own, and its scene fit failed).
TEST(TbzSimulation, DefaultsAreTheShippedThesisFile) {
  const auto file = load();
  auto empty = harvest::config::Document::load_string("{}", "<defaults>");
  const auto scenario = c::ThesisScenario::from_config(empty.root().child("scenario"));
  const auto params = c::TbzParams::from_config(empty.root().child("controller"), c::TbzParams::thesis_simulation());
  EXPECT_DOUBLE_EQ(scenario.vanishing_weight, file.scenario.vanishing_weight);
  EXPECT_LT((scenario.A - file.scenario.A).norm(), 1e-12);
  EXPECT_LT((scenario.R_r - file.scenario.R_r).norm(), 1e-12);
  EXPECT_LT((params.A_hat - file.params.A_hat).norm(), 1e-12);
  EXPECT_LT((params.R_r_hat - file.params.R_r_hat).norm(), 1e-12);
  EXPECT_EQ(params.max_linear_speed, file.params.max_linear_speed);
  EXPECT_EQ(params.max_angular_speed, file.params.max_angular_speed);
  EXPECT_EQ(params.lambda_v, file.params.lambda_v);
  EXPECT_EQ(params.gain_function, file.params.gain_function);
  const auto scene = c::fit_scene(scenario);
  EXPECT_LT(scene.rms_point_px, 0.5);
}
