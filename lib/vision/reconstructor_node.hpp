// The reconstructor node (docs/perception.md): fixed- and hand-camera
// detections with the robot state -> TARGETS, the fruit in the base frame.
#pragma once

#include <optional>

#include "config/config.hpp"
#include "harvest/targets_t.hpp"
#include "runtime/node.hpp"
#include "runtime/process_main.hpp"
#include "vision/reconstructor.hpp"

namespace harvest::vision {

class ReconstructorNode : public rt::Node {
 public:
  explicit ReconstructorNode(ReconstructorConfig config);

 protected:
  void on_attach() override;

 private:
  void publish_or_report(const std::optional<targets_t>& targets, const char* counter);
  Reconstructor reconstructor_;
};

// The node list of harvest-reconstructor.
rt::NodeList make_reconstructor(const config::Node& cfg, const rt::ProcessEnv& env);

}  // namespace harvest::vision
