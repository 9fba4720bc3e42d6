// harvest-calibrate end to end over LCM logs written here from simulator
// renders: intrinsics from one log, hand-eye from another with the arm's
// ROBOT_STATE (moving between poses, resting at each), through the files the
// processes read. Replaying twice gives byte-identical output.
#include "calib/calibrate_cli.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <sstream>

#include "calib_scenes.hpp"
#include "camera/image_codec.hpp"
#include "geometry/pose_msg.hpp"
#include "geometry/transform_file.hpp"
#include "harvest/image_t.hpp"
#include "harvest/robot_state_t.hpp"

namespace harvest::calib {
namespace {

using test::CalibScenes;
constexpr int64_t kT0 = 1'780'000'000'000'000;  // 2026-05-28 20:26:40 UTC

class LogWriter {
 public:
  explicit LogWriter(const std::string& path) : log_(path, "w") {}
  template <class Msg>
  void write(const std::string& channel, int64_t t, const Msg& m) {
    std::vector<uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(buf.data(), 0, static_cast<int>(buf.size()));
    lcm::LogEvent ev;
    ev.eventnum = n_++;
    ev.timestamp = t;
    ev.channel = channel;
    ev.datalen = static_cast<int32_t>(buf.size());
    ev.data = buf.data();
    log_.writeEvent(&ev);
  }
  void frame(const std::string& channel, int64_t t, const cv::Mat& gray) {
    image_t img{};
    img.header.utime = t;
    cv::Mat bgr;
    cv::cvtColor(gray, bgr, cv::COLOR_GRAY2BGR);
    camera::encode_image(bgr, false, 0, img);
    img.sensor_width = gray.cols;
    img.sensor_height = gray.rows;
    write(channel, t, img);
  }
  void state(int64_t t, const Eigen::Isometry3d& tool, bool moving) {
    robot_state_t s{};
    s.header.utime = t;
    s.mode = moving ? robot_state_t::MODE_MOVING : robot_state_t::MODE_IDLE;
    s.num_joints = 0;
    s.tool_pose = geometry::to_pose(tool);
    s.camera_pose = s.tool_pose;
    s.tool_twist.linear[0] = moving ? 0.1 : 0.0;
    write("ROBOT_STATE", t, s);
  }

 private:
  lcm::LogFile log_;
  int64_t n_ = 0;
};

std::string read(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

int run(std::vector<std::string> args, std::string* err_text = nullptr) {
  args.insert(args.begin(), "harvest-calibrate");
  std::vector<const char*> argv;
  for (const auto& a : args) argv.push_back(a.c_str());
  std::ostringstream out, err;
  const int rc = calibrate_main(static_cast<int>(argv.size()), argv.data(), out, err);
  std::printf("%s", err.str().c_str());
  if (err_text) *err_text = err.str();
  return rc;
}

class CalibrateCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(::testing::TempDir() + "calibrate_cli_" + std::to_string(::getpid()));
    std::filesystem::create_directories(*dir_);
    const CalibScenes s;
    {
      LogWriter w(*dir_ + "/intrinsics.lcm");
      int64_t t = kT0;
      for (const cv::Mat& f : s.intrinsics_frames(s.scenario().hand_camera)) {
        w.frame("CAMERA_HAND", t, f);
        t += 500'000;
      }
    }
    LogWriter w(*dir_ + "/hand_eye.lcm");
    int64_t t = kT0;
    cv::Mat frame;
    uint64_t seed = 500;
    Eigen::Isometry3d at = s.hand_eye_tool_poses().front();
    for (const auto& tool : s.hand_eye_tool_poses()) {
      // 0.2 s moving (the last frame still showing), then 0.5 s at rest at the new pose.
      for (int k = 0; k < 70; ++k, t += 10'000) {
        const bool moving = k < 20;
        if (!moving) at = tool;
        if (k == 20)
          frame = s.render(s.scenario().hand_camera, test::placement(tool * test::iso(s.scenario().arm.hand_eye)),
                           s.board().pose, seed++);
        w.state(t, at, moving);
        if (k % 10 == 5 && !frame.empty()) w.frame("CAMERA_HAND", t, frame);
      }
    }
  }
  static void TearDownTestSuite() {
    std::filesystem::remove_all(*dir_);
    delete dir_;
  }
  static std::string* dir_;
};
std::string* CalibrateCli::dir_ = nullptr;

TEST_F(CalibrateCli, IntrinsicsThenHandEyeFromLogsReplayToTheSameBytes) {
  const std::string d = *dir_;
  ASSERT_EQ(
      run({"intrinsics", "hand", "--log", d + "/intrinsics.lcm", "-o", d + "/hand.yaml", "--report", d + "/hand.png"}),
      0);
  const geometry::CameraModel cam = geometry::CameraModel::load(d + "/hand.yaml");
  const CalibScenes s;
  EXPECT_LT(std::abs(cam.fx / s.scenario().hand_camera.model.fx - 1), 0.005);
  EXPECT_NE(
      read(d + "/hand.yaml").find("# harvest-calibrate intrinsics hand, 2026-05-28 20:27:02 UTC, CAMERA_HAND from "),
      std::string::npos);

  std::string err;
  ASSERT_EQ(run({"hand-eye", "--log", d + "/hand_eye.lcm", "--intrinsics", d + "/hand.yaml", "-o", d + "/he1.yaml",
                 "--report", d + "/he1.png"},
                &err),
            0);
  // Every pose once; frames in motion or before the arm settled refused.
  EXPECT_NE(err.find("12 accepted"), std::string::npos) << err;
  EXPECT_NE(err.find("arm moving"), std::string::npos) << err;
  ASSERT_EQ(run({"hand-eye", "--log", d + "/hand_eye.lcm", "--intrinsics", d + "/hand.yaml", "-o", d + "/he2.yaml",
                 "--report", d + "/he2.png"}),
            0);
  const std::string yaml = read(d + "/he1.yaml");
  EXPECT_EQ(yaml, read(d + "/he2.yaml"));
  EXPECT_EQ(read(d + "/he1.png"), read(d + "/he2.png"));
  EXPECT_GT(read(d + "/he1.png").size(), 1000u);
  const Eigen::Isometry3d he = geometry::load_transform_file(d + "/he1.yaml", geometry::Handedness::kProper);
  const Eigen::Isometry3d truth = test::iso(s.scenario().arm.hand_eye);
  const double dp = (he.translation() - truth.translation()).norm();
  const double dr = Eigen::AngleAxisd(he.linear().transpose() * truth.linear()).angle();
  std::printf("hand-eye through the logs: %.3f mm, %.4f deg off the truth\n", dp * 1000, dr * 180 / M_PI);
  EXPECT_LT(dp, 0.002);
  EXPECT_LT(dr, 0.2 * M_PI / 180);
  EXPECT_NE(yaml.find("# spread of the methods"), std::string::npos);
}

TEST_F(CalibrateCli, ALogWithoutTheBoardIsAClearError) {
  std::string err;
  EXPECT_EQ(run({"extrinsics", "--log", *dir_ + "/hand_eye.lcm", "--intrinsics", "config/cameras/fixed.yaml", "-o",
                 *dir_ + "/x.yaml"},
                &err),
            1);
  EXPECT_NE(err.find("the board was not found in any frame"), std::string::npos) << err;
  EXPECT_FALSE(std::filesystem::exists(*dir_ + "/x.yaml"));
  EXPECT_EQ(run({"intrinsics", "left", "--log", "x.lcm"}), 2);
  EXPECT_EQ(run({"intrinsics", "hand"}), 2);  // neither a log nor LCM
}

}  // namespace
}  // namespace harvest::calib
