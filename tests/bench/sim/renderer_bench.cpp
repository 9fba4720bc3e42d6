// Cost of one simulated camera frame (render + encode as the drivers publish
// it) for the shipped scenarios, from the fixed camera and from the hand
// camera at the scenario's start pose and close to a fruit. Both cameras run
// at 30 Hz, so the budget on one core is about 16 ms for the pair.
//
//   build-sim/bench/sim_renderer_bench   (run from the repository root)
#include <benchmark/benchmark.h>

#include <string>

#include "sim/renderer.hpp"
#include "sim/scenario.hpp"
#include "sim/scene.hpp"
#include "sim/cameras.hpp"

namespace harvest::sim {
namespace {

std::string scenario_path(int which) {
  static const char* names[] = {"experiment1", "tree", "tree_wind"};
  return std::string(HARVEST_SOURCE_DIR) + "/config/scenarios/" + names[which] + ".yaml";
}

// 0: fixed camera, 1: hand camera at the start pose, 2: hand camera 150 mm from a fruit.
Placement camera_pose(const Scenario& s, const Scene& scene, int view) {
  if (view == 0) return s.fixed_camera_truth;
  if (view == 1) return {look_at_rotation(s.arm.start_tool_position, s.arm.start_look_at), s.arm.start_tool_position};
  const Vec3 fruit = scene.fruit().front().position;
  const Vec3 from = fruit - 0.15 * (fruit - s.arm.start_tool_position).normalized();
  return {look_at_rotation(from, fruit), from};
}

Scenario with_look(Scenario s, int field) {
  s.look.style = field ? "field" : "flat";
  return s;
}

// The hand camera approaching the fruit at 0.3 m/s (motion blur in the field look).
Placement one_frame_earlier(const Placement& pose, const Scenario& s) {
  Placement p = pose;
  p.position -= pose.rotation.col(2) * (0.3 / s.hand_camera.rate_hz);
  return p;
}

// Args: scenario, view, look (0 flat, 1 field).
void BM_Render(benchmark::State& state) {
  const Scenario s = with_look(load_scenario(scenario_path(static_cast<int>(state.range(0)))),
                               static_cast<int>(state.range(2)));
  Scene scene(s);
  const int view = static_cast<int>(state.range(1));
  const CameraSetup& cam = view == 0 ? s.fixed_camera : s.hand_camera;
  Renderer r(cam.model, cam.noise_std, 1);
  r.set_look(s.look, cam.rate_hz);
  const Placement pose = camera_pose(s, scene, view);
  const Placement before = view == 0 ? pose : one_frame_earlier(pose, s);
  for (auto _ : state) benchmark::DoNotOptimize(r.render(scene, pose, before).data);
  state.SetLabel(s.name + (view == 0 ? " fixed" : view == 1 ? " hand@start" : " hand@fruit") + " " + s.look.style);
}
BENCHMARK(BM_Render)->ArgsProduct({{0, 1, 2}, {0, 1, 2}, {0, 1}})->Unit(benchmark::kMillisecond);

// Both cameras of a scenario, rendered and encoded as the simulator publishes
// them: the frame pair that has to fit in one core at 30 Hz. Args: scenario, look.
void BM_FramePair(benchmark::State& state) {
  const Scenario s = with_look(load_scenario(scenario_path(static_cast<int>(state.range(0)))),
                               static_cast<int>(state.range(1)));
  Scene scene(s);
  Renderer fixed(s.fixed_camera.model, s.fixed_camera.noise_std, 1), hand(s.hand_camera.model, s.hand_camera.noise_std, 2);
  fixed.set_look(s.look, s.fixed_camera.rate_hz);
  hand.set_look(s.look, s.hand_camera.rate_hz);
  const Placement near = camera_pose(s, scene, 2), before = one_frame_earlier(near, s);
  for (auto _ : state) {
    const image_t a = SimCameras::make_image(fixed.render(scene, s.fixed_camera_truth), s.fixed_camera.encoding,
                                             s.fixed_camera.jpeg_quality);
    const image_t b = SimCameras::make_image(hand.render(scene, near, before), s.hand_camera.encoding,
                                             s.hand_camera.jpeg_quality);
    benchmark::DoNotOptimize(a.data.data());
    benchmark::DoNotOptimize(b.data.data());
  }
  state.SetLabel(s.name + " fixed + hand@fruit, " + s.look.style + ", " + s.fixed_camera.encoding);
}
BENCHMARK(BM_FramePair)->ArgsProduct({{0, 1}, {0, 1}})->Unit(benchmark::kMillisecond);

void BM_RenderAndEncode(benchmark::State& state) {
  const Scenario s = load_scenario(scenario_path(static_cast<int>(state.range(0))));
  Scene scene(s);
  Renderer r(s.hand_camera.model, s.hand_camera.noise_std, 1);
  const Placement pose = camera_pose(s, scene, 2);
  for (auto _ : state) {
    const image_t img =
        SimCameras::make_image(r.render(scene, pose), s.hand_camera.encoding, s.hand_camera.jpeg_quality);
    benchmark::DoNotOptimize(img.data.data());
  }
  state.SetLabel(s.name + " hand@fruit + " + s.hand_camera.encoding);
}
BENCHMARK(BM_RenderAndEncode)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace harvest::sim

BENCHMARK_MAIN();
