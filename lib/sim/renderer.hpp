// Software renderer of a Scene through one camera (the true intrinsics and
// distortion, via geometry::CameraModel).
//
// Every pixel's viewing ray is precomputed once by undistorting the pixel
// (so distortion is exact, not approximated); each primitive (fruit sphere,
// branch bead, leaf blade, and any extra Primitive such as a calibration
// board) is then ray-cast only over the pixels of its bounding box, with a
// depth buffer for occlusion.
//
// Two looks (scenario `look.style`, docs/simulator.md):
// * flat: Lambertian from the sun plus ambient on flat colours, scaled by the
//   exposure, Gaussian sensor noise from a seeded table; a frame depends only
//   on the scene, pose and frame count.
// * field: the nearest surface of each pixel is shaded afterwards (textures,
//   specular highlights, cast shadows from a ShadowMap, overexposed sky, see
//   materials.hpp), then developed by a FieldCamera (motion blur, auto
//   exposure, white-balance drift, vignetting, shot noise); a frame then also
//   depends on the frames before it (exposure) and the previous pose (blur).
#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "geometry/camera_model.hpp"
#include "sim/camera_effects.hpp"
#include "sim/materials.hpp"
#include "sim/scene.hpp"
#include "sim/shadow_map.hpp"

namespace harvest::sim {

class Renderer {
 public:
  static constexpr int32_t kSky = -1;
  static constexpr int32_t kLeaf = -2;
  static constexpr int32_t kBranch = -3;
  static constexpr int32_t kExtra = -4;  // drawn by an extra Primitive (e.g. a calibration board)

  struct PixelBox {
    int x0, y0, x1, y1;  // inclusive; empty when x0 > x1
  };

  // What an extra Primitive sees of the frame being drawn.
  class Canvas {
   public:
    int width() const { return r_.w_; }
    int height() const { return r_.h_; }
    // Undistorted viewing ray of pixel i = y * width + x, camera frame, z = 1.
    Eigen::Vector3f ray(int i) const { return {r_.nx_[i], r_.ny_[i], 1.0f}; }
    // Pixels that may see the normalised-coordinate box [ax, bx] x [ay, by].
    PixelBox pixels(float ax, float bx, float ay, float by) const { return r_.normalized_box(ax, bx, ay, by); }
    // A surface at `depth` (along the optical axis) on pixel i, if nearer than
    // what is there: its albedo (RGB 0..255) and unit normal (camera frame);
    // the renderer lights it like a leaf of either look (sun, ambient, shadow).
    void put(int i, float depth, const Vec3& albedo_rgb, const Eigen::Vector3f& normal);

   private:
    friend class Renderer;
    explicit Canvas(Renderer& r) : r_(r) {}
    Renderer& r_;
  };

  // Something drawn besides the scene (issue 20: calibration boards). `rotation`
  // and `translation` take base-frame points to the camera frame.
  class Primitive {
   public:
    virtual ~Primitive() = default;
    virtual void draw(Canvas& canvas, const Mat3& rotation, const Vec3& translation) const = 0;
  };

  Renderer(const geometry::CameraModel& model, double noise_std, uint64_t seed);

  // The look to draw with (default: flat). `rate_hz`: the camera's frame rate
  // (motion blur and drift clocks of the field look).
  void set_look(const Look& look, double rate_hz);
  const Look& look() const { return look_; }

  void add_primitive(std::shared_ptr<const Primitive> primitive) { extras_.push_back(std::move(primitive)); }

  // Renders into an 8-bit BGR image (reused between calls). `pose` places the
  // camera optical frame in the base frame. The field look blurs along the
  // motion from the pose of the previous call (none on the first).
  const cv::Mat& render(const Scene& scene, const Placement& pose);
  // The same, with the camera at `previous` one frame period earlier.
  const cv::Mat& render(const Scene& scene, const Placement& pose, const Placement& previous);

  // Per pixel of the last render: fruit index, or kSky / kLeaf / kBranch / kExtra.
  const std::vector<int32_t>& ids() const { return ids_; }
  // Per fruit of the last render: pixels where it is the nearest surface, and
  // pixels its silhouette covers ignoring occluders (both inside the image).
  const std::vector<int>& visible_pixels() const { return visible_; }
  const std::vector<int>& silhouette_pixels() const { return silhouette_; }
  // Per fruit: how it is drawn in the field look (ripeness, colours).
  FruitMaterial fruit_material(const Scene& scene, std::size_t fruit_index) const;

  const geometry::CameraModel& model() const { return model_; }

 private:
  // Pixels that may see a sphere of radius r at camera-frame centre c.
  PixelBox bounds(const Eigen::Vector3f& c, float r) const;
  // Pixels that may see a leaf blade (centre c, midrib u, across v, half sizes).
  PixelBox leaf_bounds(const Eigen::Vector3f& c, const Eigen::Vector3f& u, const Eigen::Vector3f& v, float hl,
                       float hw) const;
  // Pixels covering the normalised-coordinate box [ax, bx] x [ay, by].
  PixelBox normalized_box(float ax, float bx, float ay, float by) const;
  void put(int i, float depth, const Vec3& rgb, int32_t id, int32_t prim);
  void put_surface(int i, float depth, int32_t id, int32_t prim);  // field look: no colour yet
  void draw_sphere(const Eigen::Vector3f& c, float r, const Vec3& albedo, int32_t id, int32_t prim,
                   const Eigen::Vector3f& sun, const Lighting& light);
  void draw_leaf(const Leaf& leaf, int32_t prim, const Mat3& rt, const Vec3& t, const Eigen::Vector3f& sun,
                 const Lighting& light);
  void write_flat(const Eigen::Vector3f& sun, const Lighting& light);
  void shade_field(const Scene& scene, const Placement& pose, const Eigen::Vector3f& sun);
  Eigen::Vector2f image_motion(const Placement& pose, const Placement& previous) const;

  geometry::CameraModel model_;
  int w_, h_;
  std::vector<float> nx_, ny_;  // undistorted normalised ray per pixel (z = 1)
  float nx_min_, nx_max_, ny_min_, ny_max_;
  std::vector<float> depth_;
  std::vector<int32_t> ids_;
  std::vector<int32_t> prim_;  // leaf / bead / fruit index of the nearest surface (fruit seen from inside: -1 - index)
  std::vector<Vec3> rgb_;      // flat: shaded colour; extras: albedo
  std::vector<Eigen::Vector3f> extra_normal_;
  std::vector<int> visible_, silhouette_;
  std::vector<int16_t> noise_;  // N(0, noise_std) in 1/16 grey levels
  uint64_t noise_state_;
  cv::Mat image_;
  std::vector<std::shared_ptr<const Primitive>> extras_;

  // Field look.
  Look look_;
  double noise_std_;
  uint64_t seed_;
  double rate_hz_ = 30.0;
  std::optional<FieldCamera> camera_;
  ShadowMap shadows_;
  std::vector<float> radiance_;  // RGB per pixel before the camera
  std::vector<std::pair<float, int32_t>> leaf_order_;  // near to far
  std::optional<Placement> last_pose_;
};

}  // namespace harvest::sim
