// harvest-sim's node live, with a renderer stuck on a frame: the loop keeps
// stepping the physics, the drives and the board and publishing ROBOT_STATE,
// and the stuck camera's ticks are dropped and counted (docs/simulator.md,
// "Threads"). With the cameras rendered on the loop (render_thread false)
// nothing moves while the frame is stuck, and this test fails.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "harvest/image_t.hpp"
#include "harvest/robot_state_t.hpp"
#include "runtime/channels.hpp"
#include "runtime/live_runner.hpp"
#include "runtime/process_main.hpp"
#include "sim/ports.hpp"
#include "sim/sim_node.hpp"
#include "test_support.hpp"

namespace harvest::sim {
namespace {

namespace ht = harvest::testing;
using namespace std::chrono_literals;

// Holds every rendered frame until opened.
class Gate {
 public:
  void wait_open() {
    std::unique_lock lock(m_);
    cv_.wait(lock, [this] { return open_; });
  }
  void open() {
    std::lock_guard lock(m_);
    open_ = true;
    cv_.notify_all();
  }
  bool is_open() {
    std::lock_guard lock(m_);
    return open_;
  }

 private:
  std::mutex m_;
  std::condition_variable cv_;
  bool open_ = false;
};

// On the simulator's own loop: counts ROBOT_STATE and CAMERA_FIXED and, once
// `enough` says the loop kept going while no frame came out, opens the gate;
// stops the run at the first frame after that.
class Probe final : public rt::Node {
 public:
  Probe(Gate& gate, std::function<bool(const Probe&)> enough)
      : rt::Node("probe"), gate_(gate), enough_(std::move(enough)) {}
  int robot_states = 0, frames = 0, frames_while_stuck = -1, robot_states_while_stuck = -1;
  std::atomic<bool> done{false};

 protected:
  void on_attach() override {
    subscribe<robot_state_t>(channels::kRobotState, [this](const robot_state_t&) { ++robot_states; });
    subscribe<image_t>(channels::kCameraFixed, [this](const image_t&) {
      ++frames;
      if (gate_.is_open() && !done) {
        done = true;
        ctx().request_stop(0);
      }
    });
    every(10 * rt::kMilli, [this] {
      if (frames_while_stuck < 0 && enough_(*this)) {
        frames_while_stuck = frames;
        robot_states_while_stuck = robot_states;
        gate_.open();
      }
    });
  }

 private:
  Gate& gate_;
  std::function<bool(const Probe&)> enough_;
};

struct Outcome {
  bool finished = false;  // the probe saw the loop go on and a frame after the gate opened
  int frames_while_stuck = -1, robot_states_while_stuck = -1;
  Timekeeping::FrameTotals fixed;
  int64_t drive_steps = 0, physics_steps = 0;
};

Outcome run_stuck(SimConfig config, bool devices) {
  Scenario scenario = load_scenario(config.scenario_path).for_run(0);
  config.stop_when_done = false;
  config.realtime_priority = 0;  // the shipped configs ask SCHED_FIFO: not for the test process's own thread
  SimNode node(config, scenario);
  Gate gate;
  node.set_render_delay([&] { gate.wait_open(); });
  auto steps = [&](const std::string& name) {
    for (const auto& s : node.timekeeping().steps())
      if (s.name == name) return s.steps;
    return int64_t{0};
  };
  // Half a second of the loop's work with the renderer stuck on its first frame.
  Probe probe(gate, [&](const Probe& p) {
    return devices ? steps("drives") >= 500 && steps("board") >= 100 : p.robot_states >= 50;
  });
  rt::LiveRunner runner(rt::LiveOptions{ht::unique_lcm_url(), ""});
  runner.add(node);
  runner.add(probe);
  std::thread loop([&] { runner.run(); });
  Outcome out;
  out.finished = ht::eventually([&] { return probe.done.load(); }, 60s);
  gate.open();  // let a loop stuck in a render go
  runner.request_stop(0);
  loop.join();
  out.frames_while_stuck = probe.frames_while_stuck;
  out.robot_states_while_stuck = probe.robot_states_while_stuck;
  out.fixed = node.timekeeping().frames(CameraId::kFixed);
  out.drive_steps = steps("drives");
  out.physics_steps = steps("physics");
  return out;
}

TEST(SimRenderThread, DirectModeKeepsPublishingRobotStateWhileARenderIsStuck) {
  auto doc = rt::load_config(ht::source_path("config/sim/sim.yaml"), {});
  const Outcome o = run_stuck(SimConfig::from_config(doc.root()), false);
  ASSERT_TRUE(o.finished) << "the loop stopped while the renderer was stuck";
  EXPECT_EQ(o.frames_while_stuck, 0);  // the renderer really was stuck
  EXPECT_GE(o.robot_states_while_stuck, 50);
  EXPECT_GT(o.physics_steps, 40);
  EXPECT_GT(o.fixed.dropped, 0);  // the ticks during the stall: dropped, not queued
  EXPECT_GE(o.fixed.rendered, 1);
}

TEST(SimRenderThread, DevicesModeKeepsStepingTheDrivesAndTheBoardWhileARenderIsStuck) {
  const std::string bus = "udp_multicast:239.74.165." + std::to_string(10 + ::getpid() % 200) + ":" +
                          std::to_string(free_port(true)) + "?ttl=0";
  auto doc = rt::load_config(ht::source_path("config/sim/sim-devices.yaml"),
                             {"devices.bus=" + bus, "devices.board.port=" + std::to_string(free_port(false))});
  const Outcome o = run_stuck(SimConfig::from_config(doc.root()), true);
  ASSERT_TRUE(o.finished) << "the loop stopped while the renderer was stuck";
  EXPECT_EQ(o.frames_while_stuck, 0);
  EXPECT_GE(o.drive_steps, 500);
  EXPECT_GT(o.fixed.dropped, 0);
  EXPECT_GE(o.fixed.rendered, 1);
}

}  // namespace
}  // namespace harvest::sim
