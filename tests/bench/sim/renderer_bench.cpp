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
#include "sim/sim_node.hpp"

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

void BM_Render(benchmark::State& state) {
  const Scenario s = load_scenario(scenario_path(static_cast<int>(state.range(0))));
  Scene scene(s);
  const int view = static_cast<int>(state.range(1));
  const CameraSetup& cam = view == 0 ? s.fixed_camera : s.hand_camera;
  Renderer r(cam.model, cam.noise_std, 1);
  const Placement pose = camera_pose(s, scene, view);
  for (auto _ : state) benchmark::DoNotOptimize(r.render(scene, pose).data);
  state.SetLabel(s.name + (view == 0 ? " fixed" : view == 1 ? " hand@start" : " hand@fruit"));
}
BENCHMARK(BM_Render)->ArgsProduct({{0, 1, 2}, {0, 1, 2}})->Unit(benchmark::kMillisecond);

void BM_RenderAndEncode(benchmark::State& state) {
  const Scenario s = load_scenario(scenario_path(static_cast<int>(state.range(0))));
  Scene scene(s);
  Renderer r(s.hand_camera.model, s.hand_camera.noise_std, 1);
  const Placement pose = camera_pose(s, scene, 2);
  for (auto _ : state) {
    const image_t img = SimNode::make_image(r.render(scene, pose), s.hand_camera.encoding, s.hand_camera.jpeg_quality);
    benchmark::DoNotOptimize(img.data.data());
  }
  state.SetLabel(s.name + " hand@fruit + " + s.hand_camera.encoding);
}
BENCHMARK(BM_RenderAndEncode)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace harvest::sim

BENCHMARK_MAIN();
