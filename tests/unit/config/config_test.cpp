#include "config/config.hpp"
#include "config/schema.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "test_support.hpp"

using harvest::config::Document;
using harvest::config::Error;
using harvest::config::Range;

namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Config, ReadsTypedValuesAndDefaults) {
  auto doc = Document::load_string("gain: 2.5\nname: fixed\nenabled: true\ncount: 3\n", "test.yaml");
  auto root = doc.root();
  EXPECT_DOUBLE_EQ(root.required<double>("gain"), 2.5);
  EXPECT_EQ(root.required<std::string>("name"), "fixed");
  EXPECT_TRUE(root.required<bool>("enabled"));
  EXPECT_EQ(root.get<int>("count", 7), 3);
  EXPECT_EQ(root.get<int>("missing", 7), 7);
  EXPECT_NO_THROW(doc.check_unused());
  // Defaults land in the effective configuration.
  EXPECT_NE(doc.emit().find("missing: 7"), std::string::npos);
}

TEST(Config, MissingRequiredNamesFileAndKey) {
  auto doc = Document::load_string("detector:\n  min_area: 10\n", "det.yaml");
  const auto msg = error_of([&] { doc.root().child("detector").required<double>("max_area"); });
  EXPECT_NE(msg.find("det.yaml"), std::string::npos) << msg;
  EXPECT_NE(msg.find("detector.max_area"), std::string::npos) << msg;
  EXPECT_NE(msg.find("required"), std::string::npos) << msg;
}

TEST(Config, WrongTypeIsAnError) {
  auto doc = Document::load_string("rate: fast\nlist: [1, 2]\n", "t.yaml");
  auto msg = error_of([&] { doc.root().required<double>("rate"); });
  EXPECT_NE(msg.find("t.yaml: rate: expected a number, got 'fast'"), std::string::npos) << msg;
  msg = error_of([&] { doc.root().required<double>("list"); });
  EXPECT_NE(msg.find("got a list"), std::string::npos) << msg;
}

TEST(Config, OutOfRangeIsAnError) {
  auto doc = Document::load_string("speed: 2.0\nn: -1\n", "arm.yaml");
  auto msg = error_of([&] { doc.root().required<double>("speed", Range<double>{0.0, 0.381}); });
  EXPECT_NE(msg.find("arm.yaml: speed: expected a number in [0.000000, 0.381000], got 2.0"), std::string::npos) << msg;
  msg = error_of([&] { doc.root().get<int>("n", 1, Range<int>{0}); });
  EXPECT_NE(msg.find(">= 0"), std::string::npos) << msg;
}

TEST(Config, UnknownKeysAreErrors) {
  auto doc = Document::load_string("gain: 1\ngian: 2\nsub:\n  a: 1\n  b: 2\n", "typo.yaml");
  doc.root().required<double>("gain");
  doc.root().child("sub").required<int>("a");
  const auto msg = error_of([&] { doc.check_unused(); });
  EXPECT_NE(msg.find("typo.yaml: unknown keys: gian, sub.b"), std::string::npos) << msg;
}

TEST(Config, ChoiceAndNumbers) {
  auto doc = Document::load_string("mode: thesis\nk: [1, 2, 3]\nbad: [1, x]\n", "c.yaml");
  EXPECT_EQ(doc.root().choice("mode", "improved", {"thesis", "improved"}), "thesis");
  EXPECT_EQ(doc.root().numbers("k", 3), (std::vector<double>{1, 2, 3}));
  EXPECT_NE(error_of([&] { doc.root().numbers("k", 5); }).find("a list of 5 numbers, got 3"), std::string::npos);
  EXPECT_NE(error_of([&] { doc.root().numbers("bad"); }).find("element 1"), std::string::npos);
  auto doc2 = Document::load_string("mode: fancy\n", "c.yaml");
  EXPECT_NE(error_of([&] {
              doc2.root().choice("mode", "thesis", {"thesis", "improved"});
            }).find("one of {thesis, improved}, got 'fancy'"),
            std::string::npos);
}

TEST(Config, OverridesApplyBeforeReading) {
  auto doc = Document::load_string("a:\n  b: 1\n", "o.yaml");
  doc.apply_override("a.b=5");
  doc.apply_override("c.d.e=hello");
  EXPECT_EQ(doc.root().child("a").required<int>("b"), 5);
  EXPECT_EQ(doc.root().child("c").child("d").required<std::string>("e"), "hello");
  EXPECT_THROW(doc.apply_override("novalue"), Error);
  EXPECT_THROW(doc.apply_override("a.b.x=1"), Error);  // a.b is a scalar
}

// An override's key path names keys and stays shallow: hundreds of parts
// once emitted a configuration that did not load again (config_loader_fuzz,
// regression-override-path-depth in its corpus).
// A key given twice is an error naming both lines (yaml-cpp keeps both: one
// was read, the other emitted; config_loader_fuzz,
// regression-duplicate-key in its corpus).
TEST(Config, AKeyGivenTwiceIsRefusedWithBothLines) {
  EXPECT_EQ(error_of([] { Document::load_string("a: 1\nb:\n  c: 2\n  c: 3\n", "d.yaml"); }),
            "d.yaml:4: key 'c' given twice in one mapping (first on line 3)");
  EXPECT_THROW(Document::load_string("a: 1\na: 1\n", "d.yaml"), Error);
  EXPECT_THROW(Document::load_string("l:\n  - {x: 1, x: 2}\n", "d.yaml"), Error);
  EXPECT_NO_THROW(Document::load_string("a: {x: 1}\nb: {x: 1}\n", "d.yaml"));  // same key, other mappings
}

TEST(Config, OverrideKeyPathsAreNonEmptyAndShallow) {
  auto doc = Document::load_string("a: 1\n", "o.yaml");
  EXPECT_THROW(doc.apply_override("x..y=1"), Error);
  EXPECT_THROW(doc.apply_override(".x=1"), Error);
  EXPECT_THROW(doc.apply_override("x.=1"), Error);
  std::string deep = "k";
  for (std::size_t i = 1; i < Document::kMaxOverrideDepth; ++i) deep += ".k";
  doc.apply_override(deep + "=1");  // at the limit: fine
  EXPECT_THROW(doc.apply_override("j." + deep + "=1"), Error);
  std::string hundreds;
  for (int i = 0; i < 300; ++i) hundreds += "/c.";
  EXPECT_THROW(doc.apply_override(hundreds + "x=1"), Error);
  // What is emitted loads again.
  EXPECT_NO_THROW(Document::load_string(doc.emit(), "<effective>"));
}

TEST(Config, FileErrorsNameTheFile) {
  harvest::testing::TempDir dir;
  EXPECT_NE(error_of([&] { Document::load_file(dir / "nope.yaml"); }).find("nope.yaml: configuration file not found"),
            std::string::npos);
  std::ofstream(dir / "bad.yaml") << "a: [1, 2\n";
  const auto msg = error_of([&] { Document::load_file(dir / "bad.yaml"); });
  EXPECT_NE(msg.find("bad.yaml"), std::string::npos) << msg;
  EXPECT_NE(msg.find("YAML syntax error"), std::string::npos) << msg;
}

TEST(Config, RelativePathsResolveBesideTheFile) {
  harvest::testing::TempDir dir;
  std::filesystem::create_directories(dir / "cameras");
  std::ofstream(dir / "cameras" / "fixed.yaml") << "x: 1\n";
  std::ofstream(dir / "main.yaml") << "calibration: cameras/fixed.yaml\n";
  auto doc = Document::load_file(dir / "main.yaml");
  EXPECT_EQ(doc.root().file_path("calibration"), dir / "cameras" / "fixed.yaml");
}

TEST(Config, SequencesOfMappings) {
  auto doc = Document::load_string("joints:\n  - {name: j1, max: 1.0}\n  - {name: j2, max: 2.0, typo: 1}\n", "j.yaml");
  auto joints = doc.root().children("joints");
  ASSERT_EQ(joints.size(), 2u);
  for (auto& j : joints) {
    j.required<std::string>("name");
    j.required<double>("max");
  }
  const auto msg = error_of([&] { doc.check_unused(); });
  EXPECT_NE(msg.find("joints[1].typo"), std::string::npos) << msg;
}

// YAML allows a list or mapping as a key; no component reads one, yaml-cpp
// threw its own exception where such a key was read as a name, and emitted
// `a: {[]: ~}` as text that does not load again (both found by
// config_loader_fuzz; regression-sequence-key in its corpus). Refused on
// load, at any depth, naming the line.
TEST(Config, AListOrMappingAsAKeyIsAConfigurationError) {
  EXPECT_EQ(error_of([] { Document::load_string("? [a, b]\n: 1\n", "k.yaml"); }),
            "k.yaml:1: a key must be a plain value, not a list or a mapping");
  EXPECT_EQ(error_of([] { Document::load_string("a: 1\nlimits:\n  ? {x: 1}\n  : 2\n", "k.yaml"); }),
            "k.yaml:3: a key must be a plain value, not a list or a mapping");
  EXPECT_THROW(Document::load_string("d:\n  []: ~\n", "k.yaml"), Error);
  EXPECT_THROW(Document::load_string("l:\n  - {[1]: 2}\n", "k.yaml"), Error);
  // The same in an override's value (regression-override-sequence-key).
  auto doc = Document::load_string("a: 1\n", "k.yaml");
  EXPECT_THROW(doc.apply_override("a.b=[1;,F2]:"), Error);
  EXPECT_THROW(doc.apply_override("a.b={x: 1, x: 2}"), Error);
  EXPECT_NO_THROW(Document::load_string(doc.emit(), "<effective>"));
}

// Aliases make the tree a graph: one mapping that holds itself, or aliases of
// aliases that expand exponentially, are refused on load (config_loader_fuzz:
// a recursive alias overflowed the stack of the key check).
TEST(Config, RecursiveAliasesAliasBombsAndDeepNestingAreRefused) {
  EXPECT_NE(error_of([&] {
              Document::load_string(" &a\ny: *a\nz: 1\n", "r.yaml");
            }).find("nested deeper than 64 levels (an alias that refers to itself?)"),
            std::string::npos);
  std::string bomb = "a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n";
  for (char c = 'b'; c <= 'h'; ++c) {
    bomb += std::string(1, c) + ": &" + c + " [";
    for (int i = 0; i < 10; ++i) bomb += std::string(i ? ", *" : "*") + static_cast<char>(c - 1);
    bomb += "]\n";
  }
  EXPECT_NE(error_of([&] {
              Document::load_string(bomb, "b.yaml");
            }).find("more than 100000 values with its aliases expanded"),
            std::string::npos);
  const auto nested = [](int levels) { return "a: " + std::string(levels, '[') + std::string(levels, ']') + "\n"; };
  EXPECT_NO_THROW(Document::load_string(nested(64), "n.yaml"));
  EXPECT_NE(
      error_of([&] { Document::load_string(nested(65), "n.yaml"); }).find("n.yaml:1: nested deeper than 64 levels"),
      std::string::npos);
  // An alias used twice, as configurations do, is fine.
  const auto doc = Document::load_string("base: &b {x: 1}\none: *b\ntwo: *b\n", "ok.yaml");
  EXPECT_EQ(doc.root().child("two").get<int>("x", 0), 1);
  auto over = Document::load_string("a: 1\n", "o.yaml");
  EXPECT_THROW(over.apply_override("b=" + nested(70).substr(3)), Error);
}

// A CR, a CR LF and an LF are one line break (YAML 1.2, 5.4). yaml-cpp took
// "x: :" followed by CR CR as x = ":" and emitted "x: :", which it refuses
// (config_loader_fuzz): the text is read with LF breaks, so a file loads the
// same whichever its line ends, and what it emits loads again.
TEST(Config, CrAndCrLfLineEndsReadAsLfAndTheEmittedTextLoadsAgain) {
  for (const std::string eol : {"\n", "\r\n", "\r"}) {
    const std::string text = "a: 1" + eol + "b:" + eol + "  c: [1, 2]" + eol + "d: |" + eol + "  x" + eol + "  y" + eol;
    const auto doc = Document::load_string(text, "e.yaml");
    EXPECT_EQ(doc.root().get<int>("a", 0), 1);
    EXPECT_EQ(doc.root().child("b").numbers("c"), (std::vector<double>{1, 2}));
    EXPECT_EQ(doc.root().get<std::string>("d", ""), "x\ny\n") << "a block scalar's breaks are LF";
    EXPECT_NO_THROW(Document::load_string(doc.emit(), "effective"));
  }
  // The fuzzer's input: a syntax error whatever the line ends, on the line an editor shows.
  EXPECT_EQ(error_of([] { Document::load_string("\r\r\r\r\r\r\nx: :\r\r\n", "f.yaml"); }),
            "f.yaml:7: YAML syntax error: illegal map value");
  EXPECT_EQ(error_of([] { Document::load_string("x: :\n\n", "f.yaml"); }), "f.yaml:1: YAML syntax error: illegal map value");
  auto over = Document::load_string("a: 1\n", "o.yaml");
  over.apply_override("a=[1,\r\n 2]");
  EXPECT_EQ(over.root().numbers("a"), (std::vector<double>{1, 2}));
}

// YAML allows implicit keys of at most 1024 characters; yaml-cpp emits longer
// ones implicitly and then refuses its own text (config_loader_fuzz: an
// override path part of 958 bytes, tabs escaped to 2 characters each).
TEST(Config, KeysLongerThan256CharactersAreRefusedInFilesAndOverrides) {
  const std::string k256(256, 'k'), k257(257, 'k');
  const auto doc = Document::load_string("? " + k256 + "\n: 1\n", "k.yaml");
  EXPECT_EQ(doc.root().get<int>(k256, 0), 1);
  EXPECT_NO_THROW(Document::load_string(doc.emit(), "effective"));
  EXPECT_EQ(error_of([&] { Document::load_string("a: 1\n? " + k257 + "\n: 1\n", "k.yaml"); }),
            "k.yaml:2: key '" + k257.substr(0, 40) + "...' is longer than 256 characters");
  auto over = Document::load_string("a: 1\n", "o.yaml");
  EXPECT_EQ(error_of([&] { over.apply_override("a." + k257 + "=1"); }),
            "override: key '" + k257.substr(0, 40) + "...' is longer than 256 characters");
  EXPECT_THROW(over.apply_override("a={" + k257 + ": 1}"), Error);
  over.apply_override(std::string(200, '\t') + "=1");  // emitted as 400 characters: loads again
  EXPECT_NO_THROW(Document::load_string(over.emit(), "effective"));
}

TEST(Config, ControlCharactersAndInvalidUtf8AreRefusedNamingTheLine) {
  // yaml-cpp would load them and emit a configuration it cannot read back
  // (found by config_loader_fuzz).
  EXPECT_EQ(error_of([] { Document::load_string("a: 1\nb: {x\x1b: 2}\n", "c.yaml"); }),
            "c.yaml:2: control character 27 in the text");
  EXPECT_EQ(error_of([] { Document::load_string("a: 1\n\nb: \xc4\x1b\n", "c.yaml"); }), "c.yaml:3: not UTF-8 text");
  EXPECT_EQ(error_of([] { Document::load_string("a: \xe2\x82", "c.yaml"); }), "c.yaml:1: not UTF-8 text");
  // Tabs, CRLF line ends and UTF-8 text are fine.
  const auto doc = Document::load_string("a: \"\xc2\xb0 and \xe2\x82\xac\"\r\nb:\t2\r\n", "c.yaml");
  EXPECT_EQ(doc.root().get<std::string>("a", ""), "\xc2\xb0 and \xe2\x82\xac");
  EXPECT_EQ(error_of([] { Document::load_file("config"); }), "config: a folder, not a configuration file");
  auto ok = Document::load_string("a: 1\n", "c.yaml");
  EXPECT_EQ(error_of([&] { ok.apply_override("a=\xff\xfe"); }), "--set override:1: not UTF-8 text");
}

// ---- declared keys (config::Key, Choice, Numbers) and the reference table ----

namespace {
using harvest::config::Choice;
using harvest::config::Key;
using harvest::config::Numbers;
constexpr Key<double> kSpeed{"max_speed", 0.381, {0.01, 2.0}, "m/s", "Largest tool speed"};
constexpr Key<int> kCount{"count", 3, {1, 10}, "", "How many"};
constexpr Key<bool> kOn{"enabled", true, {}, "", "On or off"};
constexpr Key<std::string> kName{"name", "fixed", {}, "", "A name"};
constexpr Key<std::string> kPort{.name = "port", .doc = "Serial port", .required = true};
constexpr Choice kMode{"mode", "canopy", {"thesis", "canopy", "learned"}, "Detector"};
constexpr Numbers kHome{"home", 3, {1.0, 2.5, -3.0}, "m", "Home position"};
constexpr Numbers kAny{"fruit", 0, {}, "", "Fruit indices"};
constexpr Numbers kTable{.name = "table", .size = 2, .doc = "Two values", .required = true};
}  // namespace

TEST(ConfigKeys, AbsentKeysTakeTheDeclaredDefaultsAndWriteThemBack) {
  auto doc = Document::load_string("table: [1, 2]\nport: /dev/ttyUSB0\n", "k.yaml");
  const auto root = doc.root();
  EXPECT_DOUBLE_EQ(root.get(kSpeed), 0.381);
  EXPECT_EQ(root.get(kCount), 3);
  EXPECT_TRUE(root.get(kOn));
  EXPECT_EQ(root.get(kName), "fixed");
  EXPECT_EQ(root.get(kPort), "/dev/ttyUSB0");
  EXPECT_EQ(root.get(kMode), "canopy");
  EXPECT_EQ(root.get(kHome), (std::vector<double>{1.0, 2.5, -3.0}));
  EXPECT_TRUE(root.get(kAny).empty());
  EXPECT_EQ(root.get(kTable), (std::vector<double>{1, 2}));
  EXPECT_NO_THROW(doc.check_unused());
  const auto again = Document::load_string(doc.emit(), "again.yaml");
  EXPECT_DOUBLE_EQ(again.root().required<double>("max_speed"), 0.381);
  EXPECT_EQ(again.root().required<std::string>("mode"), "canopy");
  EXPECT_EQ(again.root().numbers("home", 3), (std::vector<double>{1.0, 2.5, -3.0}));
}

TEST(ConfigKeys, ValuesAreCheckedAgainstTheDeclaration) {
  auto doc = Document::load_string("max_speed: 3\ncount: 0\nmode: deep\nhome: [1, 2]\n", "k.yaml");
  const auto root = doc.root();
  EXPECT_NE(error_of([&] { root.get(kSpeed); }).find("k.yaml: max_speed: expected a number in [0.010000, 2.000000], got 3"),
            std::string::npos);
  EXPECT_NE(error_of([&] { root.get(kCount); }).find("count: expected an integer in [1, 10], got 0"), std::string::npos);
  EXPECT_NE(error_of([&] { root.get(kMode); }).find("mode: expected one of {thesis, canopy, learned}, got 'deep'"),
            std::string::npos);
  EXPECT_NE(error_of([&] { root.get(kHome); }).find("home: expected a list of 3 numbers, got 2"), std::string::npos);
  EXPECT_NE(error_of([&] { root.get(kPort); }).find("port: expected a required value"), std::string::npos);
  EXPECT_NE(error_of([&] { root.get(kTable); }).find("table: expected a required list of numbers"), std::string::npos);
}

TEST(ConfigKeys, TheReferenceTableShowsEachDeclaration) {
  using harvest::config::section;
  const auto md = harvest::config::reference_markdown(
      {section("arm.limits", "config/arm/robot_link.yaml", kSpeed, kCount, kOn, kPort, kMode, kHome, kAny, kTable)});
  EXPECT_NE(md.find("## `arm.limits`\n\nconfig/arm/robot_link.yaml\n"), std::string::npos) << md;
  EXPECT_NE(md.find("| `max_speed` | number | `0.381` | [0.01, 2] | m/s | Largest tool speed |"), std::string::npos) << md;
  EXPECT_NE(md.find("| `count` | integer | `3` | [1, 10] |  | How many |"), std::string::npos) << md;
  EXPECT_NE(md.find("| `enabled` | bool | `true` |"), std::string::npos) << md;
  EXPECT_NE(md.find("| `port` | string | `required` |"), std::string::npos) << md;
  EXPECT_NE(md.find("| `mode` | choice | `canopy` | one of thesis, canopy, learned |"), std::string::npos) << md;
  EXPECT_NE(md.find("| `home` | 3 numbers | `[1, 2.5, -3]` |  | m |"), std::string::npos) << md;
  EXPECT_NE(md.find("| `fruit` | numbers | `[]` |"), std::string::npos) << md;
  EXPECT_NE(md.find("| `table` | 2 numbers | `required` |"), std::string::npos) << md;
}
