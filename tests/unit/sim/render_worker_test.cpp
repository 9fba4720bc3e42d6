// The render thread: a slow renderer drops ticks (counted) and never holds up
// the loop that submits them; frames show the snapshot they were asked for.
#include "sim/render_worker.hpp"

#include <gtest/gtest.h>
#include <poll.h>
#include <sched.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <future>
#include <mutex>

#include "test_scenes.hpp"

namespace harvest::sim {
namespace {

using namespace std::chrono_literals;

// A renderer that blocks until opened, saying when it has started a frame.
class Gate {
 public:
  void wait_open() {
    std::unique_lock lock(m_);
    ++entered_;
    cv_.notify_all();
    cv_.wait(lock, [this] { return open_; });
  }
  bool wait_entered(int n) {
    std::unique_lock lock(m_);
    return cv_.wait_for(lock, 60s, [&] { return entered_ >= n; });
  }
  void open() {
    std::lock_guard lock(m_);
    open_ = true;
    cv_.notify_all();
  }

 private:
  std::mutex m_;
  std::condition_variable cv_;
  int entered_ = 0;
  bool open_ = false;
};

FrameRequest request(CameraId camera, int64_t utime) { return {camera, utime, {}, {}}; }

image_t stamped(const FrameRequest& r) {
  image_t img;
  img.header.utime = r.utime;
  return img;
}

bool readable(int fd, int timeout_ms) {
  pollfd p{fd, POLLIN, 0};
  return poll(&p, 1, timeout_ms) == 1;
}

std::vector<RenderWorker::Frame> take_at_least(RenderWorker& w, std::size_t n) {
  std::vector<RenderWorker::Frame> got;
  while (got.size() < n && readable(w.wake_fd(), 60'000))
    for (auto& f : w.take()) got.push_back(std::move(f));
  return got;
}

TEST(RenderWorker, ASlowRendererDropsTicksAndCountsThemWithoutHoldingUpTheLoop) {
  Gate gate;
  RenderWorker w(
      [&](const FrameRequest& r) {
        gate.wait_open();
        return stamped(r);
      },
      true);
  ASSERT_TRUE(w.threaded());
  ASSERT_TRUE(w.submit(request(CameraId::kFixed, 100)));
  ASSERT_TRUE(gate.wait_entered(1));
  // The renderer is stuck on frame 100. The loop's ticks return at once: the
  // fixed camera's are dropped, the hand camera's first one waits its turn
  // and its second is dropped.
  // (Were submit to wait for the renderer, this would never finish.)
  auto loop = std::async(std::launch::async, [&] {
    int accepted = 0;
    for (int i = 1; i <= 5; ++i) accepted += w.submit(request(CameraId::kFixed, 100 + i));
    accepted += w.submit(request(CameraId::kHand, 200));
    accepted += w.submit(request(CameraId::kHand, 201));
    return accepted;
  });
  const bool returned = loop.wait_for(60s) == std::future_status::ready;
  gate.open();
  ASSERT_TRUE(returned) << "submit() waited for the renderer";
  EXPECT_EQ(loop.get(), 1);
  EXPECT_EQ(w.stats(CameraId::kFixed).dropped, 5);
  EXPECT_EQ(w.stats(CameraId::kHand).dropped, 1);

  // The frames come back in render order, each with its own snapshot's time.
  const auto frames = take_at_least(w, 2);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].camera, CameraId::kFixed);
  EXPECT_EQ(frames[0].image.header.utime, 100);
  EXPECT_EQ(frames[1].camera, CameraId::kHand);
  EXPECT_EQ(frames[1].image.header.utime, 200);
  EXPECT_EQ(w.stats(CameraId::kFixed).rendered, 1);
  EXPECT_EQ(w.stats(CameraId::kHand).rendered, 1);
  EXPECT_TRUE(w.take().empty());  // all taken: nothing more to wake the loop for
  EXPECT_FALSE(readable(w.wake_fd(), 0));

  // Rendered: the camera takes ticks again.
  EXPECT_TRUE(w.submit(request(CameraId::kFixed, 300)));
  const auto next = take_at_least(w, 1);
  ASSERT_EQ(next.size(), 1u);
  EXPECT_EQ(next[0].image.header.utime, 300);
  EXPECT_EQ(w.stats(CameraId::kFixed).dropped, 5);
}

TEST(RenderWorker, InlineRendersAtOnceAndNeverDrops) {
  int rendered = 0;
  RenderWorker w(
      [&](const FrameRequest& r) {
        ++rendered;
        return stamped(r);
      },
      false);
  EXPECT_FALSE(w.threaded());
  EXPECT_EQ(w.wake_fd(), -1);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(w.submit(request(CameraId::kHand, i)));
  EXPECT_EQ(rendered, 3);
  const auto frames = w.take();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[2].image.header.utime, 2);
  EXPECT_EQ(w.stats(CameraId::kHand).dropped, 0);
  EXPECT_TRUE(w.take().empty());
}

TEST(RenderWorker, AFailedRenderComesBackAsAnErrorAndFreesTheCamera) {
  RenderWorker w([](const FrameRequest&) -> image_t { throw std::runtime_error("out of rays"); }, true);
  ASSERT_TRUE(w.submit(request(CameraId::kZoom, 1)));
  const auto frames = take_at_least(w, 1);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].error, "out of rays");
  EXPECT_TRUE(w.submit(request(CameraId::kZoom, 2)));
}

// The loop may run at real-time priority (the simulator's realtime_priority);
// the render thread never does, even when started from a real-time thread: a
// frame may wait, a drive may not.
TEST(RenderWorker, TheRenderThreadStaysAtNormalPriorityUnderARealTimeLoop) {
  const int before = sched_getscheduler(0);
  sched_param fifo{};
  fifo.sched_priority = 1;
  if (sched_setscheduler(0, SCHED_FIFO, &fifo) != 0) GTEST_SKIP() << "SCHED_FIFO not permitted here";
  std::atomic<int> policy{-2};
  {
    RenderWorker w(
        [&](const FrameRequest& r) {
          policy = sched_getscheduler(0);
          return stamped(r);
        },
        true);
    ASSERT_TRUE(w.submit(request(CameraId::kFixed, 1)));
    take_at_least(w, 1);
  }
  const sched_param normal{};
  sched_setscheduler(0, before, &normal);
  EXPECT_EQ(policy.load(), SCHED_OTHER);
}

// A frame shows the snapshot it was asked for, not the scene as the physics
// has moved it since: the cameras draw their own copy.
TEST(SimCameras, AFrameShowsItsSnapshotNotTheSceneAsItIsNow) {
  Scenario s = test::one_fruit(Vec3(0.0, 1.0, 0.0));
  s.fixed_camera.encoding = s.hand_camera.encoding = "bgr8";
  Scene scene(s);
  SimCameras cameras(s, scene);
  const FrameRequest before{CameraId::kFixed, 42, scene.fruit(), {}};
  scene.fruit()[0].position += Vec3(0.0, 0.0, 0.10);  // the physics moves on
  const FrameRequest after{CameraId::kFixed, 43, scene.fruit(), {}};
  const image_t a = cameras.render(before);
  const image_t b = cameras.render(after);
  const image_t a2 = cameras.render(before);
  EXPECT_EQ(a.header.utime, 42);
  EXPECT_EQ(a.header.frame_id, "camera_fixed");
  EXPECT_EQ(b.header.utime, 43);
  EXPECT_EQ(a.data, a2.data);  // no noise: the same snapshot, the same frame
  EXPECT_NE(a.data, b.data);
  // ... and the same frame a fresh set of cameras draws of a scene in that state.
  Scene fresh(s);
  SimCameras other(s, fresh);
  EXPECT_EQ(other.render(before).data, a.data);
  EXPECT_EQ(cameras.channel(CameraId::kHand), "CAMERA_HAND");
}

// The share of a fruit the fixed camera sees at the start (which fruit a run
// is scored on) is of its whole disc: a fruit the image border cuts in half
// is half visible, one mostly outside the image hardly at all (its in-image
// silhouette alone made it whole: a tree run counted a fruit 95 % outside).
TEST(SimCameras, AFruitCutByTheImageBorderIsPartlyVisible) {
  const auto fraction = [](double image_x_m) {  // the fruit 1 m ahead, this far right of the optical axis
    Scenario s = test::one_fruit(Vec3(0.0, 1.0, -image_x_m));  // base -z is image right
    Scene scene(s);
    return SimCameras(s, scene).start_visible_fraction().at(0);
  };
  const geometry::CameraModel& k = test::one_fruit().fixed_camera.model;
  // Where the right image border lies at 1 m (distortion included).
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (k.project(Eigen::Vector3d(mid, 0.0, 1.0)).x() < k.width ? lo : hi) = mid;
  }
  EXPECT_GT(fraction(0.0), 0.95);
  EXPECT_NEAR(fraction(lo), 0.5, 0.1);    // the border through its centre
  EXPECT_LT(fraction(lo + 0.025), 0.15);  // 35 mm radius, its centre 25 mm outside
  EXPECT_EQ(fraction(lo + 0.05), 0.0f);   // wholly outside
}

}  // namespace
}  // namespace harvest::sim
