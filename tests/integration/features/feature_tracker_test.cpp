// harvest-feature-tracker over real LCM: synthetic textured frames in,
// FEATURES_HAND and FEATURE_MATCHES out.
#include <gtest/gtest.h>

#include <atomic>
#include <harvest/feature_matches_t.hpp>
#include <harvest/feature_tracks_t.hpp>
#include <harvest/fruit_detections_t.hpp>
#include <harvest/image_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "camera/image_codec.hpp"
#include "runtime/log_io.hpp"
#include "synthetic.hpp"
#include "test_support.hpp"

using namespace harvest;
namespace ht = harvest::testing;
namespace ft = harvest::features::testing;
using namespace std::chrono_literals;

namespace {

class Bus {
 public:
  explicit Bus(const std::string& url) : lcm_(url), pub_(url) {
    lcm_.subscribeFunction("FEATURE.*", &Bus::on_message, this);
    thread_ = std::thread([this] {
      while (!stop_) lcm_.handleTimeout(20);
    });
  }
  ~Bus() {
    stop_ = true;
    thread_.join();
  }
  template <class T>
  std::vector<T> on(const std::string& channel) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<T> out;
    for (const auto& [c, bytes] : records_)
      if (c == channel) out.push_back(*rt::decode<T>(bytes));
    return out;
  }
  template <class T>
  void publish(const std::string& channel, T& msg) {
    pub_.publish(channel, &msg);
  }
  std::size_t count(const std::string& channel) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::size_t n = 0;
    for (const auto& r : records_) n += r.first == channel;
    return n;
  }

 private:
  static void on_message(const lcm::ReceiveBuffer* rb, const std::string& channel, Bus* self) {
    const auto* p = static_cast<const uint8_t*>(rb->data);
    std::lock_guard<std::mutex> lock(self->mutex_);
    self->records_.emplace_back(channel, std::vector<uint8_t>(p, p + rb->data_size));
  }
  lcm::LCM lcm_;
  lcm::LCM pub_;
  std::mutex mutex_;
  std::vector<std::pair<std::string, std::vector<uint8_t>>> records_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

image_t make_image(const cv::Mat1b& gray, int64_t seq) {
  cv::Mat3b bgr;
  cv::cvtColor(gray, bgr, cv::COLOR_GRAY2BGR);
  image_t m{};
  m.header.utime = 1'000'000 + seq * 33'333;
  m.header.seq = seq;
  m.header.frame_id = "camera_hand";
  m.header.source_seq = -1;
  m.sensor_width = gray.cols;
  m.sensor_height = gray.rows;
  camera::encode_image(bgr, false, 90, m);
  return m;
}

}  // namespace

class FeatureTrackerProcess : public ::testing::Test {
 protected:
  ht::TempDir dir;
  std::string url = ht::unique_lcm_url();
  Bus bus{url};
  const cv::Mat1b texture = ft::sticker_texture(480, 12);
  const cv::Size size{320, 240};

  std::unique_ptr<ht::ChildProcess> start(const std::vector<std::string>& extra = {}) {
    std::vector<std::string> args{ht::bin("harvest-feature-tracker"),
                                  "--config",
                                  ht::source_path("config/features/feature_tracker.yaml"),
                                  "--lcm-url",
                                  url,
                                  "--no-netcheck"};
    args.insert(args.end(), extra.begin(), extra.end());
    return std::make_unique<ht::ChildProcess>(args, dir / "tracker.txt");
  }
  // Publish `img` as hand frame `seq` and wait for the answer. While the
  // process starts (`repeat`), republish until it answers.
  bool send_hand(const cv::Mat1b& img, int64_t seq, bool repeat = false) {
    auto msg = make_image(img, seq);
    const auto deadline = std::chrono::steady_clock::now() + (repeat ? 10s : 8s);
    bool sent = false;
    while (std::chrono::steady_clock::now() < deadline) {
      if (repeat || !sent) bus.publish("CAMERA_HAND", msg);
      sent = true;
      if (ht::eventually(
              [&] {
                bool tracks = false, matches = false;
                for (const auto& t : bus.on<feature_tracks_t>("FEATURES_HAND")) tracks |= t.header.source_seq == seq;
                for (const auto& m : bus.on<feature_matches_t>("FEATURE_MATCHES"))
                  matches |= m.header.source_seq == seq;
                return tracks && matches;
              },
              300ms))
        return true;
    }
    return false;
  }
  template <class T>
  T answer(const std::string& channel, int64_t seq) {
    for (const auto& t : bus.on<T>(channel))
      if (t.header.source_seq == seq) return t;
    ADD_FAILURE() << "no " << channel << " for frame " << seq;
    return T{};
  }
};

TEST_F(FeatureTrackerProcess, TracksFeaturesAndMatchesTheZoomedImage) {
  auto proc = start();
  // Desired (zoomed) view: the sticker larger and rotated; current views:
  // smaller, moving by (0.6, -0.3) px per frame.
  const cv::Matx33d Hd(0.60, -0.12, 40, 0.12, 0.60, -20, 0, 0, 1);
  auto Hc = [](int k) { return cv::Matx33d(0.45, 0, 50 + 0.6 * k, 0, 0.45, 10 - 0.3 * k, 0, 0, 1); };
  ASSERT_TRUE(send_hand(ft::render_plane(texture, Hc(0), size, 90, 1.0, 0), 0, true)) << proc->output();
  // Before any desired image: an explicit status.
  const auto none = answer<feature_matches_t>("FEATURE_MATCHES", 0);
  EXPECT_EQ(none.status, +feature_matches_t::STATUS_NO_DESIRED);
  auto desired = make_image(ft::render_plane(texture, Hd, size, 90, 1.0, 100), 0);
  desired.header.frame_id = "camera_fixed";
  bus.publish("CAMERA_FIXED_ZOOM", desired);
  std::this_thread::sleep_for(300ms);

  std::map<int, cv::Point2f> start_pos;
  std::map<int, int> start_age;
  for (int k = 1; k <= 12; ++k) {
    ASSERT_TRUE(send_hand(ft::render_plane(texture, Hc(k), size, 90, 1.0, static_cast<uint64_t>(k)), k))
        << proc->output();
    const auto tracks = answer<feature_tracks_t>("FEATURES_HAND", k);
    EXPECT_EQ(tracks.header.utime, 1'000'000 + k * 33'333);
    EXPECT_EQ(tracks.num_features, static_cast<int>(tracks.features.size()));
    if (k == 1) {
      EXPECT_GE(tracks.num_features, 30);
      for (const auto& f : tracks.features) {
        start_pos[f.id] = cv::Point2f(f.u_px, f.v_px);
        start_age[f.id] = f.age;
      }
    }
    const auto m = answer<feature_matches_t>("FEATURE_MATCHES", k);
    ASSERT_EQ(m.status, +feature_matches_t::STATUS_OK) << m.status_text;
    ASSERT_GE(m.num_inliers, 20) << m.status_text;
    const cv::Matx33d truth = Hc(k) * Hd.inv();
    double worst = 0;
    for (int i = 0; i < m.num_inliers; ++i) {
      const cv::Vec3d q = truth * cv::Vec3d(m.desired_u_px[i], m.desired_v_px[i], 1);
      worst = std::max(worst, std::hypot(q[0] / q[2] - m.current_u_px[i], q[1] / q[2] - m.current_v_px[i]));
    }
    EXPECT_LT(worst, 1.0) << "frame " << k << ": " << m.status_text;
    if (k == 12) std::printf("frame 12: %s, worst inlier error %.3f px\n", m.status_text.c_str(), worst);
  }
  // Features kept their ids and moved with the image: 11 frames x (0.6, -0.3).
  const auto last = answer<feature_tracks_t>("FEATURES_HAND", 12);
  int followed = 0;
  double worst = 0, sum = 0;
  for (const auto& f : last.features) {
    if (!start_pos.count(f.id)) continue;
    ++followed;
    EXPECT_EQ(f.age, start_age[f.id] + 11);
    const double e = cv::norm(cv::Point2f(f.u_px, f.v_px) - start_pos[f.id] - cv::Point2f(6.6f, -3.3f));
    worst = std::max(worst, e);
    sum += e;
  }
  // The frames are resampled (scale 0.45, bilinear) with pixel noise, so a
  // shifted frame is not an exact shift of the texture: some drift.
  std::printf("%d features followed over 11 frames, mean drift %.3f px, worst %.3f px\n", followed, sum / followed,
              worst);
  EXPECT_GE(followed, 20);
  EXPECT_LT(sum / followed, 0.3);
  EXPECT_LT(worst, 1.0);
  EXPECT_EQ(proc->stop(5s), 0) << proc->output();
}

TEST_F(FeatureTrackerProcess, FruitRegionAndUntexturedFruit) {
  auto proc = start({"--set", "region=fruit", "--set", "fruit_max_age_s=60"});
  const cv::Mat1b textured = ft::render_plane(texture, cv::Matx33d(0.5, 0, 40, 0, 0.5, 0, 0, 0, 1), size);
  // No fruit yet: no region, no features.
  ASSERT_TRUE(send_hand(textured, 0, true)) << proc->output();
  EXPECT_EQ(answer<feature_tracks_t>("FEATURES_HAND", 0).num_features, 0);

  fruit_detections_t fruit{};
  fruit.camera = "hand";
  fruit.image_width = size.width;
  fruit.image_height = size.height;
  fruit.status = fruit_detections_t::STATUS_OK;
  fruit.selected_index = 0;
  fruit.num_fruits = 1;
  fruit.fruits.resize(1);
  fruit.fruits[0].selected = true;
  const int box[4] = {120, 80, 100, 80};
  for (int i = 0; i < 4; ++i) fruit.fruits[0].bbox_px[i] = box[i];
  bus.publish("FRUIT_HAND", fruit);
  std::this_thread::sleep_for(200ms);
  ASSERT_TRUE(send_hand(textured, 1)) << proc->output();
  const auto tracks = answer<feature_tracks_t>("FEATURES_HAND", 1);
  EXPECT_GT(tracks.num_features, 5);
  for (const auto& f : tracks.features) {  // box grown by 20 % on each side
    EXPECT_GE(f.u_px, 100.f);
    EXPECT_LE(f.u_px, 240.f);
    EXPECT_GE(f.v_px, 64.f);
    EXPECT_LE(f.v_px, 176.f);
  }
  // A smooth, untextured orange as both desired and current: too few matches.
  cv::Mat1b orange(size, uint8_t(60));
  for (int r = 60; r > 0; --r)
    cv::circle(orange, {170, 120}, r, cv::Scalar(200 - 80.0 * r / 60), cv::FILLED, cv::LINE_AA);
  auto desired = make_image(orange, 0);
  bus.publish("CAMERA_FIXED_ZOOM", desired);
  std::this_thread::sleep_for(300ms);
  ASSERT_TRUE(send_hand(orange, 2)) << proc->output();
  const auto m = answer<feature_matches_t>("FEATURE_MATCHES", 2);
  EXPECT_EQ(m.status, +feature_matches_t::STATUS_TOO_FEW) << m.status_text;
  EXPECT_EQ(m.num_inliers, 0);
  std::printf("untextured fruit over LCM: %s\n", m.status_text.c_str());
  EXPECT_EQ(proc->stop(5s), 0) << proc->output();
}
