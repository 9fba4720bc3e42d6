// What has happened to each fruit: attempts, outcomes and tallies, and the
// fruit given up for good, remembered by id, by fixed-camera position and by
// line of sight, so that neither the same fruit under a new track id nor a
// new fruit under a finished id is mistaken.
#pragma once

#include <Eigen/Core>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "harvest/fruit_outcome_t.hpp"
#include "servo/harvest/fruit.hpp"

namespace harvest::servo {

const char* outcome_name(int8_t outcome);

struct LedgerConfig {
  int max_attempts = 2;               // attempts per fruit in total
  double same_fruit_distance = 0.05;  // [m] a target this near a fruit given up is that fruit
  double same_sight_angle = 0.02;     // [rad] ... or one whose line of sight is this near one given up
  double reused_id_distance = 0.15;   // [m] a finished id seen this far from where it finished is another fruit
};

struct Tally {
  int picked = 0, lost = 0, unreachable = 0, failed_grasp = 0, aborted = 0;
};

class FruitLedger {
 public:
  explicit FruitLedger(LedgerConfig config) : cfg_(config) {}

  int attempts(int id) const;
  bool out_of_attempts(int id) const { return attempts(id) >= cfg_.max_attempts; }
  void begin_attempt(int id) { ++attempts_[id]; }
  // A certain verdict (a line of sight out of reach, an arm that cannot turn
  // to it): the next outcome gives the fruit up for good.
  void use_up_attempts(int id) { attempts_[id] = cfg_.max_attempts; }

  // Whether fixed-camera target `id` at `position` (seen along unit
  // `sight`, if the camera is known) may be selected: not finished, not a
  // fruit given up seen again under a new id (it is then finished too), not
  // out of attempts (a new id where an attempt failed carries that fruit's
  // attempts). A finished id seen far from where it finished, along
  // another line of sight, is another fruit: its record is forgotten.
  bool selectable(int id, const Eigen::Vector3d& position, const std::optional<Eigen::Vector3d>& sight);
  bool finished(int id) const { return finished_.count(id) > 0; }

  // Records an outcome. `fruit` is what the controller knew of it (nullptr
  // for a target rejected at selection, then `target` is where it was seen).
  // A picked fruit has left the tree, and with it its fixed-camera target:
  // an id still seen afterwards is a fruit still there (the camera-in-hand
  // followed a neighbour to the grasp, or the tracker passed the id on), so
  // it may be tried again. Any other fruit is given up for good once out of
  // attempts.
  const fruit_outcome_t& record(int8_t outcome, int id, const Eigen::Vector3d& target, const std::string& detail,
                                double cycle_time_s, const Eigen::Vector3d& tool_position, const Fruit* fruit);

  const std::vector<fruit_outcome_t>& outcomes() const { return outcomes_; }
  const Tally& tally() const { return tally_; }

 private:
  LedgerConfig cfg_;
  std::map<int, int> attempts_;
  std::set<int> finished_;
  // Where each finished id was (fixed camera, at selection), and its line of
  // sight: the tracker may hand a finished fruit's id on to another fruit
  // (a neighbour once the fruit is picked), which is then a new fruit.
  std::map<int, Eigen::Vector3d> finished_at_;
  std::map<int, Eigen::Vector3d> finished_sight_;
  // Every attempt that did not pick its fruit: where the fruit was (fixed
  // camera, at selection), its line of sight (unit direction), the attempts
  // made by then, and whether that gave the fruit up. The tracker gives a
  // fruit a new id after the arm has hidden it (a doubtful depth jumps by far
  // more than same_fruit_distance from image to image, the direction does
  // not): a new id there is a fruit given up, or takes over the attempts of
  // one not yet given up (else a full-tree run tried one fruit 40 times
  // under 40 ids until its time limit).
  struct Tried {
    Eigen::Vector3d at;
    std::optional<Eigen::Vector3d> sight;
    int attempts = 0;
    bool given_up = false;
  };
  std::vector<Tried> tried_;
  std::vector<fruit_outcome_t> outcomes_;
  Tally tally_;
};

}  // namespace harvest::servo
