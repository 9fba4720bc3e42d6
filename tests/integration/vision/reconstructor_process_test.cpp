// harvest-reconstructor as a real process over real LCM with the shipped
// configuration: fixed-camera detections become base-frame targets through
// the extrinsic calibration; camera-in-hand detections through the robot
// state at the image time, and the fruit chosen in the fixed camera keeps its
// id in the hand view while another fruit there gets a new one (thesis
// experiment II).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <harvest/fruit_detections_t.hpp>
#include <harvest/process_status_t.hpp>
#include <harvest/robot_state_t.hpp>
#include <harvest/targets_t.hpp>

#include "bus.hpp"
#include "geometry/camera_model.hpp"
#include "runtime/clock.hpp"
#include "test_support.hpp"
#include "vision/reconstructor.hpp"

namespace ht = harvest::testing;
using namespace std::chrono_literals;

namespace harvest::vision {
namespace {

constexpr double kDiameter = 0.0725;  // config/vision/reconstructor.yaml fruit.diameter_mean_m

fruit_t seen(const geometry::CameraModel& cam, const Eigen::Vector3d& p_cam) {
  fruit_t f{};
  const Eigen::Vector2d px = cam.project(p_cam);
  f.id = -1;
  f.u_px = static_cast<float>(px.x());
  f.v_px = static_cast<float>(px.y());
  // Apparent diameter through the lens: the distorted image of the fruit's
  // horizontal and vertical extent, as a detector measures it.
  const Eigen::Vector3d ex(0.5 * kDiameter, 0, 0), ey(0, 0.5 * kDiameter, 0);
  const double dx = cam.project(p_cam + ex).x() - cam.project(p_cam - ex).x();
  const double dy = cam.project(p_cam + ey).y() - cam.project(p_cam - ey).y();
  f.diameter_px = static_cast<float>(0.5 * (dx + dy));
  f.confidence = 1;
  return f;
}

fruit_detections_t detections(const std::string& camera, int64_t utime, int64_t seq, std::vector<fruit_t> fruits,
                              int selected) {
  fruit_detections_t d{};
  d.header.utime = utime;
  d.header.seq = seq;
  d.header.source_seq = seq;
  d.camera = camera;
  d.image_width = 640;
  d.image_height = 480;
  d.status = fruit_detections_t::STATUS_OK;
  d.fruits = std::move(fruits);
  d.num_fruits = static_cast<int32_t>(d.fruits.size());
  d.selected_index = selected;
  return d;
}

robot_state_t state_at(int64_t utime, const Eigen::Isometry3d& tool) {
  robot_state_t s{};
  s.header.utime = utime;
  s.mode = robot_state_t::MODE_IDLE;
  const Eigen::Quaterniond q(tool.linear());
  for (int i = 0; i < 3; ++i) s.tool_pose.position[i] = tool.translation()[i];
  s.tool_pose.orientation[0] = q.w();
  s.tool_pose.orientation[1] = q.x();
  s.tool_pose.orientation[2] = q.y();
  s.tool_pose.orientation[3] = q.z();
  s.camera_pose = s.tool_pose;
  return s;
}

const target_t* near_pixel(const targets_t& t, const fruit_t& f) {
  for (const target_t& x : t.targets)
    if (std::abs(x.u_px - f.u_px) < 0.01 && std::abs(x.v_px - f.v_px) < 0.01) return &x;
  return nullptr;
}

TEST(ReconstructorProcess, BothCamerasEndToEndKeepTheChosenFruit) {
  const geometry::CameraModel fixed_cam = geometry::CameraModel::load(ht::source_path("config/cameras/fixed.yaml"));
  const geometry::CameraModel hand_cam = geometry::CameraModel::load(ht::source_path("config/cameras/hand.yaml"));
  // The shipped extrinsic (eq. 4-1): p_base = R p_cam + T.
  Eigen::Matrix3d r_fixed;
  r_fixed << 0, 1, 0, 0, 0, 1, -1, 0, 0;
  const Eigen::Vector3d t_fixed(-0.254, 0.19685, -0.381);
  const Eigen::Vector3d a_cam(0.10, -0.03, 0.80);  // fruit A in the fixed camera
  const Eigen::Vector3d a_base = r_fixed * a_cam + t_fixed;
  const Eigen::Vector3d b_base = a_base + Eigen::Vector3d(0.10, 0.05, 0.08);  // fruit B, hidden from it
  // Camera-in-hand (hand-eye identity) half a metre from A, looking along base +y.
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.linear() << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  tool.translation() << -0.23, 0.50, -0.48;

  ht::TempDir dir;
  const std::string url = ht::unique_lcm_url();
  test::Bus bus(url);
  ht::ChildProcess process({ht::bin("harvest-reconstructor"), "--config",
                            ht::source_path("config/vision/reconstructor.yaml"), "--lcm-url", url, "--no-netcheck"},
                           dir / "reconstructor.txt");

  // Fixed camera: resend until the process answers (it may still be starting).
  const fruit_t a_fixed = seen(fixed_cam, a_cam);
  int64_t t = rt::wall_time_now(), seq = 1;
  ASSERT_TRUE(ht::eventually(
      [&] {
        bus.publish("FRUIT_FIXED", detections("fixed", t += 33'000, seq++, {a_fixed}, 0));
        std::this_thread::sleep_for(100ms);
        return bus.count("TARGETS") > 0;
      },
      10s))
      << process.output();
  const targets_t fixed = bus.on<targets_t>("TARGETS").front();
  EXPECT_EQ(fixed.source_camera, "fixed");
  ASSERT_EQ(fixed.num_targets, 1);
  const target_t& ta = fixed.targets[0];
  const int32_t a_id = ta.fruit_id;
  EXPECT_GE(a_id, 0);
  EXPECT_LT(a_id, kUnassociatedIdBase);
  EXPECT_TRUE(ta.selected);
  EXPECT_EQ(fixed.selected_fruit_id, a_id);
  EXPECT_LT((Eigen::Vector3d(ta.position_base) - a_base).norm(), 0.002);
  EXPECT_NEAR(ta.depth_m, a_cam.z(), 0.002);
  // Covariance: symmetric, positive, largest along the fixed camera's optical
  // axis (camera z is base +y), where the spread of fruit sizes acts.
  const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> cov(ta.covariance_base);
  EXPECT_LT((cov - cov.transpose()).norm(), 1e-12);
  EXPECT_GT(cov(1, 1), cov(0, 0));
  EXPECT_GT(cov(1, 1), cov(2, 2));
  EXPECT_GT(cov.determinant(), 0);

  // A bad fixed image: no targets, the error shows in the heartbeat.
  const std::size_t before = bus.count("TARGETS");
  fruit_detections_t bad = detections("fixed", t += 33'000, seq++, {}, -1);
  bad.status = fruit_detections_t::STATUS_BAD_IMAGE;
  bad.status_text = "corrupt JPEG (1234 bytes)";
  bus.publish("FRUIT_FIXED", bad);
  EXPECT_TRUE(ht::eventually(
      [&] {
        for (const auto& s : bus.on<process_status_t>("PROCESS_STATUS"))
          if (s.state >= process_status_t::STATE_DEGRADED && s.message.find("corrupt JPEG") != std::string::npos)
            return true;
        return false;
      },
      5s));
  EXPECT_EQ(bus.count("TARGETS"), before);

  // Camera-in-hand sees B and A; its own detector prefers B.
  const int64_t t_hand = t + 500'000;
  bus.publish("ROBOT_STATE", state_at(t_hand - 20'000, tool));
  bus.publish("ROBOT_STATE", state_at(t_hand + 20'000, tool));
  const fruit_t b_hand = seen(hand_cam, tool.inverse() * b_base), a_hand = seen(hand_cam, tool.inverse() * a_base);
  const auto hand = detections("hand", t_hand, 500, {b_hand, a_hand}, 0);
  std::optional<targets_t> from_hand;
  ASSERT_TRUE(ht::eventually(
      [&] {
        if (!from_hand) bus.publish("FRUIT_HAND", hand);  // at most a few times, until answered
        for (const auto& x : bus.on<targets_t>("TARGETS"))
          if (x.source_camera == "hand") from_hand = x;
        std::this_thread::sleep_for(50ms);
        return from_hand.has_value();
      },
      5s))
      << process.output();
  ASSERT_EQ(from_hand->num_targets, 2);
  EXPECT_EQ(from_hand->header.utime, t_hand);
  const target_t* a = near_pixel(*from_hand, a_hand);
  const target_t* b = near_pixel(*from_hand, b_hand);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->fruit_id, a_id);  // recognised by its predicted 3D position
  EXPECT_TRUE(a->selected);
  EXPECT_EQ(from_hand->selected_fruit_id, a_id);
  EXPECT_GE(b->fruit_id, kUnassociatedIdBase);  // new to the system
  EXPECT_FALSE(b->selected);
  EXPECT_LT((Eigen::Vector3d(a->position_base) - a_base).norm(), 0.002);
  EXPECT_LT((Eigen::Vector3d(b->position_base) - b_base).norm(), 0.002);

  // A hand image with no robot state near its time is refused, not guessed.
  const std::size_t n = bus.count("TARGETS");
  bus.publish("FRUIT_HAND", detections("hand", t_hand + 5'000'000, 501, {a_hand}, 0));
  EXPECT_TRUE(ht::eventually(
      [&] {
        for (const auto& s : bus.on<process_status_t>("PROCESS_STATUS"))
          if (s.message.find("no robot state") != std::string::npos) return true;
        return false;
      },
      5s));
  EXPECT_EQ(bus.count("TARGETS"), n);
  EXPECT_TRUE(process.running());
  EXPECT_EQ(process.stop(), 0) << process.output();
}

}  // namespace
}  // namespace harvest::vision
