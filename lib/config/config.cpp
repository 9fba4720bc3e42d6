#include "config/config.hpp"

#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>

namespace harvest::config {

namespace detail {
std::string describe(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Null:
      return "nothing";
    case YAML::NodeType::Scalar:
      return "'" + n.Scalar() + "'";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a mapping";
    default:
      return "an undefined value";
  }
}
}  // namespace detail

std::vector<std::string> Choice::list() const {
  std::vector<std::string> out;
  for (auto c : choices)
    if (!c.empty()) out.emplace_back(c);
  return out;
}

std::vector<double> Numbers::defaults() const { return {fallback.begin(), fallback.begin() + size}; }

std::string Node::get(const Choice& key) const { return choice(key.name, std::string(key.fallback), key.list()); }

std::vector<double> Node::get(const Numbers& key) const {
  return key.required ? numbers(key.name, key.size) : numbers(key.name, key.defaults(), key.size);
}

std::vector<double> Node::get(const Numbers& key, const std::vector<double>& derived_fallback) const {
  return numbers(key.name, derived_fallback, key.size);
}

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

namespace {
// A mapping key as text. YAML allows a list or mapping as a key ("? [a, b]:
// 1"), which yaml-cpp cannot turn into a string (it throws its own
// exception); no harvest configuration has one, so it is a configuration error.
std::string key_name(const YAML::Node& key, const std::string& file, const std::string& where) {
  if (!key.IsScalar())
    throw Error(file + ": " + (where.empty() ? std::string("top level") : where) + ": a key must be a name, not " +
                detail::describe(key));
  return key.Scalar();
}
}  // namespace

std::vector<std::string> Node::keys() const {
  std::vector<std::string> out;
  if (!node_.IsMap()) return out;
  for (const auto& kv : node_) out.push_back(key_name(kv.first, shared_->file, path_));
  return out;
}

namespace {
// YAML is Unicode text without control characters; yaml-cpp takes any bytes
// and then emits a configuration it cannot read back (config_loader_fuzz:
// ESC and invalid UTF-8 in a flow mapping), which would break --check-config
// output and replay from the CONFIG snapshot. Names the line of the first bad byte.
void check_text(const std::string& text, const std::string& name) {
  int line = 1;
  for (std::size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    std::size_t n = 1;
    if (c == '\n') {
      ++line;
    } else if ((c < 0x20 && c != '\t') || c == 0x7f) {
      throw Error(name + ":" + std::to_string(line) + ": control character " + std::to_string(c) + " in the text");
    } else if (c >= 0x80) {
      n = c >= 0xf0 && c <= 0xf4 ? 4 : c >= 0xe0 ? 3 : c >= 0xc2 && c < 0xe0 ? 2 : 0;
      bool ok = n != 0 && i + n <= text.size();
      for (std::size_t k = 1; ok && k < n; ++k) ok = (static_cast<unsigned char>(text[i + k]) & 0xc0) == 0x80;
      if (!ok) throw Error(name + ":" + std::to_string(line) + ": not UTF-8 text");
    }
    i += n;
  }
}

// YAML line breaks are LF, CR LF and CR, all one LF to a YAML processor
// (YAML 1.2, 5.4). yaml-cpp reads a CR as a break in some places and not in
// others: it loaded "x: :" followed by CR CR as x = ":" and emitted "x: :",
// which it refuses (config_loader_fuzz). Parsing LF-only text makes what it
// loads and what it emits agree, and the line numbers the ones editors show.
std::string normalise_line_breaks(const std::string& text) {
  if (text.find('\r') == std::string::npos) return text;
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '\r') {
      out += text[i];
    } else {
      out += '\n';
      if (i + 1 < text.size() && text[i + 1] == '\n') ++i;
    }
  }
  return out;
}

// YAML wants the keys of a mapping unique, yaml-cpp does not check: a key
// written twice would be read one way and emitted (--check-config, CONFIG)
// another. Names the key and both lines. Keys are plain values.
// Walks the loaded tree once. Aliases make it a graph: one that refers to
// itself (`&a` on a mapping holding `*a`) has no bottom, and aliases of
// aliases expand exponentially ("billion laughs"), so the walk is bounded in
// depth and in values visited; every other walk of the tree (unused keys, the
// effective configuration) comes after this one.
constexpr std::size_t kMaxDepth = 64;
constexpr std::size_t kMaxValues = 100'000;
// YAML allows an implicit key of at most 1024 characters (1.2, 7.4.2);
// yaml-cpp emits a longer one implicitly anyway and then refuses its own
// text (config_loader_fuzz: an override path part of 958 bytes). No
// component has a key a tenth of this long.
constexpr std::size_t kMaxKeyLength = 256;
std::string key_too_long(const std::string& key) {
  return "key '" + key.substr(0, 40) + "...' is longer than " + std::to_string(kMaxKeyLength) + " characters";
}
struct TreeWalk {
  const std::string& name;
  std::size_t values = 0;
};

void check_tree(const YAML::Node& n, TreeWalk& walk, std::size_t depth) {
  const auto line = [&] { return std::to_string(n.Mark().line + 1); };
  if (depth > kMaxDepth)
    throw Error(walk.name + ":" + line() + ": nested deeper than " + std::to_string(kMaxDepth) +
                " levels (an alias that refers to itself?)");
  if (++walk.values > kMaxValues)
    throw Error(walk.name + ": more than " + std::to_string(kMaxValues) +
                " values with its aliases expanded (aliases of aliases?)");
  if (n.IsMap()) {
    std::map<std::string, int> line_of;
    for (const auto& kv : n) {
      // A list or mapping as a key: no component reads one, and yaml-cpp
      // emits some of them as text that does not load again.
      if (!kv.first.IsScalar() && !kv.first.IsNull())
        throw Error(walk.name + ":" + std::to_string(kv.first.Mark().line + 1) +
                    ": a key must be a plain value, not a list or a mapping");
      if (kv.first.IsScalar()) {
        const int key_line = kv.first.Mark().line + 1;
        if (kv.first.Scalar().size() > kMaxKeyLength)
          throw Error(walk.name + ":" + std::to_string(key_line) + ": " + key_too_long(kv.first.Scalar()));
        const auto [it, fresh] = line_of.emplace(kv.first.Scalar(), key_line);
        if (!fresh)
          throw Error(walk.name + ":" + std::to_string(key_line) + ": key '" + kv.first.Scalar() +
                      "' given twice in one mapping (first on line " + std::to_string(it->second) + ")");
      }
      check_tree(kv.second, walk, depth + 1);
    }
  } else if (n.IsSequence()) {
    for (const auto& item : n) check_tree(item, walk, depth + 1);
  }
}

void check_tree(const YAML::Node& n, const std::string& name) {
  TreeWalk walk{name};
  check_tree(n, walk, 0);
}
}  // namespace

Document Document::load_file(const std::filesystem::path& file) {
  if (!std::filesystem::exists(file)) throw Error(file.string() + ": configuration file not found");
  if (std::filesystem::is_directory(file)) throw Error(file.string() + ": a folder, not a configuration file");
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(file.string() + ": cannot read the configuration file");
  std::ostringstream text;
  text << in.rdbuf();
  return load_string(text.str(), file.string());
}

Document Document::load_string(const std::string& raw_text, const std::string& name) {
  const std::string text = normalise_line_breaks(raw_text);
  check_text(text, name);
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
  check_tree(d.tree_, name);
  return d;
}

Node Document::root() const { return Node(tree_, "", shared_); }

void Document::apply_override(const std::string& raw_assignment) {
  const std::string assignment = normalise_line_breaks(raw_assignment);
  check_text(assignment, "--set override");  // it lands in the emitted configuration too
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) throw Error("override '" + assignment + "': expected KEY.PATH=VALUE");
  const std::string key = assignment.substr(0, eq);
  YAML::Node value;
  try {
    value = YAML::Load(assignment.substr(eq + 1));
  } catch (const YAML::Exception& e) {
    throw Error("override '" + assignment + "': bad value: " + e.msg);
  }
  check_tree(value, "override '" + assignment + "'");  // the value's keys, as a file's
  std::vector<std::string> parts;
  std::stringstream ss(key);
  for (std::string p; std::getline(ss, p, '.');) parts.push_back(p);
  // Every part names a key, and no configuration nests deeper than a few
  // levels: a path of hundreds of parts emitted a configuration yaml-cpp no
  // longer loads (found by config_loader_fuzz).
  if (key.back() == '.' || std::find(parts.begin(), parts.end(), "") != parts.end())
    throw Error("override '" + assignment + "': empty key in KEY.PATH");
  if (parts.size() > kMaxOverrideDepth)
    throw Error("override '" + assignment + "': KEY.PATH deeper than " + std::to_string(kMaxOverrideDepth) + " levels");
  for (const auto& p : parts)
    if (p.size() > kMaxKeyLength) throw Error("override: " + key_too_long(p));
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
                    std::vector<std::string>& out, const std::string& file) {
  if (n.IsMap()) {
    for (const auto& kv : n) {
      const std::string name = key_name(kv.first, file, path);
      const std::string p = path.empty() ? name : path + "." + name;
      if (!used.count(p)) {
        out.push_back(p);
        continue;
      }
      collect_unused(kv.second, p, used, out, file);
    }
  } else if (n.IsSequence()) {
    for (std::size_t i = 0; i < n.size(); ++i)
      if (n[i].IsMap()) collect_unused(n[i], path + "[" + std::to_string(i) + "]", used, out, file);
  }
}
}  // namespace

void Document::check_unused() const {
  std::vector<std::string> unused;
  collect_unused(tree_, "", shared_->used, unused, shared_->file);
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
