#include "vision/box_evaluation.hpp"

#include <fstream>
#include <sstream>
#include <stdexcept>

namespace harvest::vision {

double iou(const BoxF& a, const BoxF& b) {
  const BoxF i{std::max(a.x1, b.x1), std::max(a.y1, b.y1), std::min(a.x2, b.x2), std::min(a.y2, b.y2)};
  const double inter = i.area();
  const double uni = a.area() + b.area() - inter;
  return uni > 0 ? inter / uni : 0.0;
}

std::vector<int> match_boxes(const std::vector<DetectionBox>& detections, const std::vector<BoxF>& boxes,
                             double min_iou) {
  struct Pair {
    double score;
    int det, box;
  };
  std::vector<Pair> pairs;
  for (std::size_t d = 0; d < detections.size(); ++d)
    for (std::size_t b = 0; b < boxes.size(); ++b) {
      const DetectionBox& x = detections[d];
      const BoxF& y = boxes[b];
      const bool inside = x.u >= y.x1 && x.u <= y.x2 && x.v >= y.y1 && x.v <= y.y2;
      const double overlap = iou(x.box, y);
      if (inside || overlap >= min_iou)
        pairs.push_back({(inside ? 1.0 : 0.0) + overlap, static_cast<int>(d), static_cast<int>(b)});
    }
  std::stable_sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.score > b.score; });
  std::vector<int> match(detections.size(), -1);
  std::vector<bool> taken(boxes.size(), false);
  for (const Pair& p : pairs) {
    if (match[static_cast<std::size_t>(p.det)] >= 0 || taken[static_cast<std::size_t>(p.box)]) continue;
    match[static_cast<std::size_t>(p.det)] = p.box;
    taken[static_cast<std::size_t>(p.box)] = true;
  }
  return match;
}

DetectionBox detection_box(const Fruit& f) {
  if (f.circle_fitted) {
    const double r = 0.5 * f.diameter_px;
    return {f.u, f.v, {f.u - r, f.v - r, f.u + r, f.v + r}};
  }
  return {f.u,
          f.v,
          {static_cast<double>(f.bbox.x), static_cast<double>(f.bbox.y), static_cast<double>(f.bbox.x + f.bbox.width),
           static_cast<double>(f.bbox.y + f.bbox.height)}};
}

EvalCounts score_matches(const std::vector<int>& match, const std::vector<BoxF>& boxes) {
  EvalCounts c;
  c.images = 1;
  for (const BoxF& b : boxes) c.boxes += b.visible >= kScoredVisible;
  for (int m : match) {
    if (m >= 0 && boxes[static_cast<std::size_t>(m)].visible < kScoredVisible) continue;
    ++c.detections;
    c.true_positives += m >= 0;
  }
  return c;
}

std::vector<std::pair<std::string, std::vector<BoxF>>> read_boxes_csv(const std::filesystem::path& csv) {
  std::ifstream in(csv);
  if (!in) throw std::runtime_error("cannot read " + csv.string());
  std::vector<std::pair<std::string, std::vector<BoxF>>> out;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || (number == 1 && line.rfind("image,", 0) == 0)) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) cells.push_back(cell);
    BoxF b{};
    try {
      if (cells.size() != 7 && cells.size() != 8) throw std::invalid_argument("columns");
      b = {std::stod(cells[3]), std::stod(cells[4]), std::stod(cells[5]), std::stod(cells[6])};
      if (cells.size() == 8) b.visible = std::stod(cells[7]);
      if (!(b.visible >= 0.0 && b.visible <= 1.0)) throw std::invalid_argument("visible");
    } catch (const std::exception&) {
      throw std::runtime_error(csv.string() + ":" + std::to_string(number) +
                               ": expected image,img_w,img_h,x1,y1,x2,y2[,visible in 0..1]");
    }
    if (out.empty() || out.back().first != cells[0]) {
      auto it = std::find_if(out.begin(), out.end(), [&](const auto& e) { return e.first == cells[0]; });
      if (it == out.end()) {
        out.emplace_back(cells[0], std::vector<BoxF>{});
        it = out.end() - 1;
      }
      it->second.push_back(b);
    } else {
      out.back().second.push_back(b);
    }
  }
  return out;
}

}  // namespace harvest::vision
