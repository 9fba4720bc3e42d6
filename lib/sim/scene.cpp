#include "sim/scene.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace harvest::sim {
namespace {

double uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

Vec3 uniform_in(std::mt19937_64& rng, const Box& b) {
  return Vec3(uniform(rng, b.min.x(), b.max.x()), uniform(rng, b.min.y(), b.max.y()),
              uniform(rng, b.min.z(), b.max.z()));
}

Vec3 unit_vector(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec3 v(n(rng), n(rng), n(rng));
  return v.norm() < 1e-9 ? Vec3::UnitZ() : v.normalized();
}

// Truncated normal by rejection (the spread is small next to the bounds).
double fruit_diameter(std::mt19937_64& rng, const SizeDistribution& d) {
  std::normal_distribution<double> n(d.mean, d.std);
  for (int i = 0; i < 100; ++i) {
    const double x = n(rng);
    if (x >= d.min && x <= d.max) return x;
  }
  return std::clamp(d.mean, d.min, d.max);
}

// Orange peel colours that the thesis colour thresholds (eq. 2-1) accept
// over the whole range of shading the renderer produces.
Vec3 peel_colour(std::mt19937_64& rng) { return Vec3(uniform(rng, 200, 215), uniform(rng, 118, 138), uniform(rng, 22, 45)); }

}  // namespace

Placement start_tool_pose(const ArmSetup& arm) {
  return {look_at_rotation(arm.start_tool_position, arm.start_look_at), arm.start_tool_position};
}

Mat3 look_at_rotation(const Vec3& from, const Vec3& to) {
  const Vec3 z = (to - from).normalized();
  Vec3 y = Vec3::UnitX() - Vec3::UnitX().dot(z) * z;
  if (y.norm() < 1e-6) y = Vec3::UnitY() - Vec3::UnitY().dot(z) * z;
  y.normalize();
  Mat3 r;
  r.col(0) = y.cross(z);
  r.col(1) = y;
  r.col(2) = z;
  return r;
}

Scene::Scene(const Scenario& s) : lighting_(s.lighting), wind_(s.wind) {
  std::mt19937_64 rng(s.seed);
  place_fruit(s, rng);
  grow_branches(s, rng);
  grow_leaves(s, rng);
  // Gust times from their own stream: a scene with gusts has the same tree as without.
  if (wind_.amplitude > 0.0 && wind_.gust_factor > 1.0 && wind_.gust_rate_hz > 0.0) {
    std::mt19937_64 gusts(s.seed ^ 0x9e3779b97f4a7c15ULL);
    std::exponential_distribution<double> gap(wind_.gust_rate_hz);
    for (double t = gap(gusts); t < s.time_limit_s; t += gap(gusts)) gust_starts_.push_back(t);
  }
}

void Scene::place_fruit(const Scenario& s, std::mt19937_64& rng) {
  auto add = [&](const Vec3& p, double diameter) {
    Fruit f;
    f.id = static_cast<int>(fruit_.size());
    f.stem_position = f.position = p;
    f.radius = 0.5 * (diameter > 0.0 ? diameter : fruit_diameter(rng, s.fruit_size));
    f.albedo_rgb = peel_colour(rng);
    f.sway_direction = unit_vector(rng);
    f.sway_phase = uniform(rng, 0.0, 2.0 * std::numbers::pi);
    f.reachable = p.norm() <= s.arm.reach;
    fruit_.push_back(f);
  };
  for (const auto& spec : s.fruit) add(spec.position, spec.diameter);
  // Random fruit keep their distance from each other; give up on a fruit
  // after a fixed number of tries so a crowded box cannot loop forever.
  for (int i = 0; i < s.random_fruit.count; ++i) {
    for (int attempt = 0; attempt < 200; ++attempt) {
      const Vec3 p = uniform_in(rng, s.random_fruit.region);
      const bool clear = std::all_of(fruit_.begin(), fruit_.end(), [&](const Fruit& f) {
        return (f.stem_position - p).norm() >= s.random_fruit.min_separation;
      });
      if (clear) {
        add(p, 0.0);
        break;
      }
    }
  }
}

void Scene::grow_branches(const Scenario& s, std::mt19937_64& rng) {
  if (s.canopy.branches == 0 || fruit_.empty()) return;
  for (int b = 0; b < s.canopy.branches; ++b) {
    // Each branch runs from the trunk to just above (base -x) a fruit.
    const Fruit& f = fruit_[static_cast<std::size_t>(b) % fruit_.size()];
    const Vec3 tip = f.stem_position - Vec3::UnitX() * (f.radius + 0.02);
    const Vec3 bend = 0.5 * (tip + s.canopy.trunk_base) + 0.1 * unit_vector(rng);
    const double length = (bend - s.canopy.trunk_base).norm() + (tip - bend).norm();
    const int n = std::max(2, static_cast<int>(length / (0.9 * s.canopy.branch_radius)));
    for (int i = 0; i <= n; ++i) {
      const double t = static_cast<double>(i) / n;
      // Quadratic Bezier through the bend, tapering towards the tip.
      const Vec3 p = (1 - t) * (1 - t) * s.canopy.trunk_base + 2 * (1 - t) * t * bend + t * t * tip;
      beads_.push_back({p, s.canopy.branch_radius * (1.0 - 0.6 * t)});
    }
  }
}

void Scene::grow_leaves(const Scenario& s, std::mt19937_64& rng) {
  const auto& c = s.canopy;
  for (const auto& p : c.placed_leaves) {
    Leaf leaf;
    leaf.centre = p.centre;
    leaf.normal = (p.facing - p.centre).normalized();
    const Vec3 any = std::abs(leaf.normal.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    leaf.u = leaf.normal.cross(any).normalized();
    leaf.v = leaf.normal.cross(leaf.u);
    leaf.half_length = 0.5 * p.length;
    leaf.half_width = 0.5 * p.width;
    leaf.albedo_rgb = Vec3(c.leaf_colours_rgb[0][0], c.leaf_colours_rgb[0][1], c.leaf_colours_rgb[0][2]);
    leaves_.push_back(leaf);
  }
  const auto& greens = c.leaf_colours_rgb;
  for (int i = 0; i < c.leaves; ++i) {
    for (int attempt = 0; attempt < 50; ++attempt) {
      Leaf leaf;
      leaf.centre = uniform_in(rng, c.region);
      leaf.half_length = 0.5 * uniform(rng, c.leaf_length_min, c.leaf_length_max);
      leaf.half_width = leaf.half_length * c.leaf_width_ratio;
      const bool clear = std::all_of(fruit_.begin(), fruit_.end(), [&](const Fruit& f) {
        return (f.stem_position - leaf.centre).norm() >= f.radius + c.fruit_clearance + leaf.half_length;
      });
      if (!clear) continue;
      leaf.normal = unit_vector(rng);
      const Vec3 any = std::abs(leaf.normal.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
      leaf.u = leaf.normal.cross(any).normalized();
      leaf.v = leaf.normal.cross(leaf.u);
      const auto& g = greens[std::uniform_int_distribution<std::size_t>(0, greens.size() - 1)(rng)];
      leaf.albedo_rgb = Vec3(g[0], g[1], g[2]) * uniform(rng, 0.85, 1.15);
      leaves_.push_back(leaf);
      break;
    }
  }
}

double Scene::gust_gain(double t) const {
  double gain = 1.0;
  // Overlapping gusts: the stronger one counts.
  for (auto it = std::upper_bound(gust_starts_.begin(), gust_starts_.end(), t);
       it != gust_starts_.begin() && t - *(it - 1) < wind_.gust_duration_s; --it) {
    const double phase = (t - *(it - 1)) / wind_.gust_duration_s;
    gain = std::max(gain, 1.0 + (wind_.gust_factor - 1.0) * 0.5 * (1.0 - std::cos(2.0 * std::numbers::pi * phase)));
  }
  return gain;
}

void Scene::apply_wind(double t) {
  if (wind_.amplitude <= 0.0) return;
  const double amplitude = wind_.amplitude * gust_gain(t);
  for (auto& f : fruit_) {
    if (f.state != FruitState::kOnTree) continue;
    const double s = std::sin(2.0 * std::numbers::pi * wind_.frequency_hz * t + f.sway_phase);
    f.position = f.stem_position + amplitude * s * f.sway_direction;
  }
}

}  // namespace harvest::sim
