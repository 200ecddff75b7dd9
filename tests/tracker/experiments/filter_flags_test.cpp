// The experiments take the filter's options as flags off the options table: every key but the two
// they set themselves, with the table's values and errors.
#include "tracker/experiments/filter_flags.h"

#include <stdexcept>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace mocap {
namespace {

using ::testing::HasSubstr;

Args parse(std::vector<std::string> flags) {
  std::vector<char*> argv = {const_cast<char*>("mocap-experiment"), const_cast<char*>("human")};
  for (std::string& flag : flags) argv.push_back(flag.data());
  return Args(static_cast<int>(argv.size()), argv.data(), 2, filterFlagsUsage("  "));
}

TEST(FilterFlags, EveryTableKeyButEvaluationsAndSeedIsAFlag) {
  const std::string usage = filterFlagsUsage("  ");
  for (const FilterOptionKey& option : filterOptionKeys()) {
    std::string flag = std::string("--") + option.key;
    for (char& c : flag)
      if (c == '_') c = '-';
    const bool own = flag == "--evaluations" || flag == "--seed";
    EXPECT_EQ(usage.find("[" + flag + " ") != std::string::npos, !own) << flag;
  }
  for (std::size_t line = 0, next; line < usage.size(); line = next + 1) {
    next = usage.find('\n', line);
    if (next == std::string::npos) next = usage.size();
    EXPECT_LE(next - line, 100u) << usage.substr(line, next - line);
  }
}

TEST(FilterFlags, FlagsSetTheOptionsAndBadOnesAreNamed) {
  FilterOptions options;
  readFilterFlags(parse({"--refine", "0.4", "--refine-swap", "knees", "--inject", "segment",
                         "--refine-hold", "1"}),
                  options);
  EXPECT_EQ(options.refine.share, 0.4);
  EXPECT_TRUE(options.refine.swap.enabled);
  EXPECT_TRUE(options.refine.swap.knees_only);
  EXPECT_EQ(options.injection.redraw, InjectionOptions::Redraw::kSegment);
  EXPECT_TRUE(options.refine.hold);
  try {
    readFilterFlags(parse({"--lookahead", "subtree"}), options);
    FAIL() << "a bad value was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("--lookahead: expected none or body, got 'subtree'"));
  }
  EXPECT_THROW(parse({"--evaluations", "800"}), std::invalid_argument);  // that is --evals
}

}  // namespace
}  // namespace mocap
