#include "sim/hand.hpp"

#include <algorithm>
#include <cmath>

namespace harvest::sim {
namespace {

bool gone(const Fruit& f) { return f.state == FruitState::kPicked || f.state == FruitState::kKnocked; }

// Nearest positive hit of a ray with a sphere.
std::optional<double> hit_sphere(const Vec3& o, const Vec3& d, const Vec3& c, double r) {
  const Vec3 oc = c - o;
  const double b = d.dot(oc), disc = b * b - (oc.squaredNorm() - r * r);
  if (disc < 0.0) return std::nullopt;
  const double s = std::sqrt(disc);
  if (b - s > 0.0) return b - s;
  if (b + s > 0.0) return 0.0;  // origin inside: touching
  return std::nullopt;
}

std::optional<double> hit_leaf(const Vec3& o, const Vec3& d, const Leaf& leaf) {
  const double nd = leaf.normal.dot(d);
  if (std::abs(nd) < 1e-12) return std::nullopt;
  const double t = leaf.normal.dot(leaf.centre - o) / nd;
  if (t <= 0.0) return std::nullopt;
  const Vec3 q = o + t * d - leaf.centre;
  const double qu = q.dot(leaf.u) / leaf.half_length;
  if (std::abs(qu) > 1.0 || std::abs(q.dot(leaf.v)) > leaf.half_width * (1.0 - qu * qu)) return std::nullopt;
  return t;
}

}  // namespace

std::optional<double> ray_cast(const Scene& scene, const Vec3& origin, const Vec3& direction, double max_range) {
  std::optional<double> best;
  auto consider = [&](std::optional<double> t) {
    if (t && *t <= max_range && (!best || *t < *best)) best = t;
  };
  for (const auto& f : scene.fruit())
    if (!gone(f)) consider(hit_sphere(origin, direction, f.position, f.radius));
  for (const auto& b : scene.beads()) consider(hit_sphere(origin, direction, b.centre, b.radius));
  for (const auto& l : scene.leaves()) consider(hit_leaf(origin, direction, l));
  return best;
}

IrSensor::IrSensor(const IrSetup& setup, uint64_t seed) : setup_(setup), rng_(seed), noise_(0.0, setup.noise_std) {}

int IrSensor::ideal_raw(std::optional<double> range) const {
  auto curve = [&](double r_m) { return setup_.gain / (r_m * 1e3 + setup_.offset_mm); };
  double raw;
  if (!range || *range > setup_.max_range) {
    raw = 0.8 * curve(setup_.max_range);  // nothing in view: the floor of the curve
  } else if (*range < setup_.peak_range) {
    raw = curve(setup_.peak_range) * (*range / setup_.peak_range);  // fold-back
  } else {
    raw = curve(*range);
  }
  return std::clamp(static_cast<int>(std::lround(raw)), 0, 1023);
}

int IrSensor::sample(std::optional<double> range) {
  const double noisy = ideal_raw(range) + (setup_.noise_std > 0.0 ? noise_(rng_) : 0.0);
  return std::clamp(static_cast<int>(std::lround(noisy)), 0, 1023);
}

void Gripper::close(double t) {
  if (phase_ == GripperPhase::kClosing || phase_ == GripperPhase::kClosed || phase_ == GripperPhase::kHolding) return;
  last_t_ = t;
  phase_ = GripperPhase::kClosing;
}

void Gripper::open(double t) {
  if (phase_ == GripperPhase::kOpen || phase_ == GripperPhase::kOpening) return;
  last_t_ = t;
  phase_ = GripperPhase::kOpening;
}

void Gripper::step(double t, int64_t utime, Scene& scene, const Placement& tool) {
  // No time passed, nothing happens (as in CartesianArm::step): a repeated
  // step at the same time must not move a held fruit or decide an outcome.
  if (t <= last_t_) return;
  const double dt = t - last_t_;
  last_t_ = t;
  auto& fruit = scene.fruit();
  if (phase_ == GripperPhase::kClosing) {
    opening_ = std::max(0.0, opening_ - dt / setup_.close_time_s);
    if (opening_ == 0.0) on_closed(utime, scene, tool);
  } else if (phase_ == GripperPhase::kOpening) {
    opening_ = std::min(1.0, opening_ + dt / setup_.open_time_s);
    if (held_ >= 0) {
      // Let go: a fruit still on its stem springs back, a picked one drops into the bin.
      Fruit& f = fruit[static_cast<std::size_t>(held_)];
      if (f.state == FruitState::kHeld) {
        f.state = FruitState::kOnTree;
        f.position = f.stem_position;
      }
      held_ = -1;
    }
    if (opening_ == 1.0) phase_ = GripperPhase::kOpen;
  }

  if (held_ >= 0) {
    Fruit& f = fruit[static_cast<std::size_t>(held_)];
    f.position = tool.position + tool.rotation * hold_offset_tool_;
    if (f.state == FruitState::kHeld && (f.position - f.stem_position).norm() > setup_.detach_distance) {
      f.state = FruitState::kPicked;
      f.outcome_utime = utime;
    }
  }

  // The palm (behind the fingers) pushes any fruit it runs into off the tree.
  const Vec3 palm = tool.position - setup_.palm_offset * tool.rotation.col(2);
  for (auto& f : fruit) {
    if (f.state == FruitState::kOnTree && (f.position - palm).norm() < 0.8 * f.radius) {
      f.state = FruitState::kKnocked;
      f.outcome_utime = utime;
    }
  }
}

void Gripper::on_closed(int64_t utime, Scene& scene, const Placement& tool) {
  auto& fruit = scene.fruit();
  int nearest = -1;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < fruit.size(); ++i) {
    if (fruit[i].state != FruitState::kOnTree) continue;
    const double d = (fruit[i].position - tool.position).norm();
    if (d < best) {
      best = d;
      nearest = static_cast<int>(i);
    }
  }
  phase_ = GripperPhase::kClosed;
  if (nearest < 0) return;
  Fruit& f = fruit[static_cast<std::size_t>(nearest)];
  const Vec3 offset = f.position - tool.position;
  const Vec3 local = tool.rotation.transpose() * offset;
  const double lateral = std::hypot(local.x(), local.y()), axial = local.z();
  // Nowhere near (beside the fingers, or in front of or behind them along the
  // approach axis): the gripper closed on nothing.
  if (lateral > setup_.knock_radius + f.radius || axial < setup_.capture_axial_min - f.radius ||
      axial > setup_.capture_axial_max + f.radius)
    return;
  ++f.grasp_attempts;
  f.grasp_offset = offset;
  if (lateral <= setup_.capture_radius && axial >= setup_.capture_axial_min && axial <= setup_.capture_axial_max) {
    f.state = FruitState::kHeld;
    held_ = nearest;
    hold_offset_tool_ = local;
    phase_ = GripperPhase::kHolding;
  } else if (lateral <= setup_.knock_radius) {
    f.state = FruitState::kKnocked;  // a finger caught it off centre
    f.outcome_utime = utime;
  }
}

}  // namespace harvest::sim
