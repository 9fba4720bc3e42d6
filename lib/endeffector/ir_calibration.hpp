// IR proximity calibration: raw ADC counts -> distance [m].
//
// The curve is the monotone piecewise-linear interpolant through calibration
// knots (docs/ir-calibration.md explains the choice). Readings outside the
// knots' raw range are clamped to the nearest end and flagged TOO_NEAR or
// TOO_FAR, whichever that end is. fit_ir_curve() builds knots from noisy
// (raw, distance) samples: quantile bins, then isotonic regression.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "config/schema.hpp"

namespace harvest::endeffector {

struct IrKnot {
  double raw = 0;
  double distance_m = 0;
};

enum class IrValidity : int8_t { kValid = 0, kTooNear = 1, kTooFar = 2 };  // = ir_range_t constants

struct IrRange {
  double distance_m = 0;
  IrValidity validity = IrValidity::kValid;
};

class IrCurve {
 public:
  // Knots in any order; needs >= 2, distinct raw values and distance strictly
  // monotone in raw. Throws std::invalid_argument saying what is wrong.
  explicit IrCurve(std::vector<IrKnot> knots);

  // `points_raw` and `points_m`, two lists of the same length.
  static IrCurve from_config(const config::Node& node);
  static config::Section schema();
  // The curve used when no calibration is configured (matches the simulator's sensor, see docs).
  static IrCurve default_curve();

  IrRange evaluate(double raw) const;
  const std::vector<IrKnot>& knots() const { return knots_; }  // sorted by raw
  // YAML with points_raw / points_m, as from_config reads it.
  std::string to_yaml() const;

 private:
  std::vector<IrKnot> knots_;
  bool closer_with_higher_raw_ = true;
};

struct IrCalSample {
  double raw = 0;
  double distance_m = 0;
};

// Reads "raw,distance_m" lines; '#' comments, blank lines and one header line
// are allowed. Throws std::runtime_error naming the file and line on bad input.
std::vector<IrCalSample> read_ir_csv(const std::filesystem::path& file);

// Fits knots to samples: sort by raw, average into up to `bins` equal-count
// bins, enforce monotonicity with pool-adjacent-violators (direction from the
// sign of the correlation), merge equal neighbours. Throws
// std::invalid_argument if the data cannot give a curve.
IrCurve fit_ir_curve(const std::vector<IrCalSample>& samples, int bins = 24);

// How well a curve explains samples (within its raw range).
struct IrFitReport {
  double rms_m = 0;
  double max_abs_m = 0;
  int used = 0;  // samples inside the curve's raw range
};
IrFitReport fit_report(const IrCurve& curve, const std::vector<IrCalSample>& samples);

}  // namespace harvest::endeffector
