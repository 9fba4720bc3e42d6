// libFuzzer target: the configuration loader (lib/config) as every process
// uses it: the input's first line is a --set override (KEY.PATH=VALUE), the
// rest the YAML file. Every key is read as one kind of value a component asks
// for (number, integer, flag, string, choice, list, mapping, list of
// mappings; see read_all), maps and lists walked to depth 4, then the effective configuration is emitted and unused
// keys are checked. Properties, besides "no crash, no sanitizer report": bad input is a config::Error, never another
// exception; the emitted configuration loads again (--check-config's output is a valid configuration file).
#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <functional>
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

// Each key is read as one kind of value (a component reads a key one way),
// the kind chosen by the key and by `salt` (the override line's length), so
// the fuzzer reaches every kind on every key by mutating either; a failed read
// costs an exception, and reading every key every way made this target 6x
// slower for no more coverage. Maps and lists are walked as components walk
// them.
void read_all(const config::Node& n, int depth, std::size_t salt) {
  std::vector<std::string> keys;
  tolerate([&] { keys = n.keys(); });
  for (const auto& k : keys) {
    switch ((std::hash<std::string>{}(k) + salt) % 8) {
      case 0:
        tolerate([&] { (void)n.get<double>(k, 0.0, {-1e9, 1e9}); });
        break;
      case 1:
        tolerate([&] { (void)n.get<int>(k, 0, {0, 100}); });
        break;
      case 2:
        tolerate([&] { (void)n.get<bool>(k, false); });
        break;
      case 3:
        tolerate([&] { (void)n.get<std::string>(k, ""); });
        break;
      case 4:
        tolerate([&] { (void)n.choice(k, "a", {"a", "b"}); });
        break;
      case 5:
        tolerate([&] { (void)n.numbers(k, 3); });
        break;
      case 6:
        tolerate([&] { (void)n.child(k); });
        break;  // on a scalar or list: an error
      default:
        tolerate([&] { (void)n.children(k); });
        break;  // on a scalar or map: an error
    }
    if (depth >= 4) continue;
    YAML::Node v;
    try {
      v = n.yaml()[k];
    } catch (const YAML::Exception&) {  // the harness's own look, not the loader's
    }
    if (v.IsMap()) tolerate([&] { read_all(n.child(k), depth + 1, salt); });
    if (v.IsSequence())
      tolerate([&] {
        for (const auto& c : n.children(k)) read_all(c, depth + 1, salt);
      });
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
    read_all(doc.root(), 0, override_line.size());
    effective = doc.emit();
    tolerate([&] { doc.check_unused(); });
  } catch (const config::Error&) {
    return 0;
  }
  // Uncaught if it fails: what we emit must load again.
  (void)config::Document::load_string(effective, "<effective>");
  return 0;
}
