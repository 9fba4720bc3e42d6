// A printed ChArUco calibration board: the one description the calibration
// tool detects and the simulator draws (OpenCV 4.6's cv::aruco::CharucoBoard
// layout: origin at the top-left square corner of the print, x right, y down
// the print, z into the board).
#pragma once

#include <opencv2/aruco/charuco.hpp>
#include <string>
#include <vector>

namespace harvest::calib {

struct BoardSpec {
  int squares_x = 7, squares_y = 5;
  double square_m = 0.04, marker_m = 0.03;
  std::string dictionary = "DICT_5X5_100";  // an OpenCV predefined ArUco dictionary (board_dictionaries())
  double margin_m = 0.02;                   // white plate around the squares (the detector's quiet zone)
};

// OpenCV's board for a spec; throws std::invalid_argument on an impossible
// layout or an unknown dictionary.
cv::Ptr<cv::aruco::CharucoBoard> make_board(const BoardSpec& spec);
// The dictionary names make_board accepts.
const std::vector<std::string>& board_dictionaries();

}  // namespace harvest::calib
