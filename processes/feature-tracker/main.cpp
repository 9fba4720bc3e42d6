// harvest-feature-tracker: CAMERA_HAND (+ CAMERA_FIXED_ZOOM, FRUIT_HAND) ->
// FEATURES_HAND, FEATURE_MATCHES (docs/feature-tracker.md).
#include "features/nodes.hpp"

int main(int argc, char** argv) {
  return harvest::rt::run_process(argc, argv, "feature-tracker", harvest::features::make_feature_tracker);
}
