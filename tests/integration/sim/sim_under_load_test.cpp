// The whole simulated robot on a machine kept busy: two CPU-bound processes
// (started and stopped by this test, by PID) beside harvest-demo. The
// simulator renders on its own thread, so its drives, physics and ROBOT_STATE
// keep time and the run still ends with the fruit picked (docs/simulator.md,
// "Threads"). On main's simulator, which rendered on the loop, this run failed
// under the same load: the robot link faulted with "no PDO from the drive"
// (docs/simulator.md, "Under load"). The direct set picked under this load
// on main's simulator too, so it is not repeated here.
#include <gtest/gtest.h>

#include <memory>
#include <regex>

#include "../demo/demo_support.hpp"
#include "runtime/json.hpp"

namespace ht = harvest::testing;
namespace rt = harvest::rt;

namespace {

// Two busy loops, one per core of the test machine, for the test's lifetime.
class Load {
 public:
  explicit Load(const ht::TempDir& dir) {
    for (int i = 0; i < 2; ++i)
      hogs_.push_back(std::make_unique<ht::ChildProcess>(std::vector<std::string>{"sh", "-c", "while :; do :; done"},
                                                         dir / ("hog" + std::to_string(i) + ".txt")));
  }
  ~Load() {
    for (auto& h : hogs_) h->stop();
  }
  bool running() {
    for (auto& h : hogs_)
      if (!h->running()) return false;
    return true;
  }

 private:
  std::vector<std::unique_ptr<ht::ChildProcess>> hogs_;
};

// The field set: simulated CiA 402 drives on the virtual CAN bus with the
// robot link's default deadlines (the drives' 25 ms RPDO timeout), the board on TCP.
TEST(SimUnderLoad, TheFieldSetPicksExperimentOneBesideTwoBusyLoops) {
  ht::TempDir dir;
  Load load(dir);
  std::string out;
  const int code = ht::run_demo(
      {"--set", "config/sets/sim.yaml", "--scenario", "config/scenarios/experiment1.yaml", "--image-rate", "2"},
      dir.path(), &out, std::chrono::seconds(300));
  EXPECT_TRUE(load.running()) << "the load ended before the run did";
  const std::string launch = ht::slurp(dir / "out" / "run0-launch.log");
  ASSERT_EQ(code, 0) << out << launch;
  const std::string summary = ht::slurp(dir / "summary.json");
  EXPECT_EQ(rt::Json::parse(summary)["picked"], 1) << summary << out;
  // The simulator says how it kept time (logged here for the record).
  std::smatch m;
  ASSERT_TRUE(std::regex_search(launch, m, std::regex("timekeeping over [^\\n]*"))) << launch;
  std::cout << m[0] << "\n";
}

}  // namespace
