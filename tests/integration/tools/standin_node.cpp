#include "standin_node.hpp"

#include <harvest/ir_range_t.hpp>

#include "runtime/channels.hpp"

namespace harvest::testing {

namespace {

class StandinNode final : public rt::Node {
 public:
  explicit StandinNode(const config::Node& cfg)
      : rt::Node("standin"),
        gain_(cfg.get<double>("gain", 1.0)),
        exit_after_s_(cfg.get<double>("exit_after_s", 0.0, {0.0, 3600.0})),
        exit_code_(cfg.get<int>("exit_code", 0, {0, 255})),
        output_(cfg.get<std::string>("output", "IR_SCALED")) {}

 private:
  void on_attach() override {
    advertise(output_);
    subscribe<harvest::ir_range_t>(channels::kIrRange, [this](const harvest::ir_range_t& in) {
      harvest::ir_range_t out = in;
      out.header.source_seq = in.header.seq;
      out.range_m = static_cast<float>(in.raw * gain_);
      publish(output_, out);
    });
    if (exit_after_s_ > 0) after(static_cast<rt::Micros>(exit_after_s_ * 1e6), [this] { ctx().request_stop(exit_code_); });
    set_health(rt::Health::kOk);
  }

  double gain_;
  double exit_after_s_;
  int exit_code_;
  std::string output_;
};

}  // namespace

rt::NodeList make_tools_standin(const config::Node& cfg, const rt::ProcessEnv&) {
  rt::NodeList nodes;
  nodes.push_back(std::make_unique<StandinNode>(cfg));
  return nodes;
}

}  // namespace harvest::testing
