#include "demo/set_rewrite.hpp"

#include <yaml-cpp/yaml.h>

#include <set>
#include <stdexcept>

namespace harvest::demo {

namespace fs = std::filesystem;

std::string rewrite_set(const SetRewrite& r) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(r.set_file.string());
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(r.set_file.string() + ": " + e.what());
  }
  const fs::path dir = fs::absolute(r.set_file).parent_path();
  // Relative paths in a set are relative to the set file (docs/launcher.md).
  auto absolute = [&](const std::string& p) { return fs::weakly_canonical(dir / p).string(); };
  if (!r.bin_dir.empty())
    root["bin_dir"] = fs::absolute(r.bin_dir).string();
  else if (root["bin_dir"])
    root["bin_dir"] = absolute(root["bin_dir"].as<std::string>());
  if (root["site"]) root["site"] = absolute(root["site"].as<std::string>());
  if (root["recording"] && root["recording"]["folder"])
    root["recording"]["folder"] = absolute(root["recording"]["folder"].as<std::string>());
  YAML::Node processes = root["processes"];
  if (!processes.IsSequence()) throw std::runtime_error(r.set_file.string() + ": processes: expected a list");
  std::set<std::string> found;
  for (std::size_t i = 0; i < processes.size(); ++i) {
    YAML::Node p = processes[i];
    p["cwd"] = absolute(p["cwd"] ? p["cwd"].as<std::string>() : "../..");
    const std::string name = p["name"] ? p["name"].as<std::string>() : "";
    const auto extra = r.extra_args.find(name);
    if (extra == r.extra_args.end()) continue;
    found.insert(name);
    if (!p["args"]) p["args"] = YAML::Node(YAML::NodeType::Sequence);
    for (const auto& a : extra->second) p["args"].push_back(a);
  }
  for (const auto& [name, args] : r.extra_args)
    if (!found.count(name)) throw std::runtime_error(r.set_file.string() + ": no process named '" + name + "'");
  YAML::Emitter out;
  out << root;
  return std::string(out.c_str()) + "\n";
}

}  // namespace harvest::demo
