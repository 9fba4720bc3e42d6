// libFuzzer target: the configuration loader (lib/config) as every process
// uses it: the input's first line is a --set override (KEY.PATH=VALUE), the
// rest the YAML file. Every top-level key is read as each kind of value a
// component asks for (number, integer, flag, string, list, mapping, list of
// mappings), then the effective configuration is emitted and unused keys are
// checked. Properties, besides "no crash, no sanitizer report": bad input is
// a config::Error, never another exception; the emitted configuration loads
// again (--check-config's output is a valid configuration file).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "config/config.hpp"

namespace config = harvest::config;

namespace {

template <class F>
void tolerate(F f) {
  try {
    f();
  } catch (const config::Error&) {
  }
}

void read_all(const config::Node& n, int depth) {
  std::vector<std::string> keys;
  tolerate([&] { keys = n.keys(); });
  for (const auto& k : keys) {
    tolerate([&] { (void)n.get<double>(k, 0.0, {-1e9, 1e9}); });
    tolerate([&] { (void)n.get<int>(k, 0, {0, 100}); });
    tolerate([&] { (void)n.get<bool>(k, false); });
    tolerate([&] { (void)n.get<std::string>(k, ""); });
    tolerate([&] { (void)n.choice(k, "a", {"a", "b"}); });
    tolerate([&] { (void)n.numbers(k, 3); });
    if (depth < 4) {
      tolerate([&] { read_all(n.child(k), depth + 1); });
      tolerate([&] {
        for (const auto& c : n.children(k)) read_all(c, depth + 1);
      });
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  const std::string all(reinterpret_cast<const char*>(data), size);
  const auto nl = all.find('\n');
  const std::string override_line = nl == std::string::npos ? all : all.substr(0, nl);
  const std::string yaml = nl == std::string::npos ? "" : all.substr(nl + 1);
  std::string effective;
  try {
    config::Document doc = config::Document::load_string(yaml, "<fuzz>");
    tolerate([&] { doc.apply_override(override_line); });
    read_all(doc.root(), 0);
    effective = doc.emit();
    tolerate([&] { doc.check_unused(); });
  } catch (const config::Error&) {
    return 0;
  }
  // Uncaught if it fails: what we emit must load again.
  (void)config::Document::load_string(effective, "<effective>");
  return 0;
}
