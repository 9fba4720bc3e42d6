#include "config/config.hpp"

#include <fstream>
#include <sstream>

namespace harvest::config {

namespace detail {
std::string describe(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Null: return "nothing";
    case YAML::NodeType::Scalar: return "'" + n.Scalar() + "'";
    case YAML::NodeType::Sequence: return "a list";
    case YAML::NodeType::Map: return "a mapping";
    default: return "an undefined value";
  }
}
}  // namespace detail

Node::Node(YAML::Node node, std::string path, std::shared_ptr<detail::Shared> shared)
    : node_(std::move(node)), path_(std::move(path)), shared_(std::move(shared)) {}

std::string Node::key_path(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

void Node::fail(const std::string& key, const std::string& expected) const {
  throw Error(shared_->file + ": " + (key.empty() ? (path_.empty() ? "<root>" : path_) : key_path(key)) +
              ": expected " + expected);
}

YAML::Node Node::lookup(const std::string& key) const {
  if (!node_.IsMap()) return YAML::Node();
  shared_->used.insert(key_path(key));
  const YAML::Node& c = node_;
  return c[key];
}

bool Node::has(const std::string& key) const {
  if (!node_.IsMap()) return false;
  const YAML::Node& c = node_;
  YAML::Node v = c[key];
  return v.IsDefined() && !v.IsNull();
}

std::string Node::choice(const std::string& key, const std::string& fallback,
                         const std::vector<std::string>& choices) const {
  const std::string v = get<std::string>(key, fallback);
  for (const auto& c : choices)
    if (c == v) return v;
  std::string list;
  for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
  fail(key, "one of {" + list + "}, got '" + v + "'");
}

std::vector<double> Node::numbers(const std::string& key, std::size_t expected_size) const {
  YAML::Node v = lookup(key);
  if (!v || v.IsNull()) fail(key, "a required list of numbers");
  if (!v.IsSequence()) fail(key, "a list of numbers, got " + detail::describe(v));
  std::vector<double> out;
  for (std::size_t i = 0; i < v.size(); ++i) {
    try {
      out.push_back(v[i].as<double>());
    } catch (const YAML::Exception&) {
      fail(key, "a list of numbers, element " + std::to_string(i) + " is " + detail::describe(v[i]));
    }
  }
  if (expected_size != 0 && out.size() != expected_size)
    fail(key, "a list of " + std::to_string(expected_size) + " numbers, got " + std::to_string(out.size()));
  return out;
}

std::vector<double> Node::numbers(const std::string& key, const std::vector<double>& fallback,
                                  std::size_t expected_size) const {
  if (!has(key)) {
    YAML::Node n = node_;
    n[key] = fallback;
    n[key].SetStyle(YAML::EmitterStyle::Flow);
    shared_->used.insert(key_path(key));
    return fallback;
  }
  return numbers(key, expected_size);
}

std::filesystem::path Node::file_path(const std::string& key) const {
  std::filesystem::path p = required<std::string>(key);
  if (p.is_relative() && shared_->file.front() != '<') {
    std::filesystem::path beside = std::filesystem::path(shared_->file).parent_path() / p;
    if (std::filesystem::exists(beside) || !std::filesystem::exists(p)) return beside;
  }
  return p;
}

std::filesystem::path Node::file_path(const std::string& key, const std::string& fallback) const {
  if (!has(key)) get<std::string>(key, fallback);
  return file_path(key);
}

Node Node::child(const std::string& key) const {
  YAML::Node v = lookup(key);
  if (!v || v.IsNull()) {
    YAML::Node n = node_;
    n[key] = YAML::Node(YAML::NodeType::Map);
    return Node(n[key], key_path(key), shared_);
  }
  if (!v.IsMap()) fail(key, "a mapping, got " + detail::describe(v));
  return Node(v, key_path(key), shared_);
}

Node Node::required_child(const std::string& key) const {
  if (!has(key)) fail(key, "a required mapping");
  return child(key);
}

std::vector<Node> Node::children(const std::string& key) const {
  YAML::Node v = lookup(key);
  std::vector<Node> out;
  if (!v || v.IsNull()) return out;
  if (!v.IsSequence()) fail(key, "a list, got " + detail::describe(v));
  for (std::size_t i = 0; i < v.size(); ++i) {
    const std::string p = key_path(key) + "[" + std::to_string(i) + "]";
    if (!v[i].IsMap()) throw Error(shared_->file + ": " + p + ": expected a mapping, got " + detail::describe(v[i]));
    out.emplace_back(v[i], p, shared_);
  }
  return out;
}

std::vector<std::string> Node::keys() const {
  std::vector<std::string> out;
  if (!node_.IsMap()) return out;
  for (const auto& kv : node_) out.push_back(kv.first.as<std::string>());
  return out;
}

Document Document::load_file(const std::filesystem::path& file) {
  Document d;
  d.shared_ = std::make_shared<detail::Shared>();
  d.shared_->file = file.string();
  if (!std::filesystem::exists(file)) throw Error(file.string() + ": configuration file not found");
  try {
    d.tree_ = YAML::LoadFile(file.string());
  } catch (const YAML::Exception& e) {
    throw Error(file.string() + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
  if (d.tree_.IsNull()) d.tree_ = YAML::Node(YAML::NodeType::Map);
  if (!d.tree_.IsMap()) throw Error(file.string() + ": expected a mapping at the top level");
  return d;
}

Document Document::load_string(const std::string& text, const std::string& name) {
  Document d;
  d.shared_ = std::make_shared<detail::Shared>();
  d.shared_->file = name;
  try {
    d.tree_ = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw Error(name + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
  if (d.tree_.IsNull()) d.tree_ = YAML::Node(YAML::NodeType::Map);
  if (!d.tree_.IsMap()) throw Error(name + ": expected a mapping at the top level");
  return d;
}

Node Document::root() const { return Node(tree_, "", shared_); }

void Document::apply_override(const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw Error("override '" + assignment + "': expected KEY.PATH=VALUE");
  const std::string key = assignment.substr(0, eq);
  YAML::Node value;
  try {
    value = YAML::Load(assignment.substr(eq + 1));
  } catch (const YAML::Exception& e) {
    throw Error("override '" + assignment + "': bad value: " + e.msg);
  }
  std::vector<std::string> parts;
  std::stringstream ss(key);
  for (std::string p; std::getline(ss, p, '.');) parts.push_back(p);
  // yaml-cpp nodes are handles; walk with fresh handles so we never rebind.
  std::vector<YAML::Node> chain{tree_};
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
    YAML::Node next = chain.back()[parts[i]];
    if (next.IsDefined() && !next.IsNull() && !next.IsMap())
      throw Error("override '" + assignment + "': " + parts[i] + " is not a mapping");
    if (!next.IsDefined() || next.IsNull()) chain.back()[parts[i]] = YAML::Node(YAML::NodeType::Map);
    chain.push_back(chain.back()[parts[i]]);
  }
  chain.back()[parts.back()] = value;
}

namespace {
void collect_unused(const YAML::Node& n, const std::string& path, const std::set<std::string>& used,
                    std::vector<std::string>& out) {
  if (n.IsMap()) {
    for (const auto& kv : n) {
      const std::string p = path.empty() ? kv.first.as<std::string>() : path + "." + kv.first.as<std::string>();
      if (!used.count(p)) {
        out.push_back(p);
        continue;
      }
      collect_unused(kv.second, p, used, out);
    }
  } else if (n.IsSequence()) {
    for (std::size_t i = 0; i < n.size(); ++i)
      if (n[i].IsMap()) collect_unused(n[i], path + "[" + std::to_string(i) + "]", used, out);
  }
}
}  // namespace

void Document::check_unused() const {
  std::vector<std::string> unused;
  collect_unused(tree_, "", shared_->used, unused);
  if (unused.empty()) return;
  std::string msg = shared_->file + ": unknown key";
  msg += unused.size() > 1 ? "s: " : ": ";
  for (std::size_t i = 0; i < unused.size(); ++i) msg += (i ? ", " : "") + unused[i];
  msg += " (misspelt or not used by this process)";
  throw Error(msg);
}

std::string Document::emit() const {
  YAML::Emitter e;
  e << tree_;
  return std::string(e.c_str()) + "\n";
}

}  // namespace harvest::config
