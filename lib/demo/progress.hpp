// What the demo prints while a run goes: one line whenever the controller's
// state, current fruit or tallies change, with the simulator's count of fruit
// still on the tree. Pure: messages in, lines out.
#pragma once

#include <optional>
#include <string>

#include "harvest/harvest_status_t.hpp"
#include "harvest/sim_truth_t.hpp"

namespace harvest::demo {

class Progress {
 public:
  explicit Progress(int run) : run_(run) {}

  // Returns a line to print when the status differs from the last one shown.
  std::optional<std::string> on_status(const harvest_status_t& s, double elapsed_s);
  void on_truth(const sim_truth_t& t);

  bool controller_seen() const { return last_.has_value(); }
  // True once the controller has left IDLE (the START was obeyed).
  bool started() const { return started_; }
  const std::string& state() const { return state_; }
  int on_tree() const { return on_tree_; }

 private:
  int run_;
  std::optional<std::string> last_;
  std::string state_;
  bool started_ = false;
  int on_tree_ = -1;  // fruit still on the tree (simulator truth), -1 unknown
};

}  // namespace harvest::demo
