// The experiment commands' flags: read off the usage text (value flags and switches), with errors
// that name the flag; every command's usage yields the flags its experiment reads.
#include "tracker/cli/args.h"

#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tracker/experiments/commands.h"

namespace mocap {
namespace {

using ::testing::HasSubstr;

constexpr const char* kUsage =
    "demo --input FILE [--evals N] [--mode a|b]\n"
    "       [--verbose] [--dry-run]\n"
    "       (--input: a file; --quiet: not a flag, only mentioned)";

Args parse(std::vector<std::string> words, const char* usage = kUsage) {
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(w.data());
  return Args(static_cast<int>(argv.size()), argv.data(), 0, usage);
}

std::string errorOf(std::vector<std::string> words, const char* usage = kUsage) {
  try {
    parse(std::move(words), usage);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(Args, ReadsValueFlagsAndSwitchesOffTheUsage) {
  const Args args = parse({"--input", "walk.bvh", "--evals", "800", "--verbose", "--mode", "b"});
  EXPECT_EQ(args.text("input", ""), "walk.bvh");
  EXPECT_EQ(args.integer("evals", 0, 1, 10000), 800);
  EXPECT_EQ(args.text("mode", "a"), "b");
  EXPECT_TRUE(args.has("verbose"));
  EXPECT_FALSE(args.has("dry-run"));
  EXPECT_TRUE(parse({"--dry-run"}).has("dry-run"));
}

TEST(Args, BadFlagsAreNamed) {
  EXPECT_THAT(errorOf({"--frames", "3"}), HasSubstr("unknown flag --frames"));
  EXPECT_THAT(errorOf({"--evals"}), HasSubstr("--evals needs a value"));
  EXPECT_THAT(errorOf({"--verbose", "yes"}), HasSubstr("unexpected argument 'yes'"));
  try {
    parse({"--evals", "8x"}).integer("evals", 0, 1, 10000);
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("--evals: not an integer: '8x'"));
  }
  EXPECT_EQ(errorOf({"--input", "--verbose"}), "");  // a value may look like a flag
  EXPECT_THAT(errorOf({"--quiet"}), HasSubstr("unknown flag --quiet"));
}

// Each command accepts what its usage names: a flag from every line, and the switches as switches.
TEST(Args, EveryCommandAcceptsTheFlagsItsUsageNames) {
  EXPECT_TRUE(parse({"--lost-after", "16", "--speed-scale", "2", "--motion", "x.bvh"}, kHumanUsage)
                  .has("speed-scale"));
  EXPECT_TRUE(parse({"--threads", "2", "--describe"}, kHandUsage).has("describe"));
  EXPECT_TRUE(parse({"--no-adaptive", "--dump", "d"}, kSilhouetteUsage).has("no-adaptive"));
  EXPECT_TRUE(parse({"--write-images", "d", "--dictionary", "5X5_100"}, kCalibrationUsage)
                  .has("write-images"));
  EXPECT_TRUE(parse({"--rate", "30"}, kBvhFitUsage).has("rate"));
  EXPECT_THAT(errorOf({"--describe", "1"}, kHandUsage), HasSubstr("unexpected argument '1'"));
}

}  // namespace
}  // namespace mocap
