#include "endeffector/ir_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace harvest::endeffector {

IrCurve::IrCurve(std::vector<IrKnot> knots) : knots_(std::move(knots)) {
  if (knots_.size() < 2) throw std::invalid_argument("an IR curve needs at least 2 points");
  for (const auto& k : knots_) {
    if (!std::isfinite(k.raw) || !std::isfinite(k.distance_m) || k.distance_m <= 0)
      throw std::invalid_argument("IR curve point (" + std::to_string(k.raw) + ", " + std::to_string(k.distance_m) +
                                  "): needs finite raw and distance > 0");
  }
  std::sort(knots_.begin(), knots_.end(), [](const IrKnot& a, const IrKnot& b) { return a.raw < b.raw; });
  closer_with_higher_raw_ = knots_.back().distance_m < knots_.front().distance_m;
  for (std::size_t i = 1; i < knots_.size(); ++i) {
    if (knots_[i].raw == knots_[i - 1].raw)
      throw std::invalid_argument("IR curve: two points with raw " + std::to_string(knots_[i].raw));
    const bool falling = knots_[i].distance_m < knots_[i - 1].distance_m;
    if (falling != closer_with_higher_raw_ || knots_[i].distance_m == knots_[i - 1].distance_m)
      throw std::invalid_argument("IR curve: distance must be strictly monotone in raw (at raw " +
                                  std::to_string(knots_[i].raw) + ")");
  }
}

namespace {
constexpr config::Numbers kPointsRaw{.name = "points_raw",
                                     .doc = "raw readings of the calibration points, distinct",
                                     .required = true};
constexpr config::Numbers kPointsM{.name = "points_m", .unit = "m",
                                   .doc = "their distances, as many, strictly monotone in raw",
                                   .required = true};
}  // namespace

config::Section IrCurve::schema() {
  return config::section("ir_calibration",
                         "An IR calibration file (harvest-ir-calibrate writes it; the bridge's ir_calibration_file).",
                         kPointsRaw, kPointsM);
}

IrCurve IrCurve::from_config(const config::Node& node) {
  const auto raw = node.get(kPointsRaw);
  const auto dist = node.get(kPointsM);
  if (raw.size() != dist.size()) node.fail("points_m", "as many values as points_raw (" + std::to_string(raw.size()) + ")");
  std::vector<IrKnot> knots;
  for (std::size_t i = 0; i < raw.size(); ++i) knots.push_back({raw[i], dist[i]});
  try {
    return IrCurve(std::move(knots));
  } catch (const std::invalid_argument& e) {
    node.fail("points_raw", std::string("a valid calibration: ") + e.what());
  }
}

IrCurve IrCurve::default_curve() {
  // Knots of raw = 26000 / (range_mm + 4), the triangulating sensor of the
  // simulator (10-bit ADC), between its 30 mm peak and 350 mm horizon.
  std::vector<IrKnot> k;
  for (const double mm : {30.0, 35.0, 40.0, 50.0, 60.0, 80.0, 100.0, 130.0, 160.0, 200.0, 250.0, 300.0, 350.0})
    k.push_back({26000.0 / (mm + 4.0), mm * 1e-3});
  return IrCurve(std::move(k));
}

IrRange IrCurve::evaluate(double raw) const {
  const IrValidity below = closer_with_higher_raw_ ? IrValidity::kTooFar : IrValidity::kTooNear;
  const IrValidity above = closer_with_higher_raw_ ? IrValidity::kTooNear : IrValidity::kTooFar;
  if (raw < knots_.front().raw) return {knots_.front().distance_m, below};
  if (raw > knots_.back().raw) return {knots_.back().distance_m, above};
  const auto hi = std::lower_bound(knots_.begin(), knots_.end(), raw,
                                   [](const IrKnot& k, double r) { return k.raw < r; });
  if (hi == knots_.begin()) return {hi->distance_m, IrValidity::kValid};
  const auto lo = hi - 1;
  const double t = (raw - lo->raw) / (hi->raw - lo->raw);
  return {lo->distance_m + t * (hi->distance_m - lo->distance_m), IrValidity::kValid};
}

std::string IrCurve::to_yaml() const {
  std::ostringstream out;
  out.precision(6);
  out << "# IR proximity calibration: raw ADC counts -> distance [m], monotone piecewise-linear\n"
      << "# (docs/ir-calibration.md).\n";
  out << "points_raw: [";
  for (std::size_t i = 0; i < knots_.size(); ++i) out << (i ? ", " : "") << knots_[i].raw;
  out << "]\npoints_m: [";
  for (std::size_t i = 0; i < knots_.size(); ++i) out << (i ? ", " : "") << knots_[i].distance_m;
  out << "]\n";
  return out.str();
}

std::vector<IrCalSample> read_ir_csv(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file.string() + ": cannot open");
  std::vector<IrCalSample> out;
  std::string line;
  int number = 0;
  bool header_allowed = true;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto where = [&] { return file.string() + ":" + std::to_string(number) + ": "; };
    const auto comma = line.find(',');
    double raw = 0, dist = 0;
    bool ok = comma != std::string::npos && line.find(',', comma + 1) == std::string::npos;
    if (ok) {
      try {
        std::size_t used_a = 0, used_b = 0;
        const std::string a = line.substr(0, comma), b = line.substr(comma + 1);
        raw = std::stod(a, &used_a);
        dist = std::stod(b, &used_b);
        ok = a.find_first_not_of(" \t", used_a) == std::string::npos && b.find_first_not_of(" \t", used_b) == std::string::npos;
      } catch (const std::exception&) {
        ok = false;
      }
    }
    if (!ok) {
      if (header_allowed) {  // e.g. "raw,distance_m"
        header_allowed = false;
        continue;
      }
      throw std::runtime_error(where() + "expected 'raw,distance_m' (two numbers), got '" + line + "'");
    }
    header_allowed = false;
    if (!std::isfinite(raw) || raw < 0 || raw > 65535)
      throw std::runtime_error(where() + "raw must be in [0, 65535], got '" + line + "'");
    if (!std::isfinite(dist) || dist <= 0 || dist > 10)
      throw std::runtime_error(where() + "distance_m must be in (0, 10] metres, got '" + line + "'");
    out.push_back({raw, dist});
  }
  if (out.empty()) throw std::runtime_error(file.string() + ": no (raw, distance_m) rows");
  return out;
}

IrCurve fit_ir_curve(const std::vector<IrCalSample>& samples_in, int bins) {
  if (samples_in.size() < 2) throw std::invalid_argument("need at least 2 samples");
  if (bins < 2) throw std::invalid_argument("need at least 2 bins");
  std::vector<IrCalSample> s = samples_in;
  std::sort(s.begin(), s.end(), [](const IrCalSample& a, const IrCalSample& b) { return a.raw < b.raw; });

  // Equal-count bins on raw; samples with the same raw never straddle two bins.
  struct Block {
    double raw_sum = 0, dist_sum = 0;
    double n = 0;
    double raw() const { return raw_sum / n; }
    double dist() const { return dist_sum / n; }
  };
  std::vector<Block> blocks;
  const double per_bin = static_cast<double>(s.size()) / bins;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const bool same_raw = i > 0 && s[i].raw == s[i - 1].raw;
    if (blocks.empty() || (!same_raw && blocks.back().n >= per_bin - 1e-9)) blocks.push_back({});
    blocks.back().raw_sum += s[i].raw;
    blocks.back().dist_sum += s[i].distance_m;
    blocks.back().n += 1;
  }
  if (blocks.size() < 2) throw std::invalid_argument("all samples have the same raw value");

  // Direction from the correlation sign: a calibration must say which way the sensor goes.
  double mr = 0, md = 0;
  for (const auto& x : s) mr += x.raw, md += x.distance_m;
  mr /= s.size(), md /= s.size();
  double cov = 0;
  for (const auto& x : s) cov += (x.raw - mr) * (x.distance_m - md);
  if (cov == 0) throw std::invalid_argument("distance does not change with raw");
  const double sign = cov < 0 ? -1.0 : 1.0;  // distance rises with raw if +1

  // Pool adjacent violators on sign * distance (non-decreasing).
  std::vector<Block> pooled;
  for (const Block& b : blocks) {
    pooled.push_back(b);
    while (pooled.size() >= 2 && sign * pooled[pooled.size() - 2].dist() >= sign * pooled.back().dist()) {
      Block top = pooled.back();
      pooled.pop_back();
      pooled.back().raw_sum += top.raw_sum;
      pooled.back().dist_sum += top.dist_sum;
      pooled.back().n += top.n;
    }
  }
  if (pooled.size() < 2)
    throw std::invalid_argument("samples are not monotone enough to give 2 distinct calibration points");
  std::vector<IrKnot> knots;
  for (const Block& b : pooled) knots.push_back({b.raw(), b.dist()});
  return IrCurve(std::move(knots));
}

IrFitReport fit_report(const IrCurve& curve, const std::vector<IrCalSample>& samples) {
  IrFitReport r;
  double sq = 0;
  for (const auto& s : samples) {
    const IrRange e = curve.evaluate(s.raw);
    if (e.validity != IrValidity::kValid) continue;
    const double err = e.distance_m - s.distance_m;
    sq += err * err;
    r.max_abs_m = std::max(r.max_abs_m, std::abs(err));
    ++r.used;
  }
  r.rms_m = r.used ? std::sqrt(sq / r.used) : 0.0;
  return r;
}

}  // namespace harvest::endeffector
