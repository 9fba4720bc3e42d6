// A minimal real process for the runtime integration tests: the scale node
// of the unit tests behind rt::run_process, its gain from configuration.
#include "../../unit/runtime/test_nodes.hpp"
#include "runtime/process_main.hpp"

int main(int argc, char** argv) {
  return harvest::rt::run_process(argc, argv, "harvest-test-scale",
                                  [](const harvest::config::Node& cfg, const harvest::rt::ProcessEnv&) {
                                    const double gain = cfg.required<double>("gain", {-100.0, 100.0});
                                    const auto in = cfg.get<std::string>("input", "IN");
                                    const auto out = cfg.get<std::string>("output", "OUT");
                                    harvest::rt::NodeList nodes;
                                    nodes.push_back(std::make_unique<harvest::testing::ScaleNode>(in, out, gain, false));
                                    return nodes;
                                  });
}
