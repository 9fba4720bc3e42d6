#include "sim/board.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

#include "camera/image_codec.hpp"
#include "sim/cameras.hpp"
#include "sim/cartesian_arm.hpp"
#include "sim/scene.hpp"
#include "test_scenes.hpp"

namespace harvest::sim {
namespace {

struct Found {
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
};

// What a calibration tool does: markers, ChArUco corners, tight sub-pixel refinement.
Found detect(const cv::Mat& bgr, const cv::Ptr<cv::aruco::CharucoBoard>& board) {
  cv::Mat gray;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  cv::aruco::detectMarkers(gray, board->dictionary, marker_corners, marker_ids);
  Found f;
  if (marker_ids.empty()) return f;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, board, f.corners, f.ids);
  if (!f.corners.empty())
    cv::cornerSubPix(gray, f.corners, cv::Size(3, 3), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  return f;
}

// Board facing the camera `depth` ahead, centred, then tilted about the camera's x and y axes.
Placement board_in_camera(const BoardSpec& b, double depth, double tilt_x_deg, double tilt_y_deg) {
  const double w = b.squares_x * b.square_m, h = b.squares_y * b.square_m;
  const Mat3 facing = Mat3::Identity();  // board x, y along the image's, z into the board, away from the camera
  const Mat3 tilt = (Eigen::AngleAxisd(tilt_x_deg * M_PI / 180, Vec3::UnitX()) *
                     Eigen::AngleAxisd(tilt_y_deg * M_PI / 180, Vec3::UnitY()))
                        .toRotationMatrix();
  const Vec3 centre(0.0, 0.0, depth);
  // The board's centre (w/2, h/2) sits at `centre`.
  const Mat3 r = tilt * facing;
  return {r, centre - r * Vec3(w / 2, h / 2, 0.0)};
}

double worst_corner_error(const Scenario& sc, const BoardSpec& spec, const Placement& in_camera, std::size_t* found) {
  const Placement pose = compose(sc.fixed_camera_truth, in_camera);
  auto prim = std::make_shared<BoardPrimitive>(spec, pose);
  Scenario empty = sc;
  empty.fruit.clear();
  const Scene scene(empty);
  Renderer r(sc.fixed_camera.model, 0.0, 1);
  r.add_primitive(prim);
  const cv::Mat img = r.render(scene, sc.fixed_camera_truth).clone();
  const Found f = detect(img, prim->board());
  *found = f.ids.size();
  double worst = 0.0;
  for (std::size_t k = 0; k < f.ids.size(); ++k) {
    const cv::Point3f& c = prim->board()->chessboardCorners[static_cast<std::size_t>(f.ids[k])];
    const Vec3 p_cam = in_camera.rotation * Vec3(c.x, c.y, c.z) + in_camera.position;
    const Eigen::Vector2d px = sc.fixed_camera.model.project(p_cam);
    worst = std::max(worst, (px - Eigen::Vector2d(f.corners[k].x, f.corners[k].y)).norm());
  }
  return worst;
}

// The renderer's geometry, free of any detector: facing the camera without
// distortion, a black square is an axis-aligned rectangle in the image, and a
// strip of rows (or columns) across it integrates to its exact edges (pixels
// are area-sampled). Every square's four edges must be where the camera model
// projects them.
TEST(Board, SquareEdgesAreWhereTheCameraModelProjectsThem) {
  Scenario sc = test::one_fruit();
  sc.fixed_camera.model.dist = {};
  sc.fruit.clear();
  const BoardSpec spec;
  cv::Mat printed;
  make_board(spec)->draw(cv::Size(spec.squares_x * 100, spec.squares_y * 100), printed, 0, 1);
  const auto& model = sc.fixed_camera.model;
  // Off-centre and at depths where the edges fall on arbitrary sub-pixel positions.
  for (const Vec3& offset : {Vec3(0.0, 0.0, 0.45), Vec3(0.0123, -0.0071, 0.52), Vec3(-0.031, 0.017, 0.61)}) {
    const Placement in_camera = {
        Mat3::Identity(), offset - Vec3(spec.squares_x * spec.square_m / 2, spec.squares_y * spec.square_m / 2, 0.0)};
    auto prim = std::make_shared<BoardPrimitive>(spec, compose(sc.fixed_camera_truth, in_camera));
    Renderer r(model, 0.0, 1);
    r.add_primitive(prim);
    cv::Mat gray;
    cv::cvtColor(r.render(Scene(sc), sc.fixed_camera_truth), gray, cv::COLOR_BGR2GRAY);
    // Black and white levels of the print (the sky around the plate may be brighter).
    const Eigen::Vector2d p0 = model.project(in_camera.position);
    const Eigen::Vector2d p1 =
        model.project(in_camera.position + Vec3(spec.squares_x, spec.squares_y, 0) * spec.square_m);
    double lo = 255, hi = 0;
    cv::minMaxLoc(gray(cv::Rect(cv::Point(static_cast<int>(p0.x()), static_cast<int>(p0.y())),
                                cv::Point(static_cast<int>(p1.x()), static_cast<int>(p1.y())))),
                  &lo, &hi);
    auto dark = [&](int x, int y) { return (hi - gray.at<uint8_t>(y, x)) / (hi - lo); };
    double worst = 0.0;
    int squares = 0;
    for (int j = 0; j < spec.squares_y; ++j)
      for (int i = 0; i < spec.squares_x; ++i) {
        if (printed.at<uint8_t>(j * 100 + 2, i * 100 + 2) > 127) continue;  // white square (it holds a marker)
        const Eigen::Vector2d a = model.project(in_camera.position + Vec3(i, j, 0) * spec.square_m);
        const Eigen::Vector2d b = model.project(in_camera.position + Vec3(i + 1, j + 1, 0) * spec.square_m);
        // Across x: rows inside the square, a pixel beyond it (the white gap around a marker is wider).
        double area = 0, moment = 0;
        int rows = 0;
        for (int y = static_cast<int>(std::ceil(a.y() + 3)); y <= static_cast<int>(std::floor(b.y() - 3)); ++y, ++rows)
          for (int x = static_cast<int>(std::floor(a.x())) - 1; x <= static_cast<int>(std::ceil(b.x())) + 1; ++x) {
            area += dark(x, y);
            moment += x * dark(x, y);
          }
        const double wx = area / rows, cx = moment / area;
        area = moment = 0;
        int cols = 0;
        for (int x = static_cast<int>(std::ceil(a.x() + 3)); x <= static_cast<int>(std::floor(b.x() - 3)); ++x, ++cols)
          for (int y = static_cast<int>(std::floor(a.y())) - 1; y <= static_cast<int>(std::ceil(b.y())) + 1; ++y) {
            area += dark(x, y);
            moment += y * dark(x, y);
          }
        const double wy = area / cols, cy = moment / area;
        for (const double e : {cx - wx / 2 - a.x(), cx + wx / 2 - b.x(), cy - wy / 2 - a.y(), cy + wy / 2 - b.y()})
          worst = std::max(worst, std::abs(e));
        ++squares;
      }
    SCOPED_TRACE(testing::Message() << "board centre " << offset.transpose());
    EXPECT_EQ(squares, (spec.squares_x * spec.squares_y + 1) / 2);
    EXPECT_LT(worst, 0.05) << "px";
    std::printf("square edges, board centre at depth %.2f: worst %.4f px\n", offset.z(), worst);
  }
}

// End to end through OpenCV's detector, tilted and distorted: what a
// calibration sees. The detector's own bias on these ~37 px squares (sub-pixel
// refinement between markers) is ~0.15 px; a half-pixel renderer offset or a
// wrong board frame would show as >= 0.5 px.
TEST(Board, DetectedCornersAreTheCameraModelsProjectionOfTheBoardPoints) {
  Scenario sc = test::one_fruit();  // 320 x 240, k1 = -0.12: distortion is part of the truth
  const BoardSpec spec;
  const std::size_t all = static_cast<std::size_t>((spec.squares_x - 1) * (spec.squares_y - 1));
  for (const auto& [depth, tx, ty] : {std::tuple{0.45, 0.0, 0.0}, std::tuple{0.5, 25.0, 0.0},
                                      std::tuple{0.5, -15.0, 30.0}, std::tuple{0.6, 10.0, -25.0}}) {
    std::size_t found = 0;
    const double worst = worst_corner_error(sc, spec, board_in_camera(spec, depth, tx, ty), &found);
    SCOPED_TRACE(testing::Message() << "depth " << depth << " tilt " << tx << ", " << ty);
    EXPECT_EQ(found, all);
    EXPECT_LT(worst, 0.4) << "px";
    std::printf("detected corners at depth %.2f tilt %.0f, %.0f: worst %.3f px\n", depth, tx, ty, worst);
  }
}

TEST(Board, TheBackOfThePlateShowsNoBoard) {
  Scenario sc = test::one_fruit();
  const BoardSpec spec;
  Placement p = board_in_camera(spec, 0.45, 0.0, 0.0);
  // Turn it about its own vertical centre line: the camera sees the back.
  const Vec3 centre = p.position + p.rotation * Vec3(spec.squares_x * spec.square_m / 2, 0.0, 0.0);
  p.rotation = p.rotation * Eigen::AngleAxisd(M_PI, Vec3::UnitY()).toRotationMatrix();
  p.position = centre - p.rotation * Vec3(spec.squares_x * spec.square_m / 2, 0.0, 0.0);
  std::size_t found = 1;
  worst_corner_error(sc, spec, p, &found);
  EXPECT_EQ(found, 0u);
}

// The scenario of the arm-moved procedure: the hand camera at the start pose
// sees the whole board where the true camera-in-hand pose puts it. (The fixed
// camera's thesis frame is improper, so it sees a proper board mirrored: the
// fixed-camera procedure needs its own board pose; see docs/calibration.md.)
TEST(Board, TheCalibrationScenarioShowsTheWholeBoardToTheHandCamera) {
  const Scenario sc = load_scenario("config/scenarios/calibration.yaml");
  ASSERT_EQ(sc.boards.size(), 1u);
  const BoardSetup& b = sc.boards[0];
  const Placement start{look_at_rotation(sc.arm.start_tool_position, sc.arm.start_look_at), sc.arm.start_tool_position};
  const Placement camera = CartesianArm(sc.arm, start, Placement{}).hand_camera();
  auto prim = std::make_shared<BoardPrimitive>(b.spec, b.pose);
  Renderer r(sc.hand_camera.model, sc.hand_camera.noise_std, 1);
  r.add_primitive(prim);
  const Found f = detect(r.render(Scene(sc), camera), prim->board());
  EXPECT_EQ(f.ids.size(), static_cast<std::size_t>((b.spec.squares_x - 1) * (b.spec.squares_y - 1)));
  // Each corner where the true pose and intrinsics put it (with sensor noise).
  const Mat3 rt = camera.rotation.transpose();
  double worst = 0.0;
  for (std::size_t k = 0; k < f.ids.size(); ++k) {
    const cv::Point3f& c = prim->board()->chessboardCorners[static_cast<std::size_t>(f.ids[k])];
    const Vec3 p_base = b.pose.rotation * Vec3(c.x, c.y, c.z) + b.pose.position;
    const Eigen::Vector2d px = sc.hand_camera.model.project(rt * (p_base - camera.position));
    worst = std::max(worst, (px - Eigen::Vector2d(f.corners[k].x, f.corners[k].y)).norm());
  }
  std::printf("calibration scenario, hand camera at the start: %zu corners, worst %.3f px\n", f.ids.size(), worst);
  EXPECT_LT(worst, 0.4) << "px";
}

// A board clamped to the tool, seen by the fixed camera through SimCameras
// (the simulator's own path: the tool's pose comes with the frame request).
// The worked numbers: the fixed camera at the base origin looking along base
// +y (thesis frame: camera x = -base z, y = base x, z = base y), fx 400,
// fy 380, (cx, cy) = (159.5, 119.5), no distortion. The tool at
// (-0.16, 0.60, 0.07) turned -90 deg about base x (tool z along base +y, tool
// y along base -z); the board 20 mm along tool x, -30 mm along y, 100 mm
// behind the tool, square with it. Its origin is then at base
// (-0.16 + 0.02, 0.60 - 0.10, 0.07 + 0.03) = (-0.14, 0.50, 0.10), and
// ChArUco corner 0, at (40, 40, 0) mm on the board, at base
// (-0.10, 0.50, 0.06) = camera (-0.06, -0.10, 0.50): pixel
// (159.5 + 400 x -0.12, 119.5 + 380 x -0.20) = (111.5, 43.5). Moving the tool
// 10 mm along base +x moves it 380 x 0.01 / 0.5 = 7.6 px down the image.
struct ToolBoardScene {
  Scenario sc = test::one_fruit(Vec3(0.6, 1.5, 0.0));  // the fruit well out of view
  BoardSpec spec;
  ToolBoardScene() {
    sc.fixed_camera.model.fx = 400.0;
    sc.fixed_camera.model.fy = 380.0;
    sc.fixed_camera.model.skew = 0.0;
    sc.fixed_camera.model.cx = 159.5;
    sc.fixed_camera.model.cy = 119.5;
    sc.fixed_camera.model.dist = {};
    sc.fixed_camera.encoding = "bgr8";
    sc.hand_camera.encoding = "bgr8";
    sc.boards.push_back({spec, {Mat3::Identity(), Vec3(0.02, -0.03, -0.10)}, true});
  }
  static Placement tool(const Vec3& shift = Vec3::Zero()) {
    return {Eigen::AngleAxisd(-M_PI / 2, Vec3::UnitX()).toRotationMatrix(), Vec3(-0.16, 0.60, 0.07) + shift};
  }
  // The fixed camera's frame with the tool at `tool`; corners found in the
  // left-right flipped image (a proper board seen through the improper thesis
  // frame is mirrored) and mapped back to the frame's pixels.
  Found fixed_view(SimCameras& cams, const Placement& tool) const {
    const Scene scene(sc);
    const image_t img = cams.render({CameraId::kFixed, 0, scene.fruit(), Placement{}, tool});
    const camera::DecodedImage d = camera::decode_image(img);
    EXPECT_TRUE(d.ok()) << d.error;
    cv::Mat flipped;
    cv::flip(d.bgr, flipped, 1);
    Found f = detect(flipped, make_board(spec));
    for (cv::Point2f& c : f.corners) c.x = static_cast<float>(d.bgr.cols - 1) - c.x;
    return f;
  }
};

cv::Point2f corner(const Found& f, int id) {
  for (std::size_t k = 0; k < f.ids.size(); ++k)
    if (f.ids[k] == id) return f.corners[k];
  ADD_FAILURE() << "corner " << id << " not found";
  return {-1, -1};
}

TEST(Board, ABoardOnTheToolIsWhereTheToolPutsIt) {
  ToolBoardScene t;
  SimCameras cams(t.sc, Scene(t.sc));
  const Found f = t.fixed_view(cams, ToolBoardScene::tool());
  EXPECT_EQ(f.ids.size(), static_cast<std::size_t>((t.spec.squares_x - 1) * (t.spec.squares_y - 1)));
  const cv::Point2f c0 = corner(f, 0);
  std::printf("tool-held board, corner 0 at (%.3f, %.3f) px, worked (111.5, 43.5)\n", c0.x, c0.y);
  EXPECT_NEAR(c0.x, 111.5, 0.3);
  EXPECT_NEAR(c0.y, 43.5, 0.3);
}

TEST(Board, ABoardOnTheToolMovesWithTheTool) {
  ToolBoardScene t;
  SimCameras cams(t.sc, Scene(t.sc));
  const Found before = t.fixed_view(cams, ToolBoardScene::tool());
  const Found after = t.fixed_view(cams, ToolBoardScene::tool(Vec3(0.01, 0.0, 0.0)));
  ASSERT_EQ(after.ids.size(), before.ids.size());
  // Every corner 7.6 px down the image, none across (the board square on, no distortion).
  for (int id : before.ids) {
    const cv::Point2f a = corner(before, id), b = corner(after, id);
    EXPECT_NEAR(b.x - a.x, 0.0, 0.3) << "corner " << id;
    EXPECT_NEAR(b.y - a.y, 7.6, 0.3) << "corner " << id;
  }
  // And back where it was with the tool back: the pose is the request's, nothing accumulates.
  const Found again = t.fixed_view(cams, ToolBoardScene::tool());
  EXPECT_NEAR(corner(again, 0).y, corner(before, 0).y, 0.3);
}

TEST(Board, ScenarioBoardsAreChecked) {
  const std::string good = "name: t\nfruit: [{position_mm: [0, 1000, 0]}]\nboards:\n  - ";
  const auto load = [&](const std::string& board) {
    const auto doc = config::Document::load_string(good + board + "\n");
    const Scenario s = Scenario::from_config(doc.root());
    doc.check_unused();
    return s;
  };
  const Scenario s = load("{squares: [5, 4], square_mm: 30, marker_mm: 22, stand: {translation_mm: [1, 2, 3]}}");
  ASSERT_EQ(s.boards.size(), 1u);
  EXPECT_EQ(s.boards[0].spec.squares_x, 5);
  EXPECT_NEAR(s.boards[0].spec.marker_m, 0.022, 1e-12);
  EXPECT_NEAR(s.boards[0].pose.position.z(), 0.003, 1e-12);
  const Scenario on_tool = load("{tool: {translation_mm: [0, 0, -100], rpy_deg: [0, 0, 90]}}");
  EXPECT_TRUE(on_tool.boards.at(0).on_tool);
  EXPECT_NEAR(on_tool.boards[0].pose.position.z(), -0.1, 1e-12);
  EXPECT_FALSE(s.boards[0].on_tool);
  for (const std::string bad : {"{squares: [2, 4]}", "{stand: {translation_mm: [1, 2, 3]}, tool: {}}", "{squares: [5.5, 4]}", "{square_mm: 20, marker_mm: 20}",
                                "{dictionary: DICT_7X7_50}", "{squares: [11, 11], dictionary: DICT_4X4_50}"})
    EXPECT_THROW(load(bad), config::Error) << bad;
}

TEST(Board, ImpossibleLayoutsAreRefused) {
  BoardSpec b;
  EXPECT_NO_THROW(make_board(b));
  b.marker_m = b.square_m;
  EXPECT_THROW(make_board(b), std::invalid_argument);
  b = BoardSpec{};
  b.squares_x = 2;
  EXPECT_THROW(make_board(b), std::invalid_argument);
  b = BoardSpec{};
  b.margin_m = -0.01;
  EXPECT_THROW(make_board(b), std::invalid_argument);
  b = BoardSpec{};
  b.dictionary = "DICT_5X5_1000000";
  EXPECT_THROW(make_board(b), std::invalid_argument);
  b = BoardSpec{};
  b.dictionary = "DICT_4X4_50";
  b.squares_x = b.squares_y = 11;  // 60 markers
  EXPECT_THROW(make_board(b), std::invalid_argument);
}

}  // namespace
}  // namespace harvest::sim
