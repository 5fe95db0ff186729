#include "common/config.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <fstream>

#include "common/error.hpp"
#include "tests/test_support.hpp"

namespace ovo {
namespace {

TEST(Config, ReadsTypedValuesAndDefaults) {
  const Config c = Config::fromString(
      "a:\n  b: 2.5\n  n: 3\n  flag: true\n  name: fish\nlist: [1, 2, 3]\n", "t.yaml");
  EXPECT_DOUBLE_EQ(c.get<double>("a.b", 0.0), 2.5);
  EXPECT_EQ(c.get<int>("a.n", 0), 3);
  EXPECT_TRUE(c.get<bool>("a.flag", false));
  EXPECT_EQ(c.get<std::string>("a.name", ""), "fish");
  EXPECT_EQ(c.get<std::vector<double>>("list", {}).size(), 3u);
  EXPECT_EQ(c.get<int>("a.absent", 7), 7);
  EXPECT_NO_THROW(c.checkAllUsed());
}

TEST(Config, WrongTypeNamesFileLineAndKey) {
  const Config c = Config::fromString("a:\n  b: fast\n", "cfg.yaml");
  try {
    (void)c.get<double>("a.b", 0.0);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("cfg.yaml:2"), std::string::npos) << msg;
    EXPECT_NE(msg.find("a.b"), std::string::npos) << msg;
    EXPECT_NE(msg.find("expected a number"), std::string::npos) << msg;
  }
}

TEST(Config, UnknownKeyIsReportedWithLine) {
  const Config c = Config::fromString("a:\n  b: 1\n  typo: 2\n", "cfg.yaml");
  (void)c.get<int>("a.b", 0);
  try {
    c.checkAllUsed();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("a.typo"), std::string::npos) << msg;
    EXPECT_NE(msg.find("cfg.yaml:3"), std::string::npos) << msg;
  }
}

TEST(Config, OverridesWinAndUnknownOverrideIsCaught) {
  Config c = Config::fromString("a:\n  b: 1\n", "cfg.yaml");
  c.applyOverride("a.b=4");
  c.applyOverride("x.y=[1, 2]");
  EXPECT_EQ(c.get<int>("a.b", 0), 4);
  EXPECT_THROW(c.checkAllUsed(), Error);  // x.y never read
  EXPECT_THROW(c.applyOverride("novalue"), Error);
}

// "--set a.n.x=5" where a.n is a value turns a.n into a section: the error names that --set, not
// the defaults (which hold no a.n at all).
TEST(Config, OverrideBelowAValueNamesTheOverride) {
  Config c;
  c.applyOverride("a.n.x=5");
  EXPECT_CONTAINS(test::errorOf([&] { (void)c.get<int>("a.n", 3); }),
                  "--set a.n.x: key 'a.n': expected an integer");
  // A key that merely shares the prefix is not the one that made the section.
  Config d;
  d.applyOverride("a.nn=5");
  d.applyOverride("a.n.x=5");
  EXPECT_CONTAINS(test::errorOf([&] { (void)d.get<int>("a.n", 3); }), "--set a.n.x:");
}

// An empty value is an error, not the built-in default (which differs from what the file meant).
TEST(Config, EmptyValueIsAnErrorNamingTheKey) {
  const Config c = Config::fromString("a:\n  b:\n  c: ~\n  d: 2\n", "cfg.yaml");
  EXPECT_CONTAINS(test::errorOf([&] { (void)c.get<double>("a.b", 8.0); }),
                  "cfg.yaml:2: key 'a.b': no value");
  EXPECT_CONTAINS(test::errorOf([&] { (void)c.getInRange("a.c", 8.0, 0.0, 10.0); }),
                  "key 'a.c': no value");
  EXPECT_EQ(c.get<int>("a.d", 0), 2);
  EXPECT_EQ(c.get<int>("a.absent", 5), 5);  // a key left out keeps its default
  Config o;
  o.applyOverride("w.size=");
  EXPECT_CONTAINS(test::errorOf([&] { (void)o.get<int>("w.size", 10); }),
                  "--set w.size: key 'w.size': no value");
}

TEST(Config, KeyGivenTwiceIsAnErrorNamingBothLines) {
  // yaml-cpp keeps both entries and a lookup finds the first: the later line would be ignored.
  EXPECT_CONTAINS(
      test::errorOf([] { Config::fromString("seed: 1\nrate: 2\nseed: 3\n", "c.yaml"); }),
      "c.yaml:3: key 'seed' given twice (first on line 1)");
  EXPECT_CONTAINS(test::errorOf([] {
                    Config::fromString("world:\n  grade_pct: 8\n  grade_pct: 30\n", "c.yaml");
                  }),
                  "c.yaml:3: key 'grade_pct' given twice (first on line 2)");
  EXPECT_CONTAINS(test::errorOf([] {
                    Config::fromString("rows:\n  - {a: 1, b: 2}\n  - {a: 1, a: 2}\n", "c.yaml");
                  }),
                  "c.yaml:3: key 'a' given twice");
  // The same name in two sections is two keys.
  const Config c = Config::fromString("a:\n  x: 1\nb:\n  x: 2\n", "c.yaml");
  EXPECT_EQ(c.get<int>("b.x", 0), 2);
}

// A list, a mapping or nothing before ':' (a YAML complex key): yaml-cpp's own exception escaped
// the readers (found by the rig_yaml fuzz target: a tag '!lidar:' made the next flow mapping a
// key); now an ovo::Error naming the line.
TEST(Config, KeyThatIsNotPlainTextIsAnError) {
  EXPECT_CONTAINS(test::errorOf([] { Config::fromString("a: 1\n? [x, y]\n: 2\n", "c.yaml"); }),
                  "c.yaml:2: expected a plain key (text) before ':', got a list");
  EXPECT_CONTAINS(test::errorOf([] { Config::fromString("b:\n  {x: 1}: 2\n", "c.yaml"); }),
                  "c.yaml:2: expected a plain key (text) before ':', got a mapping");
  EXPECT_CONTAINS(test::errorOf([] { Config::fromString("a: 1\n: 2\n", "c.yaml"); }),
                  "got nothing");
}

TEST(Config, SelfReferencingAndExplodingAliasesAreErrors) {
  // An alias inside the node it names is endless: walking it overflowed the stack (SIGSEGV).
  EXPECT_CONTAINS(test::errorOf([] { Config::fromString("seed: 1\nx: &a [*a]\n", "c.yaml"); }),
                  "c.yaml:2: the YAML nests more than 64 levels deep");
  EXPECT_CONTAINS(test::errorOf([] {
                    Config c = Config::fromString("seed: 1\n", "c.yaml");
                    c.applyOverride("x=&a [*a]");
                  }),
                  "--set x:1: the YAML nests more than 64 levels deep");
  // Aliases of aliases, ten times a line: 10^8 values from 9 lines (took 36 s to reject).
  std::string laughs = "l0: &l0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n";
  for (int i = 1; i <= 8; ++i) {
    laughs += fmt::format("l{}: &l{} [", i, i);
    for (int k = 0; k < 10; ++k) laughs += fmt::format("{}*l{}", k ? ", " : "", i - 1);
    laughs += "]\n";
  }
  EXPECT_CONTAINS(test::errorOf([&] { Config::fromString(laughs, "c.yaml"); }),
                  "the YAML expands to more than 100000 values");
  // Aliases that stay small are still fine.
  const Config c = Config::fromString("a: &v [1, 2]\nb: *v\n", "c.yaml");
  EXPECT_EQ(c.get<std::vector<double>>("b", {}).size(), 2u);
}

TEST(Config, LocationNamesTheKeysLineOrItsOverride) {
  // What checks across keys (sim/scenario: range_max_m against range_min_m) name in their errors.
  Config c = Config::fromString("lidar:\n  range_min_m: 1\n  range_max_m: 5\n", "s.yaml");
  c.applyOverride("lidar.range_min_m=9");
  EXPECT_EQ(c.location("lidar.range_max_m"), "s.yaml:3");
  EXPECT_EQ(c.location("lidar.range_min_m"), "--set lidar.range_min_m");
  EXPECT_EQ(c.location("lidar.absent"), "s.yaml");
}

TEST(Config, FolderGivenAsFileIsAnError) {
  EXPECT_CONTAINS(test::errorOf([&] { Config::load(test::tempDir()); }),
                  "is a folder, expected a YAML file");
}

TEST(Config, RangeAndChoiceChecks) {
  const Config c = Config::fromString("rate: -3\nmode: turbo\n", "cfg.yaml");
  EXPECT_THROW(c.getInRange("rate", 1.0, 0.0, 100.0), Error);
  EXPECT_THROW(c.getChoice("mode", "serial", {"serial", "threads"}), Error);
}

TEST(Config, MissingFileAndBadYamlAreErrors) {
  EXPECT_THROW(Config::load("/nonexistent/ovo.yaml"), Error);
  EXPECT_THROW(Config::fromString("a: [1, 2\n", "bad.yaml"), Error);
  EXPECT_THROW(Config::fromString("- 1\n- 2\n", "list.yaml"), Error);
}

TEST(Config, Matrix4FromRowsOrFlat) {
  const Config c = Config::fromString(
      "T: [[1,0,0,1],[0,1,0,2],[0,0,1,3],[0,0,0,1]]\nF: [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\nB: "
      "[1,2]\n");
  EXPECT_DOUBLE_EQ(c.get<Eigen::Matrix4d>("T", Eigen::Matrix4d::Zero())(1, 3), 2.0);
  EXPECT_TRUE(c.get<Eigen::Matrix4d>("F", Eigen::Matrix4d::Zero()).isIdentity());
  EXPECT_THROW(c.get<Eigen::Matrix4d>("B", Eigen::Matrix4d::Zero()), Error);
}

TEST(Config, MergeLayersValues) {
  Config base = Config::fromString("a: 1\nb: 2\n", "base.yaml");
  base.merge(Config::fromString("b: 5\nc: 6\n", "user.yaml"));
  EXPECT_EQ(base.get<int>("a", 0), 1);
  EXPECT_EQ(base.get<int>("b", 0), 5);
  EXPECT_EQ(base.get<int>("c", 0), 6);
}

}  // namespace
}  // namespace ovo
