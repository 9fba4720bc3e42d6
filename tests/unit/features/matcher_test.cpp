// Desired (zoomed) image <-> camera-in-hand image: ORB, ratio test, our
// RANSAC homography, Lucas-Kanade refinement; explicit status when it fails.
#include "features/matcher.hpp"

#include <gtest/gtest.h>

#include "synthetic.hpp"

namespace f = harvest::features;
namespace ft = harvest::features::testing;

namespace {

// Texture (side x side) placed in a 320x240 image by a similarity and a
// little perspective.
cv::Matx33d placement(double scale, double angle, double tx, double ty, double px = 0, double py = 0) {
  const double c = std::cos(angle) * scale, s = std::sin(angle) * scale;
  return cv::Matx33d(c, -s, tx, s, c, ty, px, py, 1);
}

double transfer_rms(const cv::Matx33d& G, const cv::Matx33d& truth, cv::Size size) {
  double sum = 0;
  int n = 0;
  for (int y = 20; y < size.height; y += 40)
    for (int x = 20; x < size.width; x += 40) {
      const cv::Vec3d a = G * cv::Vec3d(x, y, 1), b = truth * cv::Vec3d(x, y, 1);
      sum += std::pow(a[0] / a[2] - b[0] / b[2], 2) + std::pow(a[1] / a[2] - b[1] / b[2], 2);
      ++n;
    }
  return std::sqrt(sum / n);
}

}  // namespace

TEST(Matcher, RecoversTheHomographyBetweenDesiredAndCurrent) {
  const cv::Mat1b tex = ft::sticker_texture(400, 3);
  const cv::Size size(320, 240);
  const cv::Matx33d Hd = placement(0.55, 0.0, 50, 10);
  const cv::Mat1b desired = ft::render_plane(tex, Hd, size, 90, 1.5, 1);
  f::DesiredImageMatcher m({});
  EXPECT_FALSE(m.has_desired());
  EXPECT_EQ(m.match(desired).status, f::MatchStatus::kNoDesired);
  m.set_desired(desired);
  ASSERT_TRUE(m.has_desired());

  struct Case {
    cv::Matx33d Hc;
    const char* what;
  };
  const std::vector<Case> cases{{placement(0.55, 0.0, 53.3, 7.6), "shift"},
                                {placement(0.5, 0.25, 80, 0), "rotation + scale"},
                                {placement(0.62, -0.15, 40, 20, 2e-4, -1e-4), "perspective"}};
  for (const auto& c : cases) {
    const cv::Mat1b current = ft::render_plane(tex, c.Hc, size, 90, 1.5, 2);
    const cv::Matx33d truth = c.Hc * Hd.inv();  // desired px -> current px
    for (bool refine : {false, true}) {
      f::MatcherParams p;
      p.refine = refine;
      f::DesiredImageMatcher mm(p);
      mm.set_desired(desired);
      const auto r = mm.match(current);
      ASSERT_TRUE(r.ok()) << c.what << ": " << r.text;
      ASSERT_GE(r.num_inliers, 20) << c.what;
      ASSERT_EQ(r.desired.size(), r.current.size());
      double worst = 0;
      for (int i = 0; i < r.num_inliers; ++i) {
        const cv::Vec3d q = truth * cv::Vec3d(r.desired[i].x, r.desired[i].y, 1);
        worst = std::max(worst, std::hypot(q[0] / q[2] - r.current[i].x, q[1] / q[2] - r.current[i].y));
      }
      const double rms = transfer_rms(r.G, truth, size);
      std::printf(
          "%-16s refine %d: %d inliers of %d candidates, homography transfer rms %.3f px, worst inlier %.2f px\n",
          c.what, refine, r.num_inliers, r.num_candidates, rms, worst);
      EXPECT_LT(rms, refine ? 0.3 : 1.5) << c.what;
      EXPECT_LT(worst, refine ? 1.0 : 4.0) << c.what;
    }
  }
}

TEST(Matcher, UntexturedFruitGivesTooFew) {
  // The thesis's finding: a smooth orange has no four matching features.
  const cv::Size size(320, 240);
  auto fruit = [&](cv::Point c, int r) {
    cv::Mat1b img(size, uint8_t(60));
    for (int k = r; k > 0; --k)  // smooth shading, no corners
      cv::circle(img, c, k, cv::Scalar(200 - 80.0 * k / r), cv::FILLED, cv::LINE_AA);
    return img;
  };
  f::DesiredImageMatcher m({});
  m.set_desired(fruit({160, 120}, 80));
  const auto r = m.match(fruit({150, 125}, 70));
  EXPECT_EQ(r.status, f::MatchStatus::kTooFew) << r.text;
  EXPECT_EQ(r.num_inliers, 0);
  EXPECT_FALSE(r.text.empty());
  std::printf("untextured fruit: %s\n", r.text.c_str());
}

// Natural fruit among leaves (what made teach by zooming step on spurious
// matches end to end, docs/teach-by-zooming.md): a smoothly shaded disc over
// leaf texture. Its outline and the leaves beside it match and verify (here
// they are even on one plane); only matches on the fruit's face count, and a
// natural face has none. With a sticker on the face, the sticker verifies.
TEST(Matcher, OnlyMatchesOnTheFruitsFaceVerify) {
  const cv::Point2f centre(200, 200);  // texture px
  const float radius = 90;
  auto scene = [&](bool sticker) {
    cv::Mat1b tex = ft::sticker_texture(400, 11);  // leaves
    for (int k = static_cast<int>(radius); k > 0; --k)
      cv::circle(tex, centre, k, cv::Scalar(200 - 80.0 * k / radius), cv::FILLED, cv::LINE_AA);
    if (sticker) ft::sticker_texture(100, 12).copyTo(tex(cv::Rect(150, 150, 100, 100)));
    return tex;
  };
  const cv::Size size(320, 240);
  const cv::Matx33d Hd = placement(0.6, 0.0, 40, 0), Hc = placement(0.5, 0.1, 70, 15, 1e-4, -5e-5);
  auto map = [](const cv::Matx33d& H, cv::Point2f p) {
    const cv::Vec3d q = H * cv::Vec3d(p.x, p.y, 1);
    return cv::Point2f(static_cast<float>(q[0] / q[2]), static_cast<float>(q[1] / q[2]));
  };
  // The face as the feature tracker draws it from a detection: 0.7 of the radius.
  const f::Disc face{map(Hc, centre), 0.7f * radius * 0.5f};
  for (bool sticker : {false, true}) {
    const cv::Mat1b tex = scene(sticker);
    const cv::Mat1b desired = ft::render_plane(tex, Hd, size, 90, 1.5, 1);
    const cv::Mat1b current = ft::render_plane(tex, Hc, size, 90, 1.5, 2);
    f::DesiredImageMatcher anywhere({}), on_face({});
    anywhere.set_desired(desired);
    on_face.set_desired(desired);
    const auto a = anywhere.match(current);
    const auto r = on_face.match(current, {}, face);
    std::printf("%s: anywhere %s (%s); on the face %s (%s)\n", sticker ? "sticker" : "natural", f::to_string(a.status),
                a.text.c_str(), f::to_string(r.status), r.text.c_str());
    EXPECT_TRUE(a.ok()) << "the leaves verify when matches may be anywhere: " << a.text;
    EXPECT_EQ(r.desired.size(), r.current.size());
    if (!sticker) {
      EXPECT_EQ(r.status, f::MatchStatus::kTooFew) << r.text;
      EXPECT_EQ(r.num_inliers, 0);
      EXPECT_GT(r.num_off_face, 8);
      EXPECT_NE(r.text.find("fruit's face"), std::string::npos) << r.text;
      continue;
    }
    ASSERT_TRUE(r.ok()) << r.text;
    EXPECT_GE(r.num_inliers, 20);
    EXPECT_GT(r.num_off_face, 0);  // the leaves still match, and are left out
    const cv::Matx33d truth = Hc * Hd.inv();
    for (int i = 0; i < r.num_inliers; ++i) {
      const auto k = static_cast<std::size_t>(i);
      EXPECT_TRUE(face.contains(r.current[k]));
      EXPECT_LT(cv::norm(map(truth, r.desired[k]) - r.current[k]), 1.0);
    }
  }
}

TEST(Matcher, UnrelatedImagesAreNotMatched) {
  const cv::Size size(320, 240);
  f::DesiredImageMatcher m({});
  m.set_desired(ft::render_plane(ft::sticker_texture(400, 5), placement(0.6, 0, 30, 0), size));
  const auto r = m.match(ft::render_plane(ft::sticker_texture(400, 6), placement(0.6, 0, 30, 0), size));
  std::printf("unrelated: %s\n", r.text.c_str());
  EXPECT_EQ(r.status, f::MatchStatus::kTooFew) << r.text;
  // With min_inliers 4, chance matches would pass: four pairs always fit a homography.
  f::MatcherParams four;
  four.min_inliers = 4;
  f::DesiredImageMatcher m4(four);
  m4.set_desired(ft::render_plane(ft::sticker_texture(400, 5), placement(0.6, 0, 30, 0), size));
  const auto r4 = m4.match(ft::render_plane(ft::sticker_texture(400, 6), placement(0.6, 0, 30, 0), size));
  std::printf("unrelated, min_inliers 4: %s (%s)\n", f::to_string(r4.status), r4.text.c_str());
}

TEST(Matcher, DeterministicForTheSameInput) {
  const cv::Mat1b tex = ft::sticker_texture(400, 8);
  const cv::Size size(320, 240);
  const cv::Mat1b desired = ft::render_plane(tex, placement(0.55, 0, 50, 10), size);
  const cv::Mat1b cur = ft::render_plane(tex, placement(0.5, 0.2, 70, 5), size, 90, 2.0, 3);
  const cv::Mat1b next = ft::render_plane(tex, placement(0.51, 0.19, 72, 5), size, 90, 2.0, 4);
  // Two matchers fed the same sequence answer the same, frame by frame.
  f::DesiredImageMatcher m({}), n({});
  m.set_desired(desired);
  n.set_desired(desired);
  for (const cv::Mat1b* img : {&cur, &next, &next}) {
    const auto a = m.match(*img), b = n.match(*img);
    ASSERT_TRUE(a.ok());
    EXPECT_EQ(a.tracked, b.tracked);
    EXPECT_EQ(a.num_inliers, b.num_inliers);
    EXPECT_EQ(a.current, b.current);
    EXPECT_EQ(cv::norm(cv::Mat(a.G), cv::Mat(b.G)), 0.0);
  }
  // Without frame-to-frame tracking every frame is detected: the same frame twice, the same answer.
  f::MatcherParams p;
  p.track = false;
  f::DesiredImageMatcher d(p);
  d.set_desired(desired);
  const auto a = d.match(cur), b = d.match(cur);
  ASSERT_TRUE(a.ok());
  EXPECT_FALSE(b.tracked);
  EXPECT_EQ(a.current, b.current);
  EXPECT_EQ(cv::norm(cv::Mat(a.G), cv::Mat(b.G)), 0.0);
}

TEST(Matcher, FollowsAnApproachFrameToFrameAndFallsBackToDetection) {
  // The camera-in-hand closes on the sticker over 30 frames: the first is
  // detected, the others followed from the previous homography (step 4), as
  // accurate as the refined detection.
  const cv::Mat1b tex = ft::sticker_texture(400, 9);
  const cv::Size size(320, 240);
  const cv::Matx33d Hd = placement(0.55, 0.0, 50, 10);
  f::DesiredImageMatcher m({});
  m.set_desired(ft::render_plane(tex, Hd, size, 90, 1.0, 1));
  ASSERT_GT(m.desired_corners(), 100);
  double worst = 0;
  int tracked = 0;
  for (int k = 0; k < 30; ++k) {
    const double t = k / 29.0;
    const cv::Matx33d Hc = placement(0.45 + 0.12 * t, 0.25 * (1 - t), 70 - 15 * t, 5 + 6 * t, 2e-4 * (1 - t));
    const auto r = m.match(ft::render_plane(tex, Hc, size, 90, 1.0, static_cast<uint64_t>(k + 2)));
    ASSERT_TRUE(r.ok()) << k << ": " << r.text;
    EXPECT_EQ(r.tracked, k > 0) << k;
    tracked += r.tracked;
    worst = std::max(worst, transfer_rms(r.G, Hc * Hd.inv(), size));
  }
  std::printf("approach: %d of 30 frames followed, worst homography transfer rms %.3f px\n", tracked, worst);
  EXPECT_LT(worst, 0.1);
  // A jump beyond what tracking follows: the same frame is detected afresh.
  const cv::Matx33d far = placement(0.5, -0.3, 90, 0);
  const auto jump = m.match(ft::render_plane(tex, far, size, 90, 1.0, 40));
  ASSERT_TRUE(jump.ok()) << jump.text;
  EXPECT_FALSE(jump.tracked);
  EXPECT_LT(transfer_rms(jump.G, far * Hd.inv(), size), 0.1);
  // Another texture: neither followed nor detected.
  const auto other = m.match(ft::render_plane(ft::sticker_texture(400, 10), far, size, 90, 1.0, 41));
  EXPECT_EQ(other.status, f::MatchStatus::kTooFew) << other.text;
  EXPECT_FALSE(other.ok());
}
