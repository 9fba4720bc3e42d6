// harvest-calibrate: see lib/calib/calibrate_cli.hpp and docs/calibration.md.
#include <iostream>

#include "calib/calibrate_cli.hpp"

int main(int argc, char** argv) { return harvest::calib::calibrate_main(argc, argv, std::cout, std::cerr); }
