#include "vision/reconstructor.hpp"

#include <algorithm>
#include <cmath>

#include "config/config.hpp"
#include "config/schema.hpp"
#include "geometry/pose_msg.hpp"
#include "geometry/transform_file.hpp"

namespace harvest::vision {

namespace {

void fill_pose_estimate(target_t& t, const PointEstimate& cam, const PointEstimate& base) {
  for (int i = 0; i < 3; ++i) {
    t.position_camera[i] = cam.position[i];
    t.position_base[i] = base.position[i];
    for (int j = 0; j < 3; ++j) t.covariance_base[3 * i + j] = base.covariance(i, j);
  }
  t.depth_m = cam.position.z();
}

}  // namespace

ReconstructorConfig ReconstructorConfig::from_yaml(const config::Node& n) {
  namespace k = reconstructor_keys;
  ReconstructorConfig c;
  const config::Node fixed = n.child("camera_fixed");
  c.fixed_camera = geometry::CameraModel::from_config(fixed, k::fixed_calibration);
  // The thesis's eq. 4-1 matrix has determinant -1 (its fixed camera frame
  // and base frame differ in handedness), and it is the contract.
  const auto extrinsic = fixed.get(k::extrinsic);
  try {
    c.fixed_extrinsic = geometry::load_transform_file(extrinsic, geometry::Handedness::kReflectionAllowed);
  } catch (const std::exception& e) {
    fixed.fail("extrinsic", std::string("a readable extrinsic calibration (") + e.what() + ")");
  }
  c.fixed_extrinsic_sigma_m = fixed.get(k::extrinsic_sigma_m);
  const config::Node hand = n.child("camera_hand");
  c.hand_camera = geometry::CameraModel::from_config(hand, k::hand_calibration);
  c.hand_pose_sigma_m = hand.get(k::pose_sigma_m);
  c.max_state_gap_us = 1000 * hand.get(k::max_state_gap_ms);
  const config::Node fruit = n.child("fruit");
  c.fruit.diameter_mean_m = fruit.get(fruit_keys::diameter_mean_m);
  c.fruit.diameter_std_m = fruit.get(fruit_keys::diameter_std_m);
  const config::Node noise = n.child("pixel_noise");
  c.noise.centre_px = noise.get(fruit_keys::centre_px);
  c.noise.diameter_px = noise.get(fruit_keys::diameter_px);
  const config::Node tracking = n.child("tracking");
  c.track_gate_diameters = tracking.get(k::gate_diameters);
  c.track_max_missed = tracking.get(k::max_missed_frames);
  c.association_gate_chi2 = tracking.get(k::association_gate_chi2);
  c.fixed_memory_us = 1'000'000 * tracking.get(k::fixed_memory_s);
  return c;
}

std::vector<config::Section> ReconstructorConfig::schema() {
  namespace k = reconstructor_keys;
  const std::string where = "harvest-reconstructor, config/vision/reconstructor.yaml (docs/perception.md).";
  return {config::section("reconstructor.camera_fixed", where, k::fixed_calibration, k::extrinsic, k::extrinsic_sigma_m),
          config::section("reconstructor.camera_hand", where, k::hand_calibration, k::pose_sigma_m, k::max_state_gap_ms),
          config::section("reconstructor.fruit", where, fruit_keys::diameter_mean_m, fruit_keys::diameter_std_m),
          config::section("reconstructor.pixel_noise", where, fruit_keys::centre_px, fruit_keys::diameter_px),
          config::section("reconstructor.tracking", where, k::gate_diameters, k::max_missed_frames,
                          k::association_gate_chi2, k::fixed_memory_s)};
}

Reconstructor::Reconstructor(ReconstructorConfig config)
    : config_(std::move(config)),
      fixed_tracker_(config_.track_gate_diameters, config_.track_max_missed, 0),
      hand_tracker_(config_.track_gate_diameters, config_.track_max_missed, 0),
      associator_(config_.association_gate_chi2) {}

void Reconstructor::on_robot_state(const robot_state_t& state) {
  camera_poses_.add(state.header.utime, geometry::to_isometry(state.camera_pose));
}

targets_t Reconstructor::make_targets(const fruit_detections_t& d, const geometry::CameraModel& cam,
                                      const Eigen::Isometry3d& cam_to_base, double transform_sigma,
                                      const std::string& camera, std::vector<Estimate3d>& estimates) const {
  targets_t out;
  out.header.utime = d.header.utime;
  out.header.frame_id = "base";
  out.header.source_seq = d.header.seq;
  out.source_camera = camera;
  out.selected_fruit_id = -1;
  // Only the centre: the thesis's fixed-camera rotation (eq. 4-1) is a
  // reflection, which no quaternion could carry.
  out.camera_known = true;
  for (int i = 0; i < 3; ++i) out.camera_position_base[i] = cam_to_base.translation()[i];
  for (const fruit_t& f : d.fruits) {
    const PointEstimate in_cam =
        reconstruct_in_camera(cam, f.u_px, f.v_px, f.diameter_px, config_.fruit, config_.noise);
    const PointEstimate in_base = transform(cam_to_base, in_cam, transform_sigma);
    target_t t{};
    t.fruit_id = -1;
    t.source_camera = camera;
    fill_pose_estimate(t, in_cam, in_base);
    t.diameter_m = config_.fruit.diameter_mean_m;
    t.u_px = f.u_px;
    t.v_px = f.v_px;
    t.diameter_px = f.diameter_px;
    t.confidence = f.confidence;
    t.cost = f.cost;
    t.selected = false;
    out.targets.push_back(t);
    estimates.push_back({in_base.position, in_base.covariance});
  }
  out.num_targets = static_cast<int32_t>(out.targets.size());
  return out;
}

namespace {

std::optional<std::string> check_detections(const fruit_detections_t& d) {
  if (d.status != fruit_detections_t::STATUS_OK)
    return "camera '" + d.camera + "' image seq " + std::to_string(d.header.source_seq) + " was bad: " + d.status_text;
  if (d.num_fruits != static_cast<int32_t>(d.fruits.size())) return "inconsistent num_fruits";
  for (const fruit_t& f : d.fruits)
    if (!(f.diameter_px > 0) || !std::isfinite(f.u_px) || !std::isfinite(f.v_px) || !std::isfinite(f.diameter_px))
      return "camera '" + d.camera + "': fruit with invalid centre or diameter";
  return std::nullopt;
}

std::vector<PixelObservation> observations(const fruit_detections_t& d) {
  std::vector<PixelObservation> obs;
  for (const fruit_t& f : d.fruits) obs.push_back({f.u_px, f.v_px, f.diameter_px});
  return obs;
}

void select(targets_t& t, int32_t id) {
  t.selected_fruit_id = -1;
  for (target_t& x : t.targets) {
    x.selected = x.fruit_id == id && id >= 0;
    if (x.selected) t.selected_fruit_id = id;
  }
}

bool contains(const targets_t& t, int32_t id) {
  return id >= 0 &&
         std::any_of(t.targets.begin(), t.targets.end(), [id](const target_t& x) { return x.fruit_id == id; });
}

}  // namespace

std::optional<targets_t> Reconstructor::on_fixed(const fruit_detections_t& d) {
  if (auto err = check_detections(d)) {
    last_error_ = *err;
    return std::nullopt;
  }
  const std::vector<int32_t> ids = fixed_tracker_.update(observations(d));
  std::vector<Estimate3d> estimates;
  targets_t out = make_targets(d, config_.fixed_camera, config_.fixed_extrinsic, config_.fixed_extrinsic_sigma_m,
                               "fixed", estimates);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    out.targets[i].fruit_id = ids[i];
    known_[ids[i]] = estimates[i];
    last_seen_[ids[i]] = d.header.utime;
  }
  for (auto it = last_seen_.begin(); it != last_seen_.end();) {
    if (d.header.utime - it->second > config_.fixed_memory_us) {
      known_.erase(it->first);
      it = last_seen_.erase(it);
    } else {
      ++it;
    }
  }
  // Keep the fruit the controller is after; else the detector's choice.
  int32_t chosen = -1;
  if (contains(out, current_fruit_id_))
    chosen = current_fruit_id_;
  else if (d.selected_index >= 0 && d.selected_index < out.num_targets)
    chosen = out.targets[static_cast<std::size_t>(d.selected_index)].fruit_id;
  select(out, chosen);
  fixed_selected_id_ = chosen;
  return out;
}

std::optional<targets_t> Reconstructor::on_hand(const fruit_detections_t& d) {
  if (auto err = check_detections(d)) {
    last_error_ = *err;
    return std::nullopt;
  }
  const auto camera = camera_poses_.at(d.header.utime, config_.max_state_gap_us);
  if (!camera) {
    last_error_ = "no robot state within " + std::to_string(config_.max_state_gap_us / 1000) +
                  " ms of hand image time " + std::to_string(d.header.utime);
    return std::nullopt;
  }
  const std::vector<int32_t> hand_ids = hand_tracker_.update(observations(d));
  associator_.prune(hand_tracker_);
  std::vector<Estimate3d> estimates;
  targets_t out = make_targets(d, config_.hand_camera, *camera, config_.hand_pose_sigma_m, "hand", estimates);
  const auto global = associator_.associate(hand_ids, estimates, known_);
  for (std::size_t i = 0; i < hand_ids.size(); ++i)
    out.targets[i].fruit_id = global[i] ? *global[i] : kUnassociatedIdBase + hand_ids[i];
  int32_t chosen = -1;
  if (contains(out, current_fruit_id_))
    chosen = current_fruit_id_;
  else if (contains(out, fixed_selected_id_))
    chosen = fixed_selected_id_;
  else if (d.selected_index >= 0 && d.selected_index < out.num_targets)
    chosen = out.targets[static_cast<std::size_t>(d.selected_index)].fruit_id;
  select(out, chosen);
  return out;
}

}  // namespace harvest::vision
