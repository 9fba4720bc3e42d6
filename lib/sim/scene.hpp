// The simulated world: fruit, leaves and branches drawn from a scenario with
// its seed, and what happens to the fruit over time (wind, picking).
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "sim/scenario.hpp"

namespace harvest::sim {

enum class FruitState : int8_t { kOnTree = 0, kHeld = 1, kPicked = 2, kKnocked = 3 };

struct Fruit {
  int id = 0;
  Vec3 stem_position = Vec3::Zero();  // rest position on the tree [m]
  Vec3 position = Vec3::Zero();       // current centre [m]
  double radius = 0.0;        // [m]
  Vec3 albedo_rgb = Vec3::Zero();     // peel colour at full light, 0..255
  Vec3 sway_direction = Vec3::UnitX();
  double sway_phase = 0.0;
  FruitState state = FruitState::kOnTree;
  bool reachable = true;
  int grasp_attempts = 0;
  Vec3 grasp_offset = Vec3::Zero();  // fruit centre minus TCP at the last closure
  int64_t outcome_utime = 0;
};

// A leaf: a flat lens-shaped blade. A point q in its plane is inside when
// |q.v| <= half_width * (1 - (q.u / half_length)^2).
struct Leaf {
  Vec3 centre = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ(), u = Vec3::UnitX(), v = Vec3::UnitY();  // orthonormal: blade normal, midrib, across
  double half_length = 0.0, half_width = 0.0;
  Vec3 albedo_rgb = Vec3::Zero();
};

// Branches are chains of overlapping spheres ("beads"), which keeps the
// renderer to two primitive types.
struct Bead {
  Vec3 centre = Vec3::Zero();
  double radius = 0.0;
};

class Scene {
 public:
  // Deterministic for a given scenario (its seed).
  explicit Scene(const Scenario& scenario);

  const std::vector<Fruit>& fruit() const { return fruit_; }
  std::vector<Fruit>& fruit() { return fruit_; }
  const std::vector<Leaf>& leaves() const { return leaves_; }
  const std::vector<Bead>& beads() const { return beads_; }
  const Lighting& lighting() const { return lighting_; }
  // Places one more leaf (tests, hand-made scenes).
  void add_leaf(const Leaf& leaf) { leaves_.push_back(leaf); }

  // Moves fruit still on the tree with the wind at simulation time t [s].
  void apply_wind(double t);
  // The sway amplitude's factor at t [s] from the gusts (1 between gusts).
  double gust_gain(double t) const;

 private:
  void place_fruit(const Scenario& s, std::mt19937_64& rng);
  void grow_branches(const Scenario& s, std::mt19937_64& rng);
  void grow_leaves(const Scenario& s, std::mt19937_64& rng);

  std::vector<Fruit> fruit_;
  std::vector<Leaf> leaves_;
  std::vector<Bead> beads_;
  Lighting lighting_;
  Wind wind_;
  std::vector<double> gust_starts_;  // [s] ascending
};

// Tool orientation whose z axis points from `from` to `to`, with the tool x
// axis as close as possible to the base +x axis (the thesis base frame's
// "down"), so the hand image is upright.
Mat3 look_at_rotation(const Vec3& from, const Vec3& to);

// The tool's pose at the start: at start_tool_position, looking at start_look_at.
Placement start_tool_pose(const ArmSetup& arm);

}  // namespace harvest::sim
