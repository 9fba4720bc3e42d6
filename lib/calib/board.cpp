#include "calib/board.hpp"

#include <stdexcept>

namespace harvest::calib {
namespace {

const std::vector<std::pair<std::string, cv::aruco::PREDEFINED_DICTIONARY_NAME>>& dictionary_table() {
  using namespace cv::aruco;
  static const std::vector<std::pair<std::string, PREDEFINED_DICTIONARY_NAME>> t{
      {"DICT_4X4_50", DICT_4X4_50}, {"DICT_4X4_100", DICT_4X4_100}, {"DICT_4X4_250", DICT_4X4_250},
      {"DICT_5X5_50", DICT_5X5_50}, {"DICT_5X5_100", DICT_5X5_100}, {"DICT_5X5_250", DICT_5X5_250},
      {"DICT_6X6_50", DICT_6X6_50}, {"DICT_6X6_100", DICT_6X6_100}, {"DICT_6X6_250", DICT_6X6_250}};
  return t;
}

}  // namespace

const std::vector<std::string>& board_dictionaries() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& [name, id] : dictionary_table()) n.push_back(name);
    return n;
  }();
  return names;
}

cv::Ptr<cv::aruco::CharucoBoard> make_board(const BoardSpec& spec) {
  if (spec.squares_x < 3 || spec.squares_y < 3) throw std::invalid_argument("board: at least 3 x 3 squares");
  if (!(spec.square_m > 0.0) || !(spec.marker_m > 0.0) || spec.marker_m >= spec.square_m)
    throw std::invalid_argument("board: need 0 < marker_m < square_m");
  if (!(spec.margin_m >= 0.0)) throw std::invalid_argument("board: margin_m must be >= 0");
  for (const auto& [name, id] : dictionary_table())
    if (name == spec.dictionary) {
      const auto dict = cv::aruco::getPredefinedDictionary(id);
      if (dict->bytesList.rows < (spec.squares_x * spec.squares_y) / 2)
        throw std::invalid_argument("board: " + name + " has too few markers for " + std::to_string(spec.squares_x) +
                                    " x " + std::to_string(spec.squares_y) + " squares");
      return cv::aruco::CharucoBoard::create(spec.squares_x, spec.squares_y, static_cast<float>(spec.square_m),
                                             static_cast<float>(spec.marker_m), dict);
    }
  throw std::invalid_argument("board: unknown dictionary '" + spec.dictionary + "'");
}

}  // namespace harvest::calib
