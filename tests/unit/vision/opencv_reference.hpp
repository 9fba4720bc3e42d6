// The "obvious OpenCV pipeline" for the thesis detection core, used as the
// reference in tests (same mask, same regions) and as the benchmark baseline:
// cv::transform to CrCgCb, cv::inRange, cv::connectedComponentsWithStats.
// Coefficients and bounds are scaled by 1000 so float arithmetic is exact
// (all values stay below 2^24) and the mask equals the exact thesis test.
#pragma once

#include <opencv2/imgproc.hpp>

namespace harvest::vision::test {

struct OpenCvPipeline {
  cv::Mat3f f, t;
  cv::Mat1b mask;
  cv::Mat labels, stats, centroids;
  // Returns the number of labels including the background.
  int run(const cv::Mat3b& bgr) {
    static const cv::Matx33f m(-114, -587, 721,   // Cr from B, G, R
                               -114, 413, -299,   // Cg
                               886, -587, -299);  // Cb
    bgr.convertTo(f, CV_32F);
    cv::transform(f, t, m);
    cv::inRange(t, cv::Scalar(22000, -25000, -220000), cv::Scalar(90000, 25000, -5000), mask);
    return cv::connectedComponentsWithStats(mask, labels, stats, centroids, 4, CV_32S);
  }
};

}  // namespace harvest::vision::test
