#include "runtime/netcheck.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "test_support.hpp"

using harvest::testing::TempDir;

namespace {
void fake_proc(const TempDir& d, const std::string& routes, long rmem_max, long rmem_default) {
  std::filesystem::create_directories(d / "net");
  std::filesystem::create_directories(d.path() / "sys/net/core");
  std::ofstream(d / "net/route") << "Iface\tDestination\tGateway\tFlags\tRefCnt\tUse\tMetric\tMask\tMTU\tWindow\tIRTT\n"
                                 << routes;
  std::ofstream(d.path() / "sys/net/core/rmem_max") << rmem_max << "\n";
  std::ofstream(d.path() / "sys/net/core/rmem_default") << rmem_default << "\n";
}
bool all_ok(const std::vector<harvest::rt::NetFinding>& f) {
  for (const auto& x : f)
    if (!x.ok) return false;
  return true;
}
}  // namespace

TEST(NetCheck, HealthyHost) {
  TempDir d;
  fake_proc(d, "lo\t000000E0\t00000000\t0001\t0\t0\t0\t000000F0\t0\t0\t0\n", 16 << 20, 8 << 20);
  EXPECT_TRUE(all_ok(harvest::rt::check_network(d.path())));
}

TEST(NetCheck, MissingMulticastRouteSaysWhatToRun) {
  TempDir d;
  fake_proc(d, "eth0\t0000A8C0\t00000000\t0001\t0\t0\t0\t00FFFFFF\t0\t0\t0\n", 16 << 20, 8 << 20);
  const auto f = harvest::rt::check_network(d.path());
  ASSERT_FALSE(f[0].ok);
  EXPECT_NE(f[0].what.find("no route for multicast"), std::string::npos);
  EXPECT_NE(f[0].fix.find("tools/harvest netfix"), std::string::npos);
}

TEST(NetCheck, DefaultRouteCarriesMulticast) {
  TempDir d;
  fake_proc(d, "eth0\t00000000\t0101A8C0\t0003\t0\t0\t0\t00000000\t0\t0\t0\n", 16 << 20, 8 << 20);
  EXPECT_TRUE(harvest::rt::check_network(d.path())[0].ok);
}

TEST(NetCheck, SmallReceiveBuffersAreReported) {
  TempDir d;
  fake_proc(d, "lo\t000000E0\t00000000\t0001\t0\t0\t0\t000000F0\t0\t0\t0\n", 212992, 212992);
  const auto f = harvest::rt::check_network(d.path());
  EXPECT_FALSE(all_ok(f));
  EXPECT_FALSE(f[1].ok);
  EXPECT_NE(f[1].what.find("rmem_max = 212992"), std::string::npos);
}
