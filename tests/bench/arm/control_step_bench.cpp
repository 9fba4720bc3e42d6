// One robot-link control step for the 7-axis K-1207i-class arm: forward
// kinematics, Cartesian clipping, damped-least-squares IK with joint-limit
// null space and limit locking, and joint velocity/acceleration/position
// limits (what RobotLinkNode::tick computes besides CAN I/O), compared with the
// obvious Eigen ways of mapping a twist to joint velocities: the pseudo-inverse
// from JacobiSVD and from completeOrthogonalDecomposition (no damping, no
// redundancy resolution, no limits). The counter `residual_mm_s` is the
// tracking error |J qdot - twist| of each way, so speed is compared at equal work.
// Also: evaluating a pose-goal trajectory (pose + feed-forward twist), done
// once per control step while a goal motion runs; and the robot link's
// decision for a new pose goal: the Cartesian dry run (the control law run
// offline over the whole motion), the joint-space fallback's IK.
#include <benchmark/benchmark.h>

#include <Eigen/QR>
#include <Eigen/SVD>

#include "arm/motion_safety.hpp"
#include "arm/robot_link_node.hpp"
#include "arm/trajectory.hpp"
#include "kinematics/diff_ik.hpp"

namespace {

using namespace harvest;

const kinematics::ArmModel& model() {
  static const kinematics::ArmModel m = kinematics::ArmModel::load("config/arm/k1207i.yaml");
  return m;
}

kinematics::Twist test_twist() {
  kinematics::Twist t;
  t << 0.05, 0.1, -0.08, 0.1, -0.2, 0.05;
  return t;
}

// A few configurations around home so branch prediction and caches see variety.
std::vector<Eigen::VectorXd> configurations() {
  std::vector<Eigen::VectorXd> qs;
  for (int k = 0; k < 16; ++k) {
    Eigen::VectorXd q = model().home;
    for (int i = 0; i < q.size(); ++i) q[i] += 0.05 * std::sin(1.3 * k + 0.7 * i);
    qs.push_back(q);
  }
  return qs;
}

double residual(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, const kinematics::Twist& v) {
  return (kinematics::tool_jacobian(model(), q) * qdot - v).norm() * 1000.0;
}

void BM_RobotLinkControlStep(benchmark::State& state) {
  const auto qs = configurations();
  const kinematics::Twist v = test_twist();
  arm::Workspace ws;
  const arm::MotionLimits lim;
  const double dt = 0.01;
  Eigen::VectorXd previous = Eigen::VectorXd::Zero(model().dof());
  std::size_t k = 0;
  double res = 0.0;
  for (auto _ : state) {
    const Eigen::VectorXd& q = qs[k++ % qs.size()];
    const Eigen::Isometry3d tool = kinematics::tool_pose(model(), q);
    const arm::ClippedTwist c = arm::clip_twist(v, tool.translation(), ws, lim, dt);
    const Eigen::VectorXd want =
        kinematics::joint_velocity_within_limits(model(), q, c.twist, dt, {}, nullptr, &previous);
    const auto out = kinematics::limit_joint_velocity(model(), q, previous, want, dt);
    benchmark::DoNotOptimize(out.qdot.data());
    if (k == 1) res = residual(q, want, v);
  }
  state.counters["residual_mm_s"] = res;
}
BENCHMARK(BM_RobotLinkControlStep);

// Just our IK (DLS + null space, no limits), for a like-for-like comparison with the Eigen ways below.
void BM_OurDlsIk(benchmark::State& state) {
  const auto qs = configurations();
  const kinematics::Twist v = test_twist();
  std::size_t k = 0;
  double res = 0.0;
  for (auto _ : state) {
    const Eigen::VectorXd& q = qs[k++ % qs.size()];
    const Eigen::VectorXd qdot = kinematics::joint_velocity_for_twist(model(), q, v);
    benchmark::DoNotOptimize(qdot.data());
    if (k == 1) res = residual(q, qdot, v);
  }
  state.counters["residual_mm_s"] = res;
}
BENCHMARK(BM_OurDlsIk);

void BM_EigenJacobiSvdPinv(benchmark::State& state) {
  const auto qs = configurations();
  const kinematics::Twist v = test_twist();
  std::size_t k = 0;
  double res = 0.0;
  for (auto _ : state) {
    const Eigen::VectorXd& q = qs[k++ % qs.size()];
    const kinematics::Jacobian j = kinematics::tool_jacobian(model(), q);
    const Eigen::VectorXd qdot = j.jacobiSvd(Eigen::ComputeThinU | Eigen::ComputeThinV).solve(v);
    benchmark::DoNotOptimize(qdot.data());
    if (k == 1) res = residual(q, qdot, v);
  }
  state.counters["residual_mm_s"] = res;
}
BENCHMARK(BM_EigenJacobiSvdPinv);

void BM_EigenCodPinv(benchmark::State& state) {
  const auto qs = configurations();
  const kinematics::Twist v = test_twist();
  std::size_t k = 0;
  double res = 0.0;
  for (auto _ : state) {
    const Eigen::VectorXd& q = qs[k++ % qs.size()];
    const kinematics::Jacobian j = kinematics::tool_jacobian(model(), q);
    const Eigen::VectorXd qdot = j.completeOrthogonalDecomposition().pseudoInverse() * v;
    benchmark::DoNotOptimize(qdot.data());
    if (k == 1) res = residual(q, qdot, v);
  }
  state.counters["residual_mm_s"] = res;
}
BENCHMARK(BM_EigenCodPinv);

// Damped least squares written the textbook way: J^T (J J^T + lambda^2 I)^-1 v with an LDLT of the 6x6.
void BM_EigenDlsNormalEquations(benchmark::State& state) {
  const auto qs = configurations();
  const kinematics::Twist v = test_twist();
  std::size_t k = 0;
  double res = 0.0;
  for (auto _ : state) {
    const Eigen::VectorXd& q = qs[k++ % qs.size()];
    const kinematics::Jacobian j = kinematics::tool_jacobian(model(), q);
    const Eigen::Matrix<double, 6, 6> jjt = j * j.transpose() + 1e-6 * Eigen::Matrix<double, 6, 6>::Identity();
    const Eigen::VectorXd qdot = j.transpose() * jjt.ldlt().solve(v);
    benchmark::DoNotOptimize(qdot.data());
    if (k == 1) res = residual(q, qdot, v);
  }
  state.counters["residual_mm_s"] = res;
}
BENCHMARK(BM_EigenDlsNormalEquations);

void BM_ForwardKinematics(benchmark::State& state) {
  const auto qs = configurations();
  std::size_t k = 0;
  for (auto _ : state) {
    const Eigen::Isometry3d t = kinematics::tool_pose(model(), qs[k++ % qs.size()]);
    benchmark::DoNotOptimize(t.data());
  }
}
BENCHMARK(BM_ForwardKinematics);

void BM_Jacobian(benchmark::State& state) {
  const auto qs = configurations();
  std::size_t k = 0;
  for (auto _ : state) {
    const kinematics::Jacobian j = kinematics::tool_jacobian(model(), qs[k++ % qs.size()]);
    benchmark::DoNotOptimize(j.data());
  }
}
BENCHMARK(BM_Jacobian);

// The pose-goal reference of one control step: pose(t) and twist(t) of a 0.3 m, 0.8 rad goal motion, at times
// spread over the motion (ramps and cruise).
void BM_CartesianTrajectoryPoseAndTwist(benchmark::State& state) {
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity(), b = Eigen::Isometry3d::Identity();
  a.translation() = Eigen::Vector3d(-0.4, 0.7, -0.3);
  b.translation() = Eigen::Vector3d(-0.2, 0.9, -0.2);
  b.linear() = Eigen::AngleAxisd(0.8, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix();
  const arm::CartesianTrajectory tr(a, b, {0.381, 1.0, 1.0, 2.0});
  const double dt = 0.01;
  double t = 0.0;
  for (auto _ : state) {
    const Eigen::Isometry3d p = tr.pose(t);
    const kinematics::Twist v = tr.twist(t);
    benchmark::DoNotOptimize(p.data());
    benchmark::DoNotOptimize(v.data());
    t += dt;
    if (t > tr.duration()) t = 0.0;
  }
}
BENCHMARK(BM_CartesianTrajectoryPoseAndTwist);

const arm::RobotLinkConfig& link_config() {
  static const arm::RobotLinkConfig c = [] {
    auto doc = config::Document::load_file("config/arm/robot_link.yaml");
    return arm::RobotLinkConfig::from_config(doc.root());
  }();
  return c;
}

arm::CartesianTrajectory::Limits goal_limits() {
  const auto& l = link_config().limits;
  return {l.linear_speed, l.angular_speed, l.linear_acceleration, l.angular_acceleration};
}

// The tool at its home pose turned by `angle` about `axis` (base frame), position kept: an ORIENT step.
Eigen::Isometry3d turned_at_home(double angle, const Eigen::Vector3d& axis) {
  const auto& c = link_config();
  Eigen::Isometry3d goal = kinematics::tool_pose(c.model, c.model.home);
  goal.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix() * goal.linear();
  return goal;
}

// The dry run of a typical ORIENT re-orientation: 1 rad from the home joints
// (the approach axis, +y at home, turned toward -x and +z: up and to the
// right), Cartesian path of 1.79 s plus settling, every 10 ms SYNC period.
void BM_PoseGoalDryRun1Rad(benchmark::State& state) {
  const auto& c = link_config();
  const Eigen::Isometry3d start = kinematics::tool_pose(c.model, c.model.home);
  const arm::CartesianTrajectory path(start, turned_at_home(1.0, Eigen::Vector3d(1, 0, 1)), goal_limits());
  const Eigen::VectorXd previous = Eigen::VectorXd::Zero(c.model.dof());
  arm::PoseGoalDryRun d;
  for (auto _ : state) {
    d = arm::dry_run_pose_goal(c, path, c.model.home, previous, c.dry_run);
    benchmark::DoNotOptimize(d.q.data());
  }
  state.counters["reached"] = d.reached;
  state.counters["steps"] = d.steps;
  state.counters["error_mm"] = 1000.0 * d.position_error;
  state.counters["error_mrad"] = 1000.0 * d.orientation_error;
  state.counters["path_s"] = path.duration();
}
BENCHMARK(BM_PoseGoalDryRun1Rad)->Unit(benchmark::kMillisecond);

// A whole decision that ends in joint space: a re-orientation from home the
// straight path cannot complete (the aim point (-0.8, 1.0, -0.3) m of the
// RobotLinkNode tests, 0.62 rad), dry run + solve_pose (one restart) + the
// joint path's workspace check, all at once (the node spreads the IK over
// its control periods, 150 iterations a period).
void BM_PoseGoalPlanJointSpace(benchmark::State& state) {
  const auto& c = link_config();
  const Eigen::Isometry3d start = kinematics::tool_pose(c.model, c.model.home);
  // The servo controller's aim (servo::aim_rotation, thesis eq. 6-19..6-22).
  const Eigen::Vector3d m = start.linear().transpose() * (Eigen::Vector3d(-0.8, 1.0, -0.3) - start.translation());
  const double alpha = std::atan2(m.y(), m.z());
  Eigen::Matrix3d rx, ry;
  rx << 1, 0, 0, 0, std::cos(alpha), std::sin(alpha), 0, -std::sin(alpha), std::cos(alpha);
  const Eigen::Vector3d m1 = rx.transpose() * m;
  const double beta = -std::atan2(m1.x(), m1.z());
  ry << std::cos(beta), 0, -std::sin(beta), 0, 1, 0, std::sin(beta), 0, std::cos(beta);
  Eigen::Isometry3d goal = start;
  goal.linear() = start.linear() * rx * ry;
  const arm::CartesianTrajectory path(start, goal, goal_limits());
  const Eigen::VectorXd previous = Eigen::VectorXd::Zero(c.model.dof());
  arm::PoseGoalPlan plan;
  for (auto _ : state) {
    plan = arm::plan_pose_goal(c, path, c.model.home, previous);
    benchmark::DoNotOptimize(plan.dry_run.q.data());
  }
  state.counters["joint_space"] = plan.way == arm::PoseGoalPlan::Way::kJointSpace;
  state.counters["angle_rad"] = Eigen::AngleAxisd(goal.linear() * start.linear().transpose()).angle();
}
BENCHMARK(BM_PoseGoalPlanJointSpace)->Unit(benchmark::kMillisecond);

// One slice of the pose-goal IK as the node runs it after each SYNC
// (ik_iterations_per_period, 150, iterations of kinematics::PoseSolver) on an
// unreachable goal (the worst case: every start runs out, 9000 iterations =
// 60 periods).
void BM_PoseSolverSlice(benchmark::State& state) {
  const auto& c = link_config();
  Eigen::Isometry3d goal = kinematics::tool_pose(c.model, c.model.home);
  goal.translation() = Eigen::Vector3d(0.0, 1.25, -0.3);
  goal.linear() = Eigen::AngleAxisd(3.14159, Eigen::Vector3d::UnitX()).toRotationMatrix() * goal.linear();
  kinematics::PoseSolver solver(c.model, goal, c.model.home);
  for (auto _ : state) {
    if (solver.done()) {
      state.PauseTiming();
      solver = kinematics::PoseSolver(c.model, goal, c.model.home);
      state.ResumeTiming();
    }
    solver.run(c.ik_iterations_per_period);
  }
}
BENCHMARK(BM_PoseSolverSlice)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
