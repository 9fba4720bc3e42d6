#include "servo/harvest/hand_tracker.hpp"

#include <cmath>
#include <limits>
#include <vector>

#include "servo/geometry.hpp"

namespace harvest::servo {

std::optional<PixelMeasurement> HandTracker::fresh(rt::Micros now) const {
  if (pixel_ && now - pixel_rx_ <= rt::from_seconds(cfg_.timeouts.lost)) return pixel_;
  return std::nullopt;
}

std::optional<double> HandTracker::fruit_in_front(rt::Micros now) const {
  if (fruit_fills_view_rx_ != 0 && now - fruit_fills_view_rx_ <= rt::from_seconds(cfg_.timeouts.lost))
    return fruit_in_front_offset_;
  return std::nullopt;
}

bool HandTracker::seen_whole(rt::Micros now) const {
  return pixel_ && pixel_whole_ && now - pixel_->utime <= rt::from_seconds(cfg_.far_view_age);
}

bool HandTracker::fruit_on_axis(rt::Micros now) const {
  return cfg_.axis_fruit_area > 0 && fruit_on_axis_taken_ &&
         now - *fruit_on_axis_taken_ <= rt::from_seconds(cfg_.far_view_age);
}

void HandTracker::on_detections(const fruit_detections_t& msg, const Fruit& fruit, const Eigen::Isometry3d& camera,
                                rt::Micros now) {
  const geometry::CameraModel& k = cfg_.hand_camera;
  // A fruit filling the image where the gripper axis (the optical axis) meets
  // it, and far larger than the current fruit looks at its estimated depth:
  // a fruit nearer than it, so what the IR reads right in front of the
  // gripper is that fruit, not a leaf (see the leaf rule in IrGuidance).
  const double depth = (camera.inverse() * fruit.estimate).z();
  const double expected_px = depth > 0.01 ? k.fx * fruit.diameter / depth : 0.0;
  const double image_area = static_cast<double>(msg.image_width) * msg.image_height;
  for (const auto& f : msg.fruits) {
    const auto& b = f.bbox_px;
    const bool on_centre = b[0] <= k.cx && k.cx <= b[0] + b[2] && b[1] <= k.cy && k.cy <= b[1] + b[3];
    // The optical axis runs beside the gripper axis (the camera sits in the palm), so a fruit over the image centre
    // that large is near the palm and across the IR's beam.
    if (on_centre && f.area_px >= cfg_.axis_fruit_area * image_area) fruit_on_axis_taken_ = msg.header.utime;
    if (f.diameter_px >= cfg_.fills_view * msg.image_height &&
        f.diameter_px > cfg_.front_fruit_size_ratio * expected_px && on_centre) {
      fruit_fills_view_rx_ = now;
      // How far its centre lies off the gripper axis [m]: the pixel offset in
      // its own apparent diameters, times the (statistical) fruit diameter.
      fruit_in_front_offset_ =
          std::hypot(f.u_px - k.cx, f.v_px - k.cy) / std::max(1.0f, f.diameter_px) * fruit.diameter;
    }
  }
  // Where the current fruit is in this image: near our last centroid while
  // we follow it; else on the image of the fixed camera's line of sight
  // while its depth is doubtful (nearest the aim point among equals); else
  // at the hand target the reconstructor matched to the fruit in 3D; else at
  // the projected estimate.
  Eigen::Vector2d predicted;
  std::vector<Eigen::Vector2d> sight_px;
  const rt::Micros recent = rt::from_seconds(cfg_.timeouts.lost);
  const bool doubtful = fruit.depth_doubtful && fruit.sight;
  bool have_point = true;
  const bool following = pixel_ && now - pixel_rx_ <= recent;
  if (following) {
    predicted = {pixel_->u, pixel_->v};
  } else if (!doubtful && hand_target_px_ && now - hand_target_rx_ <= recent) {
    predicted = *hand_target_px_;
  } else {
    have_point = project_point(k, camera.inverse() * fruit.estimate, predicted);
    if (fruit.sight) {
      const SightLine& l = *fruit.sight;
      sight_px = project_segment(k, camera, l.at(l.near), l.at(l.far));
    }
    if (sight_px.empty() && !have_point) return;
  }
  // Gate on the distance to the image of the fixed camera's line of sight
  // (or to the point); among detections near the line, the distance to the
  // predicted point decides too: a little for a doubtful depth, more for a
  // plausible one. A neighbour nearer the point but off the line is another
  // fruit at another depth.
  const double tie_weight = doubtful ? cfg_.association_tie_weight_doubtful : cfg_.association_tie_weight;
  double best = std::numeric_limits<double>::infinity();
  const fruit_t* match = nullptr;
  // While following, the apparent size changes little from one image to the next (the tool advancing 13 mm a frame
  // at full speed 10 cm from the fruit: 13 %): a fruit near the camera broken into pieces by leaves and highlights
  // (a 250 px fruit became five 40-80 px pieces in a full-tree run) is not followed onto a piece.
  // The size it should have now is the last one scaled by how much nearer the camera has come to the estimate since
  // that image (the estimate's own error mostly cancels in the ratio): coming in at full speed the fruit grows by
  // itself, and a jump beyond it is something else: a piece, or a nearer fruit merged with it in one detection (a
  // tree_wind run followed such a merge, 115 -> 176 px in one image, and closed 32 mm beside the fruit).
  const double ratio = cfg_.association_size_ratio;
  double grown_px = pixel_diameter_;
  if (following) {
    const double then = (pixel_camera_.inverse() * fruit.estimate).z();
    if (then > 0.01 && depth > 0.01) grown_px *= then / depth;
  }
  const auto size_fits = [&](const fruit_t& f) {
    if (!following || ratio <= 0.0 || grown_px <= 0.0 || f.diameter_px <= 0.0f) return true;
    const double r = static_cast<double>(f.diameter_px) / grown_px;
    return r <= ratio && r * ratio >= 1.0;
  };
  for (const auto& f : msg.fruits) {
    if (!size_fits(f)) continue;
    const Eigen::Vector2d px(f.u_px, f.v_px);
    const double to_point = have_point ? (px - predicted).norm() : 0.0;
    const double d = sight_px.empty() ? to_point : distance_to_polyline(sight_px, px);
    const double score = sight_px.empty() ? d : d + tie_weight * to_point;
    if (d <= cfg_.association_gate_px && score < best) {
      best = score;
      match = &f;
    }
  }
  if (match == nullptr) return;
  pixel_ = PixelMeasurement{match->u_px, match->v_px, msg.header.utime};
  pixel_rx_ = now;
  pixel_diameter_ = match->diameter_px;
  pixel_camera_ = camera;
  // Whole: clear of the image border, not filling most of the image (near,
  // under IR guidance) and not a piece of a fruit (whole_min_visible): only
  // then does its apparent size give a depth.
  const int border = cfg_.whole_fruit_border_px;
  const auto& b = match->bbox_px;
  pixel_whole_ = b[0] >= border && b[1] >= border && b[0] + b[2] <= msg.image_width - border &&
                 b[1] + b[3] <= msg.image_height - border && match->diameter_px <= cfg_.fills_view * msg.image_height &&
                 match->visible_fraction >= cfg_.whole_min_visible;
  pixel_crossing_ = pixel_whole_ ? cross(*pixel_, fruit, camera) : std::nullopt;
}

void HandTracker::on_hand_targets(const targets_t& msg, Fruit& fruit, const Eigen::Isometry3d& camera, rt::Micros now) {
  // The camera-in-hand re-estimate replaces the fixed camera's (eq. 6-15).
  // It is the target made from the very detection we follow (same image,
  // same pixel), whatever id the reconstructor matched it to in 3D: its
  // match against a fixed-camera estimate with a wrong depth would fail.
  for (const auto& t : msg.targets) {
    if (t.fruit_id != fruit.id) continue;
    hand_target_px_ = Eigen::Vector2d(t.u_px, t.v_px);  // the next image's prediction, see on_detections
    hand_target_rx_ = now;
  }
  // A fruit cut by the image border, or filling most of the image, has no
  // apparent size to take a depth from: the estimate stays the last one that
  // had (eq. 6-15).
  if (!pixel_ || msg.header.utime != pixel_->utime || !pixel_whole_) return;
  constexpr double kSamePixel = 0.5;  // [px] the reconstructor copies the detection's centroid
  for (const auto& t : msg.targets) {
    if ((Eigen::Vector2d(t.u_px, t.v_px) - Eigen::Vector2d(pixel_->u, pixel_->v)).norm() > kSamePixel) continue;
    const Eigen::Vector3d sized(t.position_base[0], t.position_base[1], t.position_base[2]);
    fruit.depth_doubtful = false;
    fruit.estimate = sized;
    fruit.depth = Fruit::Depth::kSize;
    if (pixel_crossing_) {
      // The size is the better depth near the fruit (its error shrinks with
      // the distance, about 10 % rms; the crossing's stays that of the fixed
      // calibration); the crossing catches a size gone grossly wrong: a leaf
      // cutting the fruit makes it look small and far (a factor of 1.5 or more).
      const double range = (*pixel_crossing_ - camera.translation()).norm();
      const bool agrees =
          (sized - *pixel_crossing_).norm() <= std::max(cfg_.size_agreement_min, cfg_.size_agreement * range);
      // A size that disagrees is replaced only when it puts the fruit far: near the fruit a disagreeing crossing was
      // nearly always the wrong one (seven tree runs: 1 % right under 0.25 m, where it put the fruit 13 cm short and
      // the centring, placing the fruit on its image ray at that depth, steered the gripper away from it).
      const bool far = (sized - camera.translation()).norm() >= cfg_.crossing_beyond;
      if (agrees) {
        fruit.depth = Fruit::Depth::kConfirmed;
      } else if (far) {
        fruit.estimate = *pixel_crossing_;
        fruit.depth = Fruit::Depth::kCrossing;
      } else {
        fruit.depth = Fruit::Depth::kNear;
      }
    } else if (!cfg_.workspace.contains(sized)) {
      // No crossing (the rays too parallel) and a size putting it where no fruit can be picked: a leaf-cut fruit
      // looks small and far. Its ray still knows the direction; the fixed camera's estimate gives the depth.
      if (const auto along = along_ray(*pixel_, fruit.selected_from, camera)) {
        fruit.estimate = *along;
        fruit.depth = Fruit::Depth::kFixed;
      }
    }
    break;
  }
}

std::optional<Eigen::Vector3d> HandTracker::along_ray(const PixelMeasurement& pixel, const Eigen::Vector3d& fixed,
                                                      const Eigen::Isometry3d& cam) const {
  if (cfg_.fixed_depth_gap <= 0.0) return std::nullopt;
  const Eigen::Vector3d ray = ray_through(pixel, cam);
  const double s = (fixed - cam.translation()).dot(ray);
  if (s <= 0.0) return std::nullopt;
  const Eigen::Vector3d point = cam.translation() + s * ray;
  if ((point - fixed).norm() > cfg_.fixed_depth_gap || !cfg_.workspace.contains(point)) return std::nullopt;
  return point;
}

Eigen::Vector3d HandTracker::ray_through(const PixelMeasurement& pixel, const Eigen::Isometry3d& cam) const {
  const Eigen::Vector2d xy = undistort_pixel(cfg_.hand_camera, pixel.u, pixel.v);
  return cam.rotation() * Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
}

std::optional<Eigen::Vector3d> HandTracker::cross(const PixelMeasurement& pixel, const Fruit& fruit,
                                                  const Eigen::Isometry3d& cam) const {
  if (cfg_.triangulation_gap <= 0.0 || !fruit.sight) return std::nullopt;
  // `cam` is where the camera took the image (HarvestMachine::image_camera).
  const Eigen::Vector3d ray = ray_through(pixel, cam);
  const SightLine& l = *fruit.sight;
  const auto c = cross_rays(cam.translation(), ray, l.origin, l.direction);
  if (!c || c->gap > cfg_.triangulation_gap || c->angle < cfg_.min_triangulation_angle) return std::nullopt;
  return c->point;
}

}  // namespace harvest::servo
