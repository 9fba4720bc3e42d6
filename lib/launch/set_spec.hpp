// A process set: what harvest-launch starts, in which order, how it restarts
// and stops them, and what it records (docs/launcher.md).
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "config/schema.hpp"

namespace harvest::launch {

enum class RestartMode { kNever, kOnFailure, kAlways };

// Restart with exponential back-off: delay = initial * factor^n, capped; the
// count resets once a run has lasted `reset_after_s`.
struct RestartPolicy {
  RestartMode mode = RestartMode::kOnFailure;
  int max_restarts = 3;  // restarts in a row before giving up; -1: unlimited
  double backoff_initial_s = 0.5;
  double backoff_factor = 2.0;
  double backoff_max_s = 10.0;
  double reset_after_s = 30.0;
};

struct ProcessSpec {
  std::string name;                        // also its --instance and heartbeat instance
  std::string command;                     // executable: path, or name looked up in bin_dir then PATH
  std::vector<std::string> args;
  std::map<std::string, std::string> env;  // added to the launcher's environment
  std::filesystem::path cwd;               // working directory
  std::string group;                       // host group (machine)
  std::vector<std::string> after;          // started once these are ready
  RestartPolicy restart;
  bool critical = false;         // giving up on it stops the whole set
  bool stop_first = false;       // stopped before everything else (the arm)
  // When it exits, whatever the code, the launcher stops the set and exits
  // with its code (the simulator: its end is the end of the run), as
  // --exit-with NAME does from the command line.
  bool ends_set = false;
  bool harvest_options = true;   // append --instance NAME (and --prefix, --lcm-url from the set)
  double heartbeat_timeout_s = 0;  // 0: no heartbeat expected
  double stop_timeout_s = 5;       // SIGTERM -> SIGKILL
  double ready_timeout_s = 10;     // first heartbeat before dependants start anyway
};

struct RecordingSpec {
  bool enabled = false;
  std::filesystem::path folder;  // relative to the set file
  std::string file_prefix = "harvest";
  std::string channels = ".*";   // regular expression given to lcm-logger -c
  bool invert_channels = false;  // record everything that does NOT match
  double split_mb = 0;           // 0: one file
  // harvest-record (the default) or lcm-logger; only harvest-record keeps
  // channels at a reduced rate and reports size, rate and free space.
  std::string logger = "harvest-record";
  double image_rate_hz = 0;                  // 0: every frame; else image_channels at most this often
  std::string image_channels = "CAMERA_.*";  // regular expression
  double status_s = 10;                      // size/rate/free-space line this often (0: never)
  double warn_free_mb = 1000;                // warn while less is free on the folder's disk
  double warn_fill_minutes = 10;             // warn while the disk would fill within this at the current rate
};

// One robot's hardware: the values a field set leaves open (CAN bus, camera
// and serial device names), read from a small site file (config/site/*.yaml)
// and substituted for ${KEY} in the processes' args and env
// (docs/field-setup.md). The launcher's --site FILE replaces the set's `site`
// file and --set site.KEY=VALUE overrides one value.
struct SiteSpec {
  std::filesystem::path file;                // empty: the set uses no site file
  std::map<std::string, std::string> values;
  // Site keys each process uses (process name -> keys), for the device check.
  std::map<std::string, std::vector<std::string>> used_by;
};

// What the command line says about the site: another file, single values.
struct SiteOverrides {
  std::filesystem::path file;           // replaces the set's `site` (relative to the working directory)
  std::vector<std::string> assignments;  // KEY=VALUE (the "site." prefix already removed)
};

struct SetSpec {
  std::string name;
  std::filesystem::path file;     // the set file
  std::filesystem::path bin_dir;  // where harvest-* executables are looked up
  std::string lcm_url;            // empty: LCM's default / $LCM_DEFAULT_URL
  std::string prefix;
  std::vector<ProcessSpec> processes;
  RecordingSpec recording;
  SiteSpec site;
};

// Splits the launcher's --set overrides: site.KEY=VALUE go to the site,
// everything else to the set file.
void split_site_overrides(const std::vector<std::string>& overrides, std::vector<std::string>& set_overrides,
                          SiteOverrides& site);

// Reads and validates a set (throws config::Error naming file and key).
// `bin_dir_override` replaces the set's bin_dir (e.g. from --bin-dir).
// `site` chooses another site file and overrides site values.
SetSpec parse_set(const config::Node& root, const std::filesystem::path& set_file,
                  const std::filesystem::path& bin_dir_override = {}, const SiteOverrides& site = {});
// The set file's keys, for the reference (docs/configuration.md).
std::vector<config::Section> set_schema();

SetSpec load_set(const std::filesystem::path& set_file, const std::filesystem::path& bin_dir_override = {},
                 const SiteOverrides& site = {});

// Start order respecting `after` (declaration order otherwise). Throws
// config::Error on unknown names or cycles.
std::vector<std::size_t> start_order(const SetSpec& set);

// Processes to run for a host group, or several comma-separated ("sim,robot"); empty: all.
std::vector<std::size_t> select_group(const SetSpec& set, const std::string& group);

// Resolved executable path, or nullopt if it cannot be found / run: a path
// as given (relative to the set file), else bin_dir, the launcher's own
// folder (harvest-record beside harvest-launch), then PATH.
std::optional<std::filesystem::path> resolve_executable(const SetSpec& set, const std::string& command);

// Everything that would stop the set from starting, one line each
// (missing executables, missing working directories, unwritable record folder).
std::vector<std::string> preflight(const SetSpec& set, const std::vector<std::size_t>& selected);

// Full argument vector (argv[0] = resolved or raw command) for a process.
std::vector<std::string> command_line(const SetSpec& set, const ProcessSpec& p);
// Whether the set records with harvest-record (else lcm-logger's options only).
bool is_harvest_record(const RecordingSpec& r);
// The recorder's command line (harvest-record or lcm-logger) for the set's recording.
std::vector<std::string> recorder_command_line(const SetSpec& set, const std::string& timestamp);

// Seconds to wait before restart number `restarts_done + 1`, or nullopt if
// the policy says not to restart after this exit.
std::optional<double> restart_delay(const RestartPolicy& policy, int restarts_done, bool failed);

}  // namespace harvest::launch
