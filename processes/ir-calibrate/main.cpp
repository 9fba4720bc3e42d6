// harvest-ir-calibrate: fit the IR curve (raw -> metres) from a CSV of
// (raw, distance_m) measurements and print it as YAML for
// config/endeffector/ir_calibration.yaml. See docs/ir-calibration.md.
#include <CLI/CLI.hpp>

#include <fstream>
#include <iostream>

#include "endeffector/ir_calibration.hpp"

int main(int argc, char** argv) {
  CLI::App app("Fit the IR proximity calibration curve from (raw, distance_m) CSV rows", "harvest-ir-calibrate");
  std::string csv, output;
  int bins = 24;
  app.add_option("csv", csv, "CSV file, one 'raw,distance_m' row per measurement")->required();
  app.add_option("--bins", bins, "number of calibration points to fit (before monotone pooling)")
      ->check(CLI::Range(2, 200));
  app.add_option("--output,-o", output, "write the YAML here instead of stdout");
  CLI11_PARSE(app, argc, argv);
  namespace ee = harvest::endeffector;
  try {
    const auto samples = ee::read_ir_csv(csv);
    const ee::IrCurve curve = ee::fit_ir_curve(samples, bins);
    const ee::IrFitReport report = ee::fit_report(curve, samples);
    std::string yaml = curve.to_yaml();
    yaml += "# fitted from " + std::to_string(samples.size()) + " rows of " + csv + "; residual RMS " +
            std::to_string(report.rms_m * 1000) + " mm, max " + std::to_string(report.max_abs_m * 1000) + " mm\n";
    if (output.empty()) {
      std::cout << yaml;
    } else {
      std::ofstream out(output);
      if (!(out << yaml)) throw std::runtime_error(output + ": cannot write");
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "harvest-ir-calibrate: " << e.what() << "\n";
    return 2;
  }
}
