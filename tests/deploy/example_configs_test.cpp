// The shipped configurations (deploy/configs/*.yaml and the system default deploy/mocapd.yaml)
// are accepted by mocapd's own config loader, their calibrations fit their cameras, and broken
// variants of them are refused naming the field.
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "drivers/builtin_drivers.h"
#include "server/config.h"
#include "tracker/model/camera.h"

namespace mocap {
namespace {

using ::testing::HasSubstr;

const std::filesystem::path kDeployDir = std::filesystem::path(MOCAP_SOURCE_DIR) / "deploy";
const std::filesystem::path kConfigDir = kDeployDir / "configs";

// Registers this build's drivers, as mocapd's main() does, before any test parses.
class DriversEnvironment : public testing::Environment {
 public:
  void SetUp() override { registerBuiltinDrivers(DriverRegistry::instance()); }
};
const testing::Environment* const kDrivers =
    testing::AddGlobalTestEnvironment(new DriversEnvironment);

bool compiledIn(const std::string& driver) {
  return DriverRegistry::instance().create(driver) != nullptr;
}

std::string readFile(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// `text` with its single `from` replaced by `to`; fails the test if `from` is not there once.
std::string replaceOnce(const std::string& text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "'" << from << "' not in the example";
  EXPECT_EQ(text.find(from, at + 1), std::string::npos) << "'" << from << "' is there twice";
  if (at == std::string::npos) return text;
  return text.substr(0, at) + to + text.substr(at + from.size());
}

// The file parsed as loadConfigFile would (relative paths against its folder), from `text`.
ServerConfig parseAs(const std::filesystem::path& path, const std::string& text) {
  return parseConfig(text, path.string(), path.parent_path().string());
}

std::string errorOf(const std::filesystem::path& path, const std::string& text) {
  try {
    parseAs(path, text);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

// The calibration a config names has one camera per configured camera, each at its size.
void expectRigFits(const ServerConfig& config) {
  ASSERT_FALSE(config.calibration_file.empty());
  const Rig rig = loadRig(config.calibration_file);
  ASSERT_EQ(rig.size(), config.cameras.size());
  for (std::size_t c = 0; c < rig.size(); ++c) {
    EXPECT_EQ(rig[c].width, config.cameras[c].width) << "camera " << c;
    EXPECT_EQ(rig[c].height, config.cameras[c].height) << "camera " << c;
  }
}

TEST(ExampleConfigsTest, EveryShippedExampleIsCoveredHere) {
  std::set<std::string> found;
  for (const auto& entry : std::filesystem::directory_iterator(kConfigDir)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("example-rig-", 0) != 0) found.insert(name);
  }
  EXPECT_EQ(found,
            (std::set<std::string>{"fake.yaml", "fake-walk.yaml", "fake-walk-extracted.yaml",
                                   "fake-walk-fit.yaml", "fake-walk-product.yaml", "gige.yaml",
                                   "libcamera.yaml", "replay.yaml", "v4l2.yaml"}));
}

TEST(ExampleConfigsTest, FakeIsTheEmbeddedDefaultSpeltOut) {
  const ServerConfig config = loadConfigFile((kConfigDir / "fake.yaml").string());
  const ServerConfig embedded = parseConfig(kDefaultConfigYaml, "default", ".");
  ASSERT_EQ(config.cameras.size(), embedded.cameras.size());
  for (std::size_t c = 0; c < config.cameras.size(); ++c) {
    EXPECT_EQ(config.cameras[c].driver, "fake");
    EXPECT_EQ(config.cameras[c].width, embedded.cameras[c].width);
    EXPECT_EQ(config.cameras[c].height, embedded.cameras[c].height);
    EXPECT_EQ(config.cameras[c].fps, embedded.cameras[c].fps);
  }
  EXPECT_EQ(config.cameras[1].device, "scene:1");
  EXPECT_TRUE(config.calibration_file.empty());
  EXPECT_TRUE(config.body_model.empty());
  EXPECT_EQ(config.tracker.method, embedded.tracker.method);
  EXPECT_EQ(config.tracker.filter.evaluations_per_frame,
            embedded.tracker.filter.evaluations_per_frame);
  EXPECT_EQ(config.tracker.threads, embedded.tracker.threads);
  EXPECT_EQ(config.listen, embedded.listen);
}

TEST(ExampleConfigsTest, FakeWalkPlaysTheSharedWalkOnTheHumanBody) {
  const ServerConfig config = loadConfigFile((kConfigDir / "fake-walk.yaml").string());
  EXPECT_EQ(config.cameras.size(), 2u);
  EXPECT_EQ(config.body_model, "builtin:human");
  EXPECT_TRUE(std::filesystem::equivalent(
      config.scene_motion,
      std::filesystem::path(MOCAP_SHARED_DIR) / "data/motion/cmu_131_01_walk.bvh"));
  EXPECT_EQ(config.tracker.filter.evaluations_per_frame, 2000);
  EXPECT_EQ(config.tracker.filter.lookahead, FilterOptions::Lookahead::kBody);
  // A motion is for the fake scene only.
  const std::filesystem::path path = kConfigDir / "fake-walk.yaml";
  EXPECT_THAT(errorOf(path, replaceOnce(readFile(path), "driver: fake, device: \"scene:1\"",
                                        "driver: v4l2, device: /dev/video2")),
              HasSubstr("scene_motion: only the fake scene plays a motion (cameras[1] is v4l2)"));
}

// The session as on real cameras: an empty room first (for the background), silhouettes
// extracted, the person found rather than placed; the people defaults otherwise.
TEST(ExampleConfigsTest, FakeWalkExtractedStartsEmptyAndExtractsTheSilhouettes) {
  const ServerConfig config = loadConfigFile((kConfigDir / "fake-walk-extracted.yaml").string());
  const ServerConfig walk = loadConfigFile((kConfigDir / "fake-walk.yaml").string());
  EXPECT_EQ(config.scene_motion, walk.scene_motion);
  EXPECT_EQ(config.scene_empty_seconds, 5.0);
  EXPECT_FALSE(config.true_silhouettes);
  EXPECT_TRUE(walk.true_silhouettes);
  EXPECT_EQ(config.tracker.start, "acquire");
  EXPECT_EQ(config.tracker.filter.evaluations_per_frame, walk.tracker.filter.evaluations_per_frame);
  EXPECT_EQ(config.tracker.filter.refine.share, walk.tracker.filter.refine.share);
  EXPECT_EQ(config.tracker.filter.lookahead, walk.tracker.filter.lookahead);
}

// Fitting the body: the shipped human tracked as given while the walk's subject stands in the fit
// pose first; the people defaults otherwise.
TEST(ExampleConfigsTest, FakeWalkFitTracksTheShippedBodyWhileTheSubjectStandsInTheFitPose) {
  const ServerConfig config = loadConfigFile((kConfigDir / "fake-walk-fit.yaml").string());
  const ServerConfig walk = loadConfigFile((kConfigDir / "fake-walk.yaml").string());
  EXPECT_EQ(config.scene_motion, walk.scene_motion);
  EXPECT_EQ(config.body_model, "builtin:human");
  EXPECT_FALSE(config.track_subject_body);
  EXPECT_TRUE(walk.track_subject_body);
  EXPECT_EQ(config.scene_fit_pose_seconds, 20.0);
  EXPECT_EQ(config.tracker.filter.evaluations_per_frame, walk.tracker.filter.evaluations_per_frame);
  EXPECT_EQ(config.tracker.filter.lookahead, walk.tracker.filter.lookahead);
}

// The product path: a simulated person, not the body, seen in an empty room first (for the
// background), standing in the fit pose (for the body fit), found on extracted silhouettes by the
// shipped body; the people defaults otherwise.
TEST(ExampleConfigsTest, FakeWalkProductShowsAPersonToTheShippedBodyOnExtractedSilhouettes) {
  const ServerConfig config = loadConfigFile((kConfigDir / "fake-walk-product.yaml").string());
  const ServerConfig walk = loadConfigFile((kConfigDir / "fake-walk.yaml").string());
  EXPECT_EQ(config.scene_motion, walk.scene_motion);
  ASSERT_TRUE(config.scene_subject_seed);
  EXPECT_FALSE(walk.scene_subject_seed);
  EXPECT_EQ(config.body_model, "builtin:human");
  EXPECT_FALSE(config.track_subject_body);
  EXPECT_GT(config.scene_empty_seconds, 0.0);
  EXPECT_GT(config.scene_fit_pose_seconds, 0.0);
  EXPECT_FALSE(config.true_silhouettes);
  EXPECT_EQ(config.tracker.start, "acquire");
  EXPECT_EQ(config.tracker.filter.evaluations_per_frame, walk.tracker.filter.evaluations_per_frame);
  EXPECT_EQ(config.tracker.filter.lookahead, walk.tracker.filter.lookahead);
}

TEST(ExampleConfigsTest, SystemDefaultRecordsAndKeepsBackgroundsUnderTheStateDirectory) {
  // /var/lib/mocapd is made by the unit's StateDirectory=; here a scratch folder stands in.
  const std::filesystem::path path = kDeployDir / "mocapd.yaml";
  const std::filesystem::path state = std::filesystem::path(testing::TempDir()) / "mocapd-state";
  std::filesystem::create_directories(state);
  const std::string text = replaceOnce(
      replaceOnce(readFile(path), "recording_directory: /var/lib/mocapd",
                  "recording_directory: " + state.string()),
      "background_directory: /var/lib/mocapd", "background_directory: " + state.string());
  const ServerConfig config = parseAs(path, text);
  EXPECT_EQ(config.cameras.size(), 2u);
  EXPECT_EQ(config.listen, "127.0.0.1:50051");
  EXPECT_EQ(config.recording_directory, std::filesystem::canonical(state).string());
  EXPECT_EQ(config.background_directory, config.recording_directory);
  EXPECT_TRUE(config.bearer_token.empty());
}

TEST(ExampleConfigsTest, V4l2TwoUsbCamerasAt800x600) {
  ASSERT_TRUE(compiledIn("v4l2"));
  const ServerConfig config = loadConfigFile((kConfigDir / "v4l2.yaml").string());
  ASSERT_EQ(config.cameras.size(), 2u);
  EXPECT_EQ(config.cameras[0].device, "/dev/video0");
  EXPECT_EQ(config.cameras[1].device, "/dev/video2");
  for (const CameraConfig& camera : config.cameras) {
    EXPECT_EQ(camera.driver, "v4l2");
    EXPECT_EQ(camera.width, 800);
    EXPECT_EQ(camera.height, 600);
    EXPECT_EQ(camera.fps, 25.0);
  }
  EXPECT_EQ(config.body_model, "builtin:human");
  EXPECT_EQ(config.tracker.filter.evaluations_per_frame,
            2000);  // the people defaults, on two threads
  EXPECT_EQ(config.tracker.threads, 2);
  expectRigFits(config);
}

TEST(ExampleConfigsTest, GigeHardwareTriggeredByAddressAndSerial) {
  if (!compiledIn("aravis")) GTEST_SKIP() << "the aravis driver is not in this build";
  const ServerConfig config = loadConfigFile((kConfigDir / "gige.yaml").string());
  ASSERT_EQ(config.cameras.size(), 2u);
  EXPECT_EQ(config.cameras[0].device, "192.168.10.11");
  EXPECT_EQ(config.cameras[1].device, "21234568");
  for (const CameraConfig& camera : config.cameras) {
    EXPECT_EQ(camera.driver, "aravis");
    EXPECT_EQ(camera.pixel_format, "Mono8");
    EXPECT_EQ(camera.exposure_us, 8000.0);
    EXPECT_EQ(camera.gain_db, 6.0);
    EXPECT_EQ(camera.trigger, TriggerMode::kHardwareLine);
    EXPECT_EQ(camera.trigger_line, "Line1");
  }
  expectRigFits(config);
}

TEST(ExampleConfigsTest, LibcameraByIndex) {
  if (!compiledIn("libcamera")) GTEST_SKIP() << "the libcamera driver is not in this build";
  const ServerConfig config = loadConfigFile((kConfigDir / "libcamera.yaml").string());
  ASSERT_EQ(config.cameras.size(), 2u);
  EXPECT_EQ(config.cameras[0].device, "0");
  EXPECT_EQ(config.cameras[1].device, "1");
  expectRigFits(config);
}

TEST(ExampleConfigsTest, ReplayConfigIsValidWithoutCameras) {
  const ServerConfig config = loadConfigFile((kConfigDir / "replay.yaml").string());
  EXPECT_EQ(config.cameras.size(), 2u);
  EXPECT_FALSE(config.replay());  // replay is the --replay flag, not a config field
  EXPECT_TRUE(config.calibration_file.empty());
}

TEST(ExampleConfigsTest, BrokenVariantsNameTheField) {
  ASSERT_TRUE(compiledIn("v4l2"));
  const std::filesystem::path v4l2 = kConfigDir / "v4l2.yaml";
  const std::string text = readFile(v4l2);
  EXPECT_THAT(errorOf(v4l2, replaceOnce(text, "device: /dev/video0", "devise: /dev/video0")),
              HasSubstr("v4l2.yaml:17: cameras[0].devise: unknown key"));
  EXPECT_THAT(errorOf(v4l2, replaceOnce(text, "calibration: example-rig-800x600.yaml",
                                        "calibration: no-such-rig.yaml")),
              HasSubstr("calibration: no such file"));
  EXPECT_THAT(errorOf(v4l2, replaceOnce(text, "fps: 25\n# The rig", "fps: 30\n# The rig")),
              HasSubstr("cameras[1].fps: every camera of the rig must run at the same rate"));

  const std::filesystem::path system = kDeployDir / "mocapd.yaml";
  EXPECT_THAT(errorOf(system, replaceOnce(readFile(system), "threads: 1", "threads: 0")),
              HasSubstr("mocapd.yaml:9: tracker.threads: must be between 1 and 256"));

  if (!compiledIn("aravis")) GTEST_SKIP() << "the aravis driver is not in this build";
  const std::filesystem::path gige = kConfigDir / "gige.yaml";
  EXPECT_THAT(errorOf(gige, replaceOnce(readFile(gige), "trigger_line: Line1      #", "#")),
              HasSubstr("cameras[0].trigger_line: required with trigger: hardware"));
}

}  // namespace
}  // namespace mocap
