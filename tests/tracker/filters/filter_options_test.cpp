// The options table: every key reads back what it writes, bad values are refused with the key and
// the value, and validation checks every option in one place.
#include "tracker/filters/filter_options.h"

#include <set>
#include <stdexcept>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace mocap {
namespace {

using ::testing::HasSubstr;

std::string errorOf(FilterOptions& options, const std::string& key, const std::string& text) {
  try {
    setFilterOption(options, key, text);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(FilterOptions, EveryKeyReadsBackWhatItWrites) {
  FilterOptions people = humanFilterDefaults();
  people.injection.share = 0.1 + 0.2;  // not the shortest decimal: must still read back exactly
  people.refine.swap.enabled = true;
  people.refine.swap.knees_only = true;
  people.refine.max_evaluations = 30;
  std::set<std::string> keys;
  for (const FilterOptionKey& option : filterOptionKeys()) {
    EXPECT_TRUE(keys.insert(option.key).second) << option.key << " is in the table twice";
    FilterOptions read;
    option.set(read, option.get(people));
    EXPECT_EQ(option.get(read), option.get(people)) << option.key;
  }
  FilterOptions read;
  for (const FilterOptionKey& option : filterOptionKeys()) option.set(read, option.get(people));
  EXPECT_EQ(read.injection.share, people.injection.share);
  EXPECT_EQ(read.injection.redraw, InjectionOptions::Redraw::kSegment);
  EXPECT_EQ(read.lookahead, FilterOptions::Lookahead::kBody);
  EXPECT_EQ(read.refine.share, 0.4);
  EXPECT_TRUE(read.refine.hold);
  EXPECT_TRUE(read.refine.plant);
  EXPECT_TRUE(read.refine.swap.knees_only);
  EXPECT_EQ(read.refine.max_evaluations, 30);
  EXPECT_EQ(read.refine.restart_share, 0.14);
  EXPECT_EQ(read.refine.facing_prior, 16);
}

TEST(FilterOptions, BadValuesAreRefusedWithTheKeyAndTheValue) {
  FilterOptions options;
  EXPECT_THAT(errorOf(options, "inject", "limb"), HasSubstr("inject: expected dof or segment"));
  EXPECT_THAT(errorOf(options, "inject", "limb"), HasSubstr("'limb'"));
  EXPECT_THAT(errorOf(options, "lookahead", "subtree"), HasSubstr("expected none or body"));
  EXPECT_THAT(errorOf(options, "refine", "1.5"), HasSubstr("refine: must be between 0 and 0.99"));
  EXPECT_THAT(errorOf(options, "keep", "0"), HasSubstr("keep: must be between 1 and"));
  EXPECT_THAT(errorOf(options, "keep", "2.5"), HasSubstr("keep: expected a whole number"));
  EXPECT_THAT(errorOf(options, "refine_hold", "maybe"), HasSubstr("expected true or false"));
  EXPECT_THAT(errorOf(options, "refine_swap", "sometimes"),
              HasSubstr("expected true, false or knees"));
  EXPECT_THAT(errorOf(options, "speed", "3"), HasSubstr("speed: not a filter option"));
  // A refused value leaves the option as it was.
  EXPECT_EQ(options.keep, FilterOptions().keep);
  EXPECT_EQ(errorOf(options, "refine_hold", "yes"), "");
  EXPECT_TRUE(options.refine.hold);
}

TEST(FilterOptions, ValidationChecksEveryOptionInOnePlace) {
  EXPECT_NO_THROW(validateFilterOptions(FilterOptions()));
  EXPECT_NO_THROW(validateFilterOptions(humanFilterDefaults()));
  const auto errorOfValidating = [](const FilterOptions& options) -> std::string {
    try {
      validateFilterOptions(options);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  FilterOptions bad;
  bad.keep = 0;
  EXPECT_THAT(errorOfValidating(bad), HasSubstr("keep: must be between 1 and"));
  bad = FilterOptions();
  bad.refine.share = -0.1;
  EXPECT_THAT(errorOfValidating(bad), HasSubstr("refine: must be between 0 and 0.99"));
  bad = FilterOptions();
  bad.annealing_layers = 0;
  EXPECT_THAT(errorOfValidating(bad), HasSubstr("layers: must be between 1 and 100"));
  bad = FilterOptions();
  bad.refine.swap.knees_only = true;
  EXPECT_THAT(errorOfValidating(bad), HasSubstr("refine_swap: knees only, but the swap is off"));
}

TEST(FilterOptions, NumbersAreWrittenInTheirShortestExactForm) {
  EXPECT_EQ(shortestText(0.05), "0.05");
  EXPECT_EQ(shortestText(16), "16");
  EXPECT_EQ(std::stod(shortestText(0.1 + 0.2)), 0.1 + 0.2);
}

}  // namespace
}  // namespace mocap
