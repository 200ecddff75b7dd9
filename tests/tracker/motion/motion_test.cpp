// Generated motions respect the model's limits and speeds and cover the range; CSV motions round
// trip and bad files are refused with the line and column.
#include "tracker/motion/motion.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

namespace mocap {
namespace {

using ::testing::HasSubstr;

BodyModel hand() {
  return loadBodyModel(std::string(MOCAP_SOURCE_DIR) + "/tracker/models/hand.yaml");
}

TEST(Motion, GeneratedMotionStaysInLimitsAndSpeedAndCoversTheRange) {
  const BodyModel m = hand();
  const Motion motion = generateMotion(m, 300, 42);
  ASSERT_EQ(motion.size(), 300u);
  for (std::size_t d = 0; d < m.dofs.size(); ++d) {
    const Dof& dof = m.dofs[d];
    double lo = dof.max, hi = dof.min, fastest = 0;
    for (std::size_t f = 0; f < motion.size(); ++f) {
      ASSERT_GE(motion[f][d], dof.min);
      ASSERT_LE(motion[f][d], dof.max);
      lo = std::min(lo, motion[f][d]);
      hi = std::max(hi, motion[f][d]);
      if (f > 0) fastest = std::max(fastest, std::abs(motion[f][d] - motion[f - 1][d]));
    }
    EXPECT_LE(fastest, dof.max_speed + 1e-12) << dof.name;
    EXPECT_GT(fastest, 0.5 * dof.max_speed) << dof.name << " never moves fast";
    EXPECT_GT(hi - lo, 0.5 * (dof.max - dof.min)) << dof.name << " covers too little of its range";
  }
  EXPECT_EQ(generateMotion(m, 50, 42)[49], motion[49]);  // seeded
  EXPECT_NE(generateMotion(m, 50, 43)[49], motion[49]);
}

std::string write(const std::string& name, const std::string& text) {
  const std::string path = testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(Motion, CsvRoundTrip) {
  const BodyModel m = hand();
  const Motion motion = generateMotion(m, 20, 1);
  const std::string path = testing::TempDir() + "/motion.csv";
  saveMotionCsv(path, m, motion);
  const Motion back = loadMotionCsv(path, m);
  ASSERT_EQ(back.size(), motion.size());
  for (std::size_t f = 0; f < back.size(); ++f) EXPECT_TRUE(back[f].isApprox(motion[f], 1e-15));
}

std::string errorOf(const std::string& text) {
  try {
    loadMotionCsv(write("bad.csv", text), hand());
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(Motion, BadCsvFilesAreRefusedWithLineAndColumn) {
  const BodyModel m = hand();
  std::string header;
  std::string zeros;
  for (std::size_t d = 0; d < m.dofs.size(); ++d) {
    header += (d ? "," : "") + m.dofs[d].name;
    zeros += d ? ",0.1" : "0.1";
  }
  EXPECT_EQ(errorOf(header + "\n" + zeros + "\n"), "");
  EXPECT_THAT(errorOf("bogus," + header + "\n"),
              HasSubstr("bad.csv:1: column 1: unknown DOF 'bogus'"));
  EXPECT_THAT(errorOf(header.substr(header.find(',') + 1) + "\n"),
              HasSubstr("missing column for DOF 'thumb_cmc_flex'"));
  EXPECT_THAT(errorOf(header + "\n" + zeros + ",0\n"),
              HasSubstr("bad.csv:2: 16 values, expected 15"));
  std::string row = zeros;
  row.replace(row.find(",0.1"), 4, ",abc");
  EXPECT_THAT(errorOf(header + "\n" + zeros + "\n" + row + "\n"),
              HasSubstr("bad.csv:3: column 2 (thumb_mcp_flex): not a number: 'abc'"));
  row = zeros;
  row.replace(0, 3, "9.5");
  EXPECT_THAT(errorOf(header + "\n" + row + "\n"),
              HasSubstr("bad.csv:2: column 1 (thumb_cmc_flex): 9.5 is outside the limits"));
  EXPECT_THAT(errorOf(header + "\n"), HasSubstr("no frames"));
  EXPECT_THAT(errorOf(""), HasSubstr("empty file"));
}

}  // namespace
}  // namespace mocap
