#include "vision/reconstructor_node.hpp"

#include "runtime/channels.hpp"

namespace harvest::vision {

ReconstructorNode::ReconstructorNode(ReconstructorConfig config)
    : rt::Node("reconstructor"), reconstructor_(std::move(config)) {}

void ReconstructorNode::on_attach() {
  advertise(channels::kTargets);
  subscribe<robot_state_t>(channels::kRobotState, [this](const robot_state_t& m) { reconstructor_.on_robot_state(m); });
  subscribe<harvest_status_t>(channels::kHarvestStatus,
                              [this](const harvest_status_t& m) { reconstructor_.on_harvest_status(m); });
  subscribe<fruit_detections_t>(channels::kFruitFixed, [this](const fruit_detections_t& m) {
    publish_or_report(reconstructor_.on_fixed(m), "fixed_rejected");
  });
  subscribe<fruit_detections_t>(channels::kFruitHand, [this](const fruit_detections_t& m) {
    publish_or_report(reconstructor_.on_hand(m), "hand_rejected");
  });
  set_health(rt::Health::kOk);
}

void ReconstructorNode::publish_or_report(const std::optional<targets_t>& targets, const char* counter) {
  if (!targets) {
    count(counter);
    set_health(rt::Health::kDegraded, reconstructor_.last_error());
    return;
  }
  targets_t out = *targets;
  publish(channels::kTargets, out);
  count("targets", out.num_targets);
  if (health() != rt::Health::kOk) set_health(rt::Health::kOk);
}

rt::NodeList make_reconstructor(const config::Node& cfg, const rt::ProcessEnv&) {
  rt::NodeList nodes;
  nodes.push_back(std::make_unique<ReconstructorNode>(ReconstructorConfig::from_yaml(cfg)));
  return nodes;
}

}  // namespace harvest::vision
