// Key files: round trip, permissions, malformed files, no silent overwrite,
// and the harvest-keygen tool.
#include "security/key.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "test_support.hpp"

namespace sec = harvest::security;
namespace fs = std::filesystem;

namespace {

struct KeyFile : ::testing::Test {
  fs::path dir;
  void SetUp() override {
    dir = fs::temp_directory_path() / ("harvest-key-test-" + std::to_string(getpid()));
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  std::string path(const std::string& name) const { return (dir / name).string(); }
  void write_text(const std::string& p, const std::string& text, mode_t mode = 0600) {
    std::ofstream(p) << text;
    ::chmod(p.c_str(), mode);
  }
};

TEST_F(KeyFile, RoundTrip) {
  auto k = sec::generate_key(sec::KeyKind::robot);
  sec::write_key(path("k"), k);
  struct stat st {};
  ASSERT_EQ(::stat(path("k").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600);
  auto back = sec::load_key(path("k"));
  EXPECT_EQ(back.bytes, k.bytes);
  EXPECT_EQ(back.kind, sec::KeyKind::robot);
  EXPECT_EQ(back.id(), k.id());
  EXPECT_EQ(k.id().size(), 8u);
  auto s = sec::generate_key(sec::KeyKind::sim);
  EXPECT_NE(s.bytes, k.bytes);
  sec::write_key(path("s"), s);
  EXPECT_EQ(sec::load_key(path("s")).kind, sec::KeyKind::sim);
}

TEST_F(KeyFile, NoSilentOverwrite) {
  sec::write_key(path("k"), sec::generate_key(sec::KeyKind::robot));
  EXPECT_THROW(sec::write_key(path("k"), sec::generate_key(sec::KeyKind::robot)), std::runtime_error);
  ::chmod(path("k").c_str(), 0644);
  auto k2 = sec::generate_key(sec::KeyKind::robot);
  sec::write_key(path("k"), k2, /*overwrite=*/true);
  EXPECT_EQ(sec::load_key(path("k")).bytes, k2.bytes);  // and the mode is 0600 again
}

TEST_F(KeyFile, GroupOrWorldReadableRefused) {
  sec::write_key(path("k"), sec::generate_key(sec::KeyKind::robot));
  ::chmod(path("k").c_str(), 0640);
  try {
    sec::load_key(path("k"));
    FAIL() << "a group-readable key was loaded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("chmod 600"), std::string::npos) << e.what();
  }
  ::chmod(path("k").c_str(), 0604);
  EXPECT_THROW(sec::load_key(path("k")), std::runtime_error);
}

TEST_F(KeyFile, MalformedRefused) {
  const std::string hex(64, 'a');
  EXPECT_THROW(sec::load_key(path("missing")), std::runtime_error);
  write_text(path("magic"), "something else\nsim " + hex + "\n");
  EXPECT_THROW(sec::load_key(path("magic")), std::runtime_error);
  write_text(path("kind"), "harvest-command-key v1\nlab " + hex + "\n");
  EXPECT_THROW(sec::load_key(path("kind")), std::runtime_error);
  write_text(path("short"), "harvest-command-key v1\nsim " + hex.substr(2) + "\n");
  EXPECT_THROW(sec::load_key(path("short")), std::runtime_error);
  write_text(path("nothex"), "harvest-command-key v1\nsim " + std::string(64, 'g') + "\n");
  EXPECT_THROW(sec::load_key(path("nothex")), std::runtime_error);
  write_text(path("extra"), "harvest-command-key v1\nsim " + hex + " more\n");
  EXPECT_THROW(sec::load_key(path("extra")), std::runtime_error);
  write_text(path("good"), "harvest-command-key v1\nsim " + hex + "\n");
  EXPECT_EQ(sec::load_key(path("good")).bytes[0], 0xaa);
  fs::create_directories(dir / "adir");
  ::chmod(path("adir").c_str(), 0700);
  EXPECT_THROW(sec::load_key(path("adir")), std::runtime_error);
}

TEST_F(KeyFile, KeygenTool) {
  const std::string bin = harvest::testing::bin("harvest-keygen") + " ";
  ASSERT_EQ(std::system((bin + path("robot.key") + " >/dev/null").c_str()), 0);
  EXPECT_EQ(sec::load_key(path("robot.key")).kind, sec::KeyKind::robot);
  ASSERT_EQ(std::system((bin + path("sim.key") + " --sim >/dev/null").c_str()), 0);
  EXPECT_EQ(sec::load_key(path("sim.key")).kind, sec::KeyKind::sim);
  EXPECT_EQ(sec::load_key(path("sim.key")).bytes, sec::sim_key().bytes);
  auto before = sec::load_key(path("robot.key")).bytes;
  // An existing key is kept unless --force: exit 1, file unchanged.
  EXPECT_EQ(WEXITSTATUS(std::system((bin + path("robot.key") + " 2>/dev/null").c_str())), 1);
  EXPECT_EQ(sec::load_key(path("robot.key")).bytes, before);
  ASSERT_EQ(std::system((bin + path("robot.key") + " --force >/dev/null").c_str()), 0);
  EXPECT_NE(sec::load_key(path("robot.key")).bytes, before);
  EXPECT_EQ(WEXITSTATUS(std::system((bin + "2>/dev/null").c_str())), 2);
  // --keep leaves a valid key of the asked kind alone, refuses another kind.
  const auto sim_before = sec::load_key(path("sim.key")).bytes;
  ASSERT_EQ(std::system((bin + path("sim.key") + " --sim --keep >/dev/null").c_str()), 0);
  EXPECT_EQ(sec::load_key(path("sim.key")).bytes, sim_before);
  EXPECT_EQ(WEXITSTATUS(std::system((bin + path("sim.key") + " --keep 2>/dev/null").c_str())), 1);
  ASSERT_EQ(std::system((bin + path("new.key") + " --sim --keep >/dev/null").c_str()), 0);
  EXPECT_EQ(sec::load_key(path("new.key")).kind, sec::KeyKind::sim);
  EXPECT_EQ(WEXITSTATUS(std::system((bin + path("x.key") + " --keep --force 2>/dev/null").c_str())), 2);
}

TEST(SimKey, IsTheSameEverywhereAndMarkedSim) {
  // Reference logs signed on one machine replay on another: the sim key is a
  // fixed hash, not random (its id is part of the recorded configuration).
  const auto a = sec::sim_key(), b = sec::sim_key();
  EXPECT_EQ(a.bytes, b.bytes);
  EXPECT_EQ(a.kind, sec::KeyKind::sim);
  EXPECT_EQ(a.id(), "cf4a1ec1") << "the sim key changed: every reference log must be re-recorded";
  EXPECT_NE(a.bytes, sec::generate_key(sec::KeyKind::sim).bytes);
}

}  // namespace
