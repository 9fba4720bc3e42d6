#include "servo/harvest/sway.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace harvest::servo {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;
// The scan for the best moment to close [s].
constexpr double kScanStep = 0.01;

}  // namespace

Eigen::Vector3d SwayFit::at(double t) const {
  const double w = kTwoPi * frequency_hz * (t - t_ref);
  return centre + cos_part * std::cos(w) + sin_part * std::sin(w);
}

void SwayEstimator::add(double t, const Eigen::Vector3d& position) {
  if (!samples_.empty() && t <= samples_.back().first) return;  // the same image again, or out of order
  samples_.emplace_back(t, position);
  while (samples_.front().first < t - p_.window) samples_.pop_front();
}

double SwayEstimator::spread() const {
  if (samples_.empty()) return 0.0;
  return spread_since(samples_.front().first).value_or(0.0);
}

std::optional<double> SwayEstimator::spread_since(double t) const {
  const auto first =
      std::lower_bound(samples_.begin(), samples_.end(), t, [](const auto& s, double time) { return s.first < time; });
  const auto n = std::distance(first, samples_.end());
  if (n < p_.min_samples) return std::nullopt;  // min_samples >= 5 (its key's range)
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (auto it = first; it != samples_.end(); ++it) mean += it->second;
  mean /= static_cast<double>(n);
  double ss = 0.0;
  for (auto it = first; it != samples_.end(); ++it) ss += (it->second - mean).squaredNorm();
  return std::sqrt(ss / static_cast<double>(n));
}

int SwayEstimator::grid_size() const {
  return static_cast<int>(std::floor((p_.max_frequency_hz - p_.min_frequency_hz) / p_.frequency_step_hz + 1e-9)) + 1;
}

std::optional<double> SwayEstimator::learned_hz() const {
  // The least mean unexplained share among the frequencies learn_fruit fruit were seen long enough for.
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < unexplained_.size(); ++i) {
    if (fruit_seen_[i] < p_.learn_fruit) continue;
    if (!best || unexplained_[i] / fruit_seen_[i] < unexplained_[*best] / fruit_seen_[*best]) best = i;
  }
  return best ? std::optional<double>(grid_hz(static_cast<int>(*best))) : std::nullopt;
}

void SwayEstimator::reset() {
  // The fruit's own fit (not one at the learned frequency) says whether it moved: a sway of a plausible size,
  // however poorly fitted (its fit at the right frequency is what the sum is after).
  ignore_learned_ = true;
  const SwayFit own = fit();
  ignore_learned_ = false;
  if (own.samples >= p_.min_samples && own.span_s >= p_.min_span && own.amplitude >= p_.min_amplitude &&
      own.amplitude <= p_.max_amplitude) {
    unexplained_.resize(static_cast<std::size_t>(grid_size()), 0.0);
    fruit_seen_.resize(unexplained_.size(), 0);
    for (int i = 0; i < grid_size(); ++i) {
      const double hz = grid_hz(i);
      if (own.span_s * hz < p_.min_periods_seen) continue;  // too short a look to tell this frequency from a drift
      unexplained_[static_cast<std::size_t>(i)] += 1.0 - fit_at(hz).confidence;
      ++fruit_seen_[static_cast<std::size_t>(i)];
    }
  }
  samples_.clear();
}

SwayFit SwayEstimator::fit_at(double hz) const {
  const auto n = static_cast<Eigen::Index>(samples_.size());
  SwayFit f;
  f.frequency_hz = hz;
  f.samples = static_cast<int>(n);
  f.t_ref = samples_.back().first;
  f.span_s = f.t_ref - samples_.front().first;
  Eigen::MatrixXd a(n, 4), y(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& [t, p] = samples_[static_cast<std::size_t>(i)];
    const double dt = t - f.t_ref, w = kTwoPi * hz * dt;
    a.row(i) << 1.0, dt, std::cos(w), std::sin(w);
    y.row(i) = p.transpose();
  }
  const Eigen::MatrixXd x = a.colPivHouseholderQr().solve(y);  // 4 x 3
  const double ss_res = (a * x - y).squaredNorm();
  // The variance about the drift alone: what the sinusoid has to explain.
  const Eigen::MatrixXd trend = a.leftCols(2);
  const double ss_trend = (trend * trend.colPivHouseholderQr().solve(y) - y).squaredNorm();
  f.centre = x.row(0).transpose();
  f.drift = x.row(1).transpose();
  f.cos_part = x.row(2).transpose();
  f.sin_part = x.row(3).transpose();
  f.amplitude = std::sqrt(f.cos_part.squaredNorm() + f.sin_part.squaredNorm());
  f.rms_residual = std::sqrt(ss_res / static_cast<double>(n));
  f.confidence = ss_trend > 1e-12 ? std::clamp(1.0 - ss_res / ss_trend, 0.0, 1.0) : 0.0;
  // p = centre + u A sin(w dt + phase): cos_part = u A sin(phase), sin_part = u A cos(phase).
  const Eigen::Vector3d u = (f.cos_part.norm() > f.sin_part.norm() ? f.cos_part : f.sin_part).normalized();
  f.phase = f.amplitude > 0.0 ? std::atan2(u.dot(f.cos_part), u.dot(f.sin_part)) : 0.0;
  return f;
}

SwayFit SwayEstimator::fit() const {
  SwayFit still;
  still.samples = size();
  if (samples_.empty()) return still;
  still.t_ref = samples_.back().first;
  still.span_s = still.t_ref - samples_.front().first;
  if (still.samples < p_.min_samples || still.span_s < p_.min_span) return still;
  std::optional<SwayFit> best;
  if (const auto hz = ignore_learned_ ? std::nullopt : learned_hz()) {
    best = fit_at(*hz);
    best->learned_frequency = true;
  } else {
    for (int i = 0; i < grid_size(); ++i) {
      if (still.span_s * grid_hz(i) < p_.min_periods_seen) continue;
      SwayFit f = fit_at(grid_hz(i));
      if (!best || f.rms_residual < best->rms_residual) best = f;
    }
  }
  if (!best) return still;
  best->swaying = best->amplitude >= p_.min_amplitude && best->amplitude <= p_.max_amplitude &&
                  best->confidence >= p_.min_confidence;
  return *best;
}

CloseDecision close_decision(const SwayFit& fit, const Eigen::Isometry3d& tool, double now_s, double waited_s,
                             double step_s, const ServoConfig::Sway& p) {
  CloseDecision d;
  if (!fit.swaying) return d;  // still: close at once, as without wind
  const Eigen::Isometry3d tool_inv = tool.inverse();
  // The IR reads the fruit inside and the approach centred on its middle: a sway centred far off the axis is a
  // fit gone wrong.
  if ((tool_inv * fit.centre).head<2>().norm() > p.max_centre_offset) return d;
  auto off_axis = [&](double t) { return (tool_inv * fit.at(t + p.close_delay)).head<2>().norm(); };
  d.offset = d.best_offset = off_axis(now_s);
  const double horizon = std::min(p.max_wait - waited_s, 1.0 / fit.frequency_hz);
  for (double tau = kScanStep; tau <= horizon + 1e-9; tau += kScanStep) {
    const double o = off_axis(now_s + tau);
    if (o < d.best_offset) {
      d.best_offset = o;
      d.best_wait = tau;
    }
  }
  // Near enough now, or now (within one control step) is the nearest it will come.
  d.close = d.offset <= p.close_tolerance || d.best_wait < step_s || waited_s >= p.max_wait;
  return d;
}

}  // namespace harvest::servo
