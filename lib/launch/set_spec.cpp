#include "launch/set_spec.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <set>
#include <sstream>

namespace harvest::launch {

namespace {

// config::Node has no reader for lists of strings and check_unused() would
// not see keys read through yaml(), so sets check their own keys.
void check_keys(const config::Node& n, const std::set<std::string>& allowed) {
  for (const auto& k : n.keys()) {
    if (allowed.count(k)) continue;
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
    throw config::Error(n.file() + ": " + n.key_path(k) + ": unknown key (misspelt?); expected one of {" + list + "}");
  }
}

std::vector<std::string> strings(const config::Node& n, const std::string& key) {
  std::vector<std::string> out;
  if (!n.has(key)) return out;
  const YAML::Node v = n.yaml()[key];
  if (v.IsScalar()) return {v.Scalar()};
  if (!v.IsSequence()) n.fail(key, "a list of strings, got " + config::detail::describe(v));
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!v[i].IsScalar()) n.fail(key, "a list of strings, element " + std::to_string(i) + " is not a string");
    out.push_back(v[i].Scalar());
  }
  return out;
}

// The keys of a launch set file (config/sets/*.yaml, docs/launcher.md).
namespace lk {
using config::Key;
namespace restart {
constexpr config::Choice policy{"policy", "on-failure", {"never", "on-failure", "always"}, "when to restart it"};
constexpr Key<int> max_restarts{"max_restarts", 3, {-1, 1000}, "", "restarts in a row before giving up (-1: no limit)"};
constexpr Key<double> backoff_s{"backoff_s", 0.5, {0.0, 3600.0}, "s", "wait before the first restart ..."};
constexpr Key<double> backoff_factor{"backoff_factor", 2.0, {1.0, 10.0}, "", "... multiplied by this each time ..."};
constexpr Key<double> backoff_max_s{"backoff_max_s", 10.0, {0.0, 3600.0}, "s", "... up to this (at least backoff_s)"};
constexpr Key<double> reset_after_s{"reset_after_s", 30.0, {0.0, 86400.0}, "s",
                                    "running this long counts as healthy: the count starts again"};
}  // namespace restart
namespace set {
constexpr Key<std::string> name{.name = "name", .doc = "the set's name", .derived = "the file's name"};
constexpr Key<std::string> bin_dir{"bin_dir", "../../build/bin", {}, "", "where the commands are (beside the file)"};
constexpr Key<std::string> lcm_url{"lcm_url", "", {}, "", "LCM URL for every process (empty: theirs)"};
constexpr Key<std::string> prefix{"prefix", "", {}, "", "channel prefix for every process"};
constexpr Key<std::string> site{"site", "", {}, "", "the site file whose values ${site.KEY} substitute"};
}  // namespace set
namespace process {
constexpr Key<std::string> name{.name = "name", .doc = "unique, no spaces or '/'", .required = true};
constexpr Key<std::string> command{.name = "command", .doc = "the program (in bin_dir unless a path)", .required = true};
constexpr Key<std::string> cwd{"cwd", "../..", {}, "", "working directory (beside the file)"};
constexpr Key<std::string> group{"group", "default", {}, "", "group name (start and stop together)"};
constexpr Key<bool> critical{"critical", false, {}, "", "its giving up stops the set"};
constexpr Key<bool> stop_first{"stop_first", false, {}, "", "stopped before the others"};
constexpr Key<bool> ends_set{"ends_set", false, {}, "", "its clean exit ends the set"};
constexpr Key<bool> harvest_options{"harvest_options", true, {}, "",
                                    "a harvest process: gets --lcm-url, --prefix, --instance; sends heartbeats"};
constexpr Key<double> heartbeat_timeout_s{.name = "heartbeat_timeout_s", .range = {0.0, 3600.0}, .unit = "s",
                                          .doc = "no heartbeat this long: hung (0: not watched)",
                                          .derived = "3 with harvest_options, else 0"};
constexpr Key<double> stop_timeout_s{"stop_timeout_s", 5.0, {0.0, 600.0}, "s", "SIGTERM, then SIGKILL after this"};
constexpr Key<double> ready_timeout_s{"ready_timeout_s", 10.0, {0.0, 600.0}, "s",
                                      "processes after it wait this long for its first heartbeat"};
}  // namespace process
namespace recording {
constexpr Key<bool> enabled{"enabled", false, {}, "", "record the run"};
constexpr Key<std::string> folder{"folder", "../../logs/runs", {}, "", "where logs go (beside the file)"};
constexpr Key<std::string> file_prefix{.name = "file_prefix", .doc = "log file names start so",
                                       .derived = "the set's name"};
constexpr Key<std::string> channels{"channels", ".*", {}, "", "regular expression of channels recorded"};
constexpr Key<bool> invert_channels{"invert_channels", false, {}, "", "record everything that does NOT match"};
constexpr Key<double> split_mb{"split_mb", 0.0, {0.0, 1e6}, "MB", "start a new file at this size (0: one file)"};
constexpr Key<std::string> logger{"logger", "harvest-record", {}, "", "the recorder program"};
constexpr Key<double> image_rate_hz{"image_rate_hz", 0.0, {0.0, 1000.0}, "Hz",
                                    "image_channels at most this often (0: every frame)"};
constexpr Key<std::string> image_channels{"image_channels", "CAMERA_.*", {}, "", "regular expression"};
constexpr Key<double> status_s{"status_s", 10.0, {0.0, 3600.0}, "s", "size/rate/free-space line this often (0: never)"};
constexpr Key<double> warn_free_mb{"warn_free_mb", 1000.0, {0.0, 1e9}, "MB", "warn while less is free on its disk"};
constexpr Key<double> warn_fill_minutes{"warn_fill_minutes", 10.0, {0.0, 1e6}, "min",
                                        "warn while the disk would fill within this at the current rate"};
}  // namespace recording
}  // namespace lk

RestartPolicy parse_restart(const config::Node& n) {
  check_keys(n, {"policy", "max_restarts", "backoff_s", "backoff_factor", "backoff_max_s", "reset_after_s"});
  RestartPolicy r;
  namespace k = lk::restart;
  const std::string mode = n.get(k::policy);
  r.mode = mode == "never" ? RestartMode::kNever : mode == "always" ? RestartMode::kAlways : RestartMode::kOnFailure;
  r.max_restarts = n.get(k::max_restarts);
  r.backoff_initial_s = n.get(k::backoff_s);
  r.backoff_factor = n.get(k::backoff_factor);
  r.backoff_max_s = n.get(k::backoff_max_s);
  r.reset_after_s = n.get(k::reset_after_s);
  if (r.backoff_max_s < r.backoff_initial_s) n.fail("backoff_max_s", "a value >= backoff_s");
  return r;
}

std::filesystem::path beside(const std::filesystem::path& set_file, const std::string& p) {
  std::filesystem::path path(p);
  return path.is_relative() ? (set_file.parent_path() / path).lexically_normal() : path;
}

bool executable(const std::filesystem::path& p) {
  return std::filesystem::is_regular_file(p) && access(p.c_str(), X_OK) == 0;
}

// The site: the set's `site` file (or the command line's), then single values.
SiteSpec load_site(const config::Node& root, const std::filesystem::path& set_file, const SiteOverrides& over) {
  SiteSpec site;
  if (!over.file.empty())
    site.file = std::filesystem::absolute(over.file).lexically_normal();
  else if (root.has("site"))
    site.file = beside(set_file, root.get(lk::set::site));
  config::Document doc = site.file.empty() ? config::Document::load_string("{}", "<no site file>")
                                           : config::Document::load_file(site.file);
  for (const auto& a : over.assignments) {
    const auto eq = a.find('=');
    if (eq == std::string::npos || eq == 0 || a.substr(0, eq).find('.') != std::string::npos)
      throw config::Error("--set site." + a + ": expected site.KEY=VALUE (a site file is one flat list of values)");
    doc.apply_override(a);
  }
  const config::Node n = doc.root();
  if (!n.yaml().IsMap() && !n.yaml().IsNull())
    throw config::Error(doc.file() + ": a site file is a mapping KEY: VALUE (docs/field-setup.md)");
  for (const auto& k : n.keys()) {
    const YAML::Node v = n.yaml()[k];
    if (!v.IsScalar()) n.fail(k, "a single value (device path, bus string), got " + config::detail::describe(v));
    if (k.empty() || k.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_") !=
                         std::string::npos)
      n.fail(k, "a key of letters, digits and '_'");
    site.values[k] = v.Scalar();
  }
  return site;
}

// Replaces ${KEY} with the site's value, ${KEY:-DEFAULT} with DEFAULT when
// the site has no KEY (a choice with a sound default, not a device); records
// the keys used.
std::string substitute(const std::string& text, const SiteSpec& site, const std::string& where,
                       std::vector<std::string>& used) {
  std::string out;
  std::size_t pos = 0;
  for (;;) {
    const std::size_t start = text.find("${", pos);
    if (start == std::string::npos) break;
    const std::size_t end = text.find('}', start);
    if (end == std::string::npos) throw config::Error(where + ": '" + text + "': unterminated ${");
    std::string key = text.substr(start + 2, end - start - 2);
    const std::size_t dash = key.find(":-");
    const std::optional<std::string> fallback =
        dash == std::string::npos ? std::nullopt : std::optional<std::string>(key.substr(dash + 2));
    if (fallback) key.resize(dash);
    const auto it = site.values.find(key);
    if (it == site.values.end() && fallback) {
      out += text.substr(pos, start - pos) + *fallback;
      pos = end + 1;
      continue;
    }
    if (it == site.values.end())
      throw config::Error(where + ": ${" + key + "} is not a site value (" +
                          (site.file.empty() ? std::string("the set names no site file; give `site:` in the set or "
                                                           "harvest-launch --site FILE")
                                             : "not in " + site.file.string()) +
                          "; or harvest-launch --set site." + key + "=VALUE)");
    out += text.substr(pos, start - pos) + it->second;
    if (std::find(used.begin(), used.end(), key) == used.end()) used.push_back(key);
    pos = end + 1;
  }
  return out + text.substr(pos);
}

}  // namespace

void split_site_overrides(const std::vector<std::string>& overrides, std::vector<std::string>& set_overrides,
                          SiteOverrides& site) {
  for (const auto& o : overrides) {
    if (o.rfind("site.", 0) == 0)
      site.assignments.push_back(o.substr(5));
    else
      set_overrides.push_back(o);
  }
}

SetSpec parse_set(const config::Node& root, const std::filesystem::path& set_file,
                  const std::filesystem::path& bin_dir_override, const SiteOverrides& site_overrides) {
  check_keys(root, {"name", "bin_dir", "lcm_url", "prefix", "site", "processes", "recording"});
  SetSpec s;
  s.file = std::filesystem::absolute(set_file).lexically_normal();
  s.name = root.get(lk::set::name, set_file.stem().string());
  s.bin_dir = bin_dir_override.empty() ? beside(s.file, root.get(lk::set::bin_dir)) : bin_dir_override;
  s.lcm_url = root.get(lk::set::lcm_url);
  s.prefix = root.get(lk::set::prefix);
  s.site = load_site(root, s.file, site_overrides);

  std::set<std::string> names;
  for (const config::Node& p : root.children("processes")) {
    check_keys(p, {"name", "command", "args", "env", "cwd", "group", "after", "restart", "critical", "stop_first",
                   "ends_set", "harvest_options", "heartbeat_timeout_s", "stop_timeout_s", "ready_timeout_s"});
    ProcessSpec ps;
    namespace kp = lk::process;
    ps.name = p.get(kp::name);
    if (ps.name.empty() || ps.name.find_first_of(" \t/") != std::string::npos)
      p.fail("name", "a non-empty name without spaces or '/', got '" + ps.name + "'");
    if (!names.insert(ps.name).second) p.fail("name", "a unique name, '" + ps.name + "' is used twice");
    ps.command = p.get(kp::command);
    std::vector<std::string> used;
    for (const auto& a : strings(p, "args")) ps.args.push_back(substitute(a, s.site, s.file.string() + ": " + p.key_path("args"), used));
    const config::Node env = p.child("env");
    for (const auto& k : env.keys())
      ps.env[k] = substitute(env.required<std::string>(k), s.site, s.file.string() + ": " + env.key_path(k), used);
    if (!used.empty()) s.site.used_by[ps.name] = used;
    ps.cwd = beside(s.file, p.get(kp::cwd));
    ps.group = p.get(kp::group);
    ps.after = strings(p, "after");
    ps.restart = parse_restart(p.child("restart"));
    ps.critical = p.get(kp::critical);
    ps.stop_first = p.get(kp::stop_first);
    ps.ends_set = p.get(kp::ends_set);
    ps.harvest_options = p.get(kp::harvest_options);
    ps.heartbeat_timeout_s = p.get(kp::heartbeat_timeout_s, ps.harvest_options ? 3.0 : 0.0);
    ps.stop_timeout_s = p.get(kp::stop_timeout_s);
    ps.ready_timeout_s = p.get(kp::ready_timeout_s);
    s.processes.push_back(std::move(ps));
  }
  if (s.processes.empty()) root.fail("processes", "a non-empty list of processes");

  const config::Node rec = root.child("recording");
  check_keys(rec, {"enabled", "folder", "file_prefix", "channels", "invert_channels", "split_mb", "logger",
                   "image_rate_hz", "image_channels", "status_s", "warn_free_mb", "warn_fill_minutes"});
  namespace kr = lk::recording;
  s.recording.enabled = rec.get(kr::enabled);
  s.recording.folder = beside(s.file, rec.get(kr::folder));
  s.recording.file_prefix = rec.get(kr::file_prefix, s.name);
  s.recording.channels = rec.get(kr::channels);
  s.recording.invert_channels = rec.get(kr::invert_channels);
  s.recording.split_mb = rec.get(kr::split_mb);
  s.recording.logger = rec.get(kr::logger);
  s.recording.image_rate_hz = rec.get(kr::image_rate_hz);
  s.recording.image_channels = rec.get(kr::image_channels);
  s.recording.status_s = rec.get(kr::status_s);
  s.recording.warn_free_mb = rec.get(kr::warn_free_mb);
  s.recording.warn_fill_minutes = rec.get(kr::warn_fill_minutes);

  start_order(s);  // throws on unknown dependencies and cycles
  return s;
}

std::vector<config::Section> set_schema() {
  const std::string where = "harvest-launch, config/sets/*.yaml (docs/launcher.md).";
  namespace kp = lk::process;
  namespace kr = lk::recording;
  namespace kq = lk::restart;
  return {config::section("set", where, lk::set::name, lk::set::bin_dir, lk::set::lcm_url, lk::set::prefix,
                          lk::set::site),
          config::section("set.processes[]", "Each process (also `args` and `after`: lists of strings; `env`: a "
                          "mapping of strings).", kp::name, kp::command, kp::cwd, kp::group, kp::critical,
                          kp::stop_first, kp::ends_set, kp::harvest_options, kp::heartbeat_timeout_s,
                          kp::stop_timeout_s, kp::ready_timeout_s),
          config::section("set.processes[].restart", where, kq::policy, kq::max_restarts, kq::backoff_s,
                          kq::backoff_factor, kq::backoff_max_s, kq::reset_after_s),
          config::section("set.recording", where, kr::enabled, kr::folder, kr::file_prefix, kr::channels,
                          kr::invert_channels, kr::split_mb, kr::logger, kr::image_rate_hz, kr::image_channels,
                          kr::status_s, kr::warn_free_mb, kr::warn_fill_minutes)};
}

SetSpec load_set(const std::filesystem::path& set_file, const std::filesystem::path& bin_dir_override,
                 const SiteOverrides& site) {
  const config::Document doc = config::Document::load_file(set_file);
  return parse_set(doc.root(), set_file, bin_dir_override, site);
}

std::vector<std::size_t> start_order(const SetSpec& set) {
  std::map<std::string, std::size_t> index;
  for (std::size_t i = 0; i < set.processes.size(); ++i) index[set.processes[i].name] = i;
  for (const auto& p : set.processes)
    for (const auto& d : p.after) {
      if (!index.count(d))
        throw config::Error(set.file.string() + ": processes." + p.name + ".after: unknown process '" + d + "'");
      if (d == p.name) throw config::Error(set.file.string() + ": processes." + p.name + ".after: depends on itself");
    }
  // Depth-first topological sort in declaration order, so independent
  // processes keep the order the set file gives them.
  std::vector<int> state(set.processes.size(), 0);  // 0 new, 1 visiting, 2 done
  std::vector<std::size_t> order;
  std::function<void(std::size_t, std::string)> visit = [&](std::size_t i, std::string chain) {
    chain += (chain.empty() ? "" : " -> ") + set.processes[i].name;
    if (state[i] == 2) return;
    if (state[i] == 1) throw config::Error(set.file.string() + ": dependency cycle: " + chain);
    state[i] = 1;
    for (const auto& d : set.processes[i].after) visit(index[d], chain);
    state[i] = 2;
    order.push_back(i);
  };
  for (std::size_t i = 0; i < set.processes.size(); ++i) visit(i, "");
  return order;
}

std::vector<std::size_t> select_group(const SetSpec& set, const std::string& group) {
  // "a,b": the processes of either group (one host running two groups, e.g. a deputy).
  std::vector<std::string> wanted;
  for (std::size_t start = 0; start <= group.size();) {
    const std::size_t comma = std::min(group.find(',', start), group.size());
    if (comma > start) wanted.push_back(group.substr(start, comma - start));
    start = comma + 1;
  }
  std::vector<std::size_t> out;
  for (std::size_t i : start_order(set))
    if (wanted.empty() || std::find(wanted.begin(), wanted.end(), set.processes[i].group) != wanted.end())
      out.push_back(i);
  return out;
}

std::optional<std::filesystem::path> resolve_executable(const SetSpec& set, const std::string& command) {
  if (command.find('/') != std::string::npos) {
    const std::filesystem::path p = beside(set.file, command);
    return executable(p) ? std::optional(p) : std::nullopt;
  }
  if (!set.bin_dir.empty() && executable(set.bin_dir / command)) return set.bin_dir / command;
  std::error_code ec;
  const auto own = std::filesystem::read_symlink("/proc/self/exe", ec).parent_path();
  if (!ec && executable(own / command)) return own / command;
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "/usr/bin:/bin");
  for (std::string d; std::getline(dirs, d, ':');)
    if (!d.empty() && executable(std::filesystem::path(d) / command)) return std::filesystem::path(d) / command;
  return std::nullopt;
}

bool is_harvest_record(const RecordingSpec& r) {
  return std::filesystem::path(r.logger).filename() == "harvest-record";
}

std::vector<std::string> preflight(const SetSpec& set, const std::vector<std::size_t>& selected) {
  std::vector<std::string> problems;
  for (std::size_t i : selected) {
    const ProcessSpec& p = set.processes[i];
    if (!resolve_executable(set, p.command))
      problems.push_back(p.name + ": executable '" + p.command + "' not found (looked in " + set.bin_dir.string() +
                         " and PATH); build it or fix 'command'");
    if (!std::filesystem::is_directory(p.cwd))
      problems.push_back(p.name + ": working directory " + p.cwd.string() + " does not exist");
  }
  if (set.recording.enabled && !resolve_executable(set, set.recording.logger))
    problems.push_back(
        "recording: '" + set.recording.logger + "' not found (" +
        (is_harvest_record(set.recording) ? "build it: tools/harvest build" : "apt-get install liblcm-bin") + ")");
  if (set.recording.enabled && set.recording.image_rate_hz > 0 && !is_harvest_record(set.recording))
    problems.push_back("recording: image_rate_hz needs logger harvest-record ('" + set.recording.logger +
                       "' records every message)");
  return problems;
}

std::vector<std::string> command_line(const SetSpec& set, const ProcessSpec& p) {
  const auto exe = resolve_executable(set, p.command);
  std::vector<std::string> argv{exe ? exe->string() : p.command};
  argv.insert(argv.end(), p.args.begin(), p.args.end());
  if (p.harvest_options) {
    argv.insert(argv.end(), {"--instance", p.name});
    if (!set.prefix.empty()) argv.insert(argv.end(), {"--prefix", set.prefix});
    if (!set.lcm_url.empty()) argv.insert(argv.end(), {"--lcm-url", set.lcm_url});
  }
  return argv;
}

std::vector<std::string> recorder_command_line(const SetSpec& set, const std::string& timestamp) {
  const RecordingSpec& r = set.recording;
  const auto exe = resolve_executable(set, r.logger);
  const bool ours = is_harvest_record(r);
  // The options both loggers take, in lcm-logger's spelling.
  std::vector<std::string> argv{exe ? exe->string() : r.logger};
  if (!ours) argv.push_back("--quiet");  // harvest-record's lines are its size/rate reports
  argv.push_back("--channel=" + r.channels);
  if (r.invert_channels) argv.push_back("--invert-channels");
  if (!set.lcm_url.empty()) argv.push_back("--lcm-url=" + set.lcm_url);
  argv.push_back("-i");  // append .00, .01, ... ; the long form --increment is broken in lcm-logger 1.4
  if (r.split_mb > 0) argv.push_back("--split-mb=" + std::to_string(r.split_mb));
  if (ours) {
    if (r.image_rate_hz > 0) argv.push_back("--max-rate=" + r.image_channels + "=" + std::to_string(r.image_rate_hz));
    argv.push_back("--status-s=" + std::to_string(r.status_s));
    argv.push_back("--warn-free-mb=" + std::to_string(r.warn_free_mb));
    argv.push_back("--warn-fill-minutes=" + std::to_string(r.warn_fill_minutes));
  }
  argv.push_back((r.folder / (r.file_prefix + "-" + timestamp + ".lcm")).string());
  return argv;
}

std::optional<double> restart_delay(const RestartPolicy& policy, int restarts_done, bool failed) {
  if (policy.mode == RestartMode::kNever) return std::nullopt;
  if (policy.mode == RestartMode::kOnFailure && !failed) return std::nullopt;
  if (policy.max_restarts >= 0 && restarts_done >= policy.max_restarts) return std::nullopt;
  const double d = policy.backoff_initial_s * std::pow(policy.backoff_factor, restarts_done);
  return std::min(d, policy.backoff_max_s);
}

}  // namespace harvest::launch
