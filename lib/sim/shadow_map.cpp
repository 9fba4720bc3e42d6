#include "sim/shadow_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace harvest::sim {

void ShadowMap::update(const Scene& scene, int cells) {
  const Eigen::Vector3d sun = scene.lighting().sun_direction.normalized();
  if (&scene == scene_ && scene.leaves().size() == leaves_ && scene.beads().size() == beads_ && sun == sun_ &&
      cells == n_)
    return;
  scene_ = &scene;
  leaves_ = scene.leaves().size();
  beads_ = scene.beads().size();
  sun_ = sun;
  build(scene, cells);
}

void ShadowMap::build(const Scene& scene, int cells) {
  const Eigen::Vector3d s = sun_;
  const Eigen::Vector3d a = (std::abs(s.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY()).cross(s).normalized();
  const Eigen::Vector3d b = s.cross(a);
  a_ = a.cast<float>();
  b_ = b.cast<float>();
  s_ = s.cast<float>();
  n_ = cells;
  top_.assign(static_cast<std::size_t>(n_) * n_, -std::numeric_limits<float>::infinity());

  // Extent of everything that casts or receives a shadow, across the sun.
  double u0 = 1e30, u1 = -1e30, v0 = 1e30, v1 = -1e30;
  auto extend = [&](const Eigen::Vector3d& p, double r) {
    u0 = std::min(u0, p.dot(a) - r), u1 = std::max(u1, p.dot(a) + r);
    v0 = std::min(v0, p.dot(b) - r), v1 = std::max(v1, p.dot(b) + r);
  };
  for (const auto& l : scene.leaves()) extend(l.centre, l.half_length);
  for (const auto& bd : scene.beads()) extend(bd.centre, bd.radius);
  for (const auto& f : scene.fruit()) extend(f.stem_position, f.radius + 0.05);
  if (u0 > u1) {  // nothing at all
    u0 = v0 = -1, u1 = v1 = 1;
  }
  const double cell = std::max(u1 - u0, v1 - v0) / (n_ - 2);
  cell_ = static_cast<float>(cell);
  inv_cell_ = static_cast<float>(1.0 / cell);
  u0_ = static_cast<float>(u0 - cell);
  v0_ = static_cast<float>(v0 - cell);

  auto cell_range = [&](double lo, double hi, float origin, int& i0, int& i1) {
    i0 = std::max(0, static_cast<int>(std::floor((lo - origin) / cell)));
    i1 = std::min(n_ - 1, static_cast<int>(std::ceil((hi - origin) / cell)));
  };
  auto raise = [&](int i, int j, float w) {
    float& t = top_[static_cast<std::size_t>(j) * n_ + i];
    t = std::max(t, w);
  };
  for (const auto& l : scene.leaves()) {
    const double ns = l.normal.dot(s);
    if (std::abs(ns) < 1e-3) continue;  // edge-on to the sun: no area
    const double hl = l.half_length, hw = l.half_width;
    const double cu = l.centre.dot(a), cv = l.centre.dot(b);
    const double ru = std::abs(l.u.dot(a)) * hl + std::abs(l.v.dot(a)) * hw;
    const double rv = std::abs(l.u.dot(b)) * hl + std::abs(l.v.dot(b)) * hw;
    int i0, i1, j0, j1;
    cell_range(cu - ru, cu + ru, u0_, i0, i1);
    cell_range(cv - rv, cv + rv, v0_, j0, j1);
    const double nc = l.normal.dot(l.centre), na = l.normal.dot(a), nb = l.normal.dot(b);
    for (int j = j0; j <= j1; ++j) {
      const double v = v0_ + (j + 0.5) * cell;
      for (int i = i0; i <= i1; ++i) {
        const double u = u0_ + (i + 0.5) * cell;
        const double w = (nc - u * na - v * nb) / ns;  // where the sun ray through the cell meets the blade plane
        const Eigen::Vector3d q = u * a + v * b + w * s - l.centre;
        const double qu = q.dot(l.u) / hl;
        if (qu < -1.0 || qu > 1.0 || std::abs(q.dot(l.v)) > hw * (1.0 - qu * qu)) continue;
        raise(i, j, static_cast<float>(w));
      }
    }
  }
  for (const auto& bd : scene.beads()) {
    const double cu = bd.centre.dot(a), cv = bd.centre.dot(b), cw = bd.centre.dot(s), r = bd.radius;
    int i0, i1, j0, j1;
    cell_range(cu - r, cu + r, u0_, i0, i1);
    cell_range(cv - r, cv + r, v0_, j0, j1);
    for (int j = j0; j <= j1; ++j) {
      const double dv = v0_ + (j + 0.5) * cell - cv;
      for (int i = i0; i <= i1; ++i) {
        const double du = u0_ + (i + 0.5) * cell - cu;
        const double h2 = r * r - du * du - dv * dv;
        if (h2 >= 0) raise(i, j, static_cast<float>(cw + std::sqrt(h2)));
      }
    }
  }
}

float ShadowMap::sunlit(const Eigen::Vector3f& p, float cos_sun) const {
  return lookup(p.dot(a_), p.dot(b_), p.dot(s_), cos_sun);
}

ShadowMap::View ShadowMap::view(const Eigen::Matrix3f& rotation, const Eigen::Vector3f& position) const {
  View v;
  v.map_ = this;
  v.a_ = rotation.transpose() * a_;
  v.b_ = rotation.transpose() * b_;
  v.s_ = rotation.transpose() * s_;
  v.au_ = position.dot(a_);
  v.bv_ = position.dot(b_);
  v.sw_ = position.dot(s_);
  return v;
}

float ShadowMap::View::sunlit(const Eigen::Vector3f& p, float cos_sun) const {
  return map_->lookup(p.dot(a_) + au_, p.dot(b_) + bv_, p.dot(s_) + sw_, cos_sun);
}

float ShadowMap::lookup(float u, float v, float w, float cos_sun) const {
  if (n_ == 0) return 1.0f;
  // Cell centres at (i + 0.5) cells; the outermost ring of cells is empty.
  const float gu = std::clamp((u - u0_) * inv_cell_ - 0.5f, 0.0f, static_cast<float>(n_ - 2));
  const float gv = std::clamp((v - v0_) * inv_cell_ - 0.5f, 0.0f, static_cast<float>(n_ - 2));
  // Slope-scaled bias: a surface tilted to the sun spans more height per cell.
  const float c = std::clamp(std::abs(cos_sun), 0.3f, 1.0f);
  const float bias = 0.004f + 1.5f * cell_ * std::sqrt(1.0f - c * c) / c;
  const int i = static_cast<int>(gu), j = static_cast<int>(gv);
  const float fu = gu - static_cast<float>(i), fv = gv - static_cast<float>(j);
  const float* row = top_.data() + static_cast<std::size_t>(j) * n_ + i;
  const float wb = w + bias;
  const float l00 = wb >= row[0] ? 1.0f : 0.0f, l10 = wb >= row[1] ? 1.0f : 0.0f;
  const float l01 = wb >= row[n_] ? 1.0f : 0.0f, l11 = wb >= row[n_ + 1] ? 1.0f : 0.0f;
  const float t = l00 + (l10 - l00) * fu, b = l01 + (l11 - l01) * fu;
  return t + (b - t) * fv;
}

}  // namespace harvest::sim
