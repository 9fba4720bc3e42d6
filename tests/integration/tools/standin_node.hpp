// A small stand-in process for the tooling tests, so they do not depend on
// other components: it scales IR_RANGE.raw by a configured gain into
// IR_SCALED (a node whose behaviour a test can change through configuration)
// and can exit by itself after a while with a chosen code.
#pragma once

#include "config/config.hpp"
#include "runtime/process_main.hpp"

namespace harvest::testing {

rt::NodeList make_tools_standin(const config::Node& cfg, const rt::ProcessEnv& env);

}  // namespace harvest::testing
