// Recorder and SessionReader: round trips, the stored body model, crash tolerance, bad sessions,
// path confinement.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "drivers/record/recorder.h"
#include "drivers/record/session_reader.h"
#include "tracker/model/builtin_models.h"

namespace mocap {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr int kWidth = 64;
constexpr int kHeight = 48;

// What a session was tracked with, for Recorder::open (fields not given: none).
SessionTracking tracked(const BodyModel* body,
                        std::vector<std::pair<std::string, std::string>> settings = {},
                        std::vector<std::string> truth_dofs = {}) {
  SessionTracking tracking;
  tracking.body = body;
  tracking.tracker_settings = std::move(settings);
  tracking.truth_dofs = std::move(truth_dofs);
  return tracking;
}

class SessionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("mocap_session_test_" + std::to_string(::getpid()) + "_" +
                                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  static std::vector<SessionCamera> cameras(const std::string& format) {
    return {{"left", kWidth, kHeight, format, 25.0}, {"right", kWidth, kHeight, format, 25.0}};
  }
  static Rig rig() {
    Rig r;
    for (int i = 0; i < 2; ++i) {
      r.push_back(CameraModel::lookAt("cam" + std::to_string(i), Eigen::Vector3d(i, -4, 1.5),
                                      Eigen::Vector3d(0, 0, 1), Eigen::Vector3d::UnitZ(), kWidth, kHeight, 80));
    }
    return r;
  }
  // Replaces the first `from` in the session's manifest by `to` (a test failure if it is absent).
  static void editManifest(const fs::path& session, const std::string& from, const std::string& to) {
    std::ifstream in(session / kManifestFile);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    in.close();
    const std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << "'" << from << "' not in\n" << text;
    text.replace(at, from.size(), to);
    std::ofstream(session / kManifestFile, std::ios::trunc) << text;
  }
  // Set `n`: noisy images (incompressible, like the fake scene's), camera 1 missing in set 2.
  static FrameSet makeSet(uint64_t n, int type) {
    FrameSet set;
    set.sequence = 10 + 2 * n;  // gaps, as the synchronizer's numbering can have
    set.timestamp_ns = 1'000'000'000 + static_cast<int64_t>(n) * 40'000'000;
    set.frames.resize(2);
    for (int c = 0; c < 2; ++c) {
      if (n == 2 && c == 1) continue;
      Frame f;
      f.camera = c;
      f.sequence = 100 * c + n;
      f.timestamp_ns = set.timestamp_ns + c * 1000 + 7;
      f.dropped_before = static_cast<uint32_t>(n % 3);
      f.corrupt = n == 3;
      f.image.create(kHeight, kWidth, type);
      cv::RNG rng(n * 2 + c);
      rng.fill(f.image, cv::RNG::UNIFORM, 0, 256);
      set.frames[c] = std::move(f);
    }
    return set;
  }
  fs::path record(const std::string& name, int type, int sets, RecorderOptions options = {}) {
    Recorder recorder(root_, options);
    const std::string format = type == CV_8UC1 ? kPixelGray : kPixelBgr;
    EXPECT_TRUE(recorder.open(name, rig(), cameras(format)).ok());
    for (int n = 0; n < sets; ++n) recorder.write(makeSet(n, type));
    EXPECT_TRUE(recorder.close().ok());
    EXPECT_EQ(recorder.stats().sets_written, static_cast<uint64_t>(sets));
    return recorder.sessionPath();
  }
  static std::string openError(const fs::path& dir, SessionReadOptions options = {}) {
    Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(dir, options);
    return reader.ok() ? std::string("(opened)") : reader.error();
  }
  static void truncateFile(const fs::path& path, std::uintmax_t cut) {
    fs::resize_file(path, fs::file_size(path) - cut);
  }

  fs::path root_;
};

class SessionRoundTrip : public SessionTest, public ::testing::WithParamInterface<int> {};

TEST_P(SessionRoundTrip, ReplaysPixelsTimestampsAndSequencesExactly) {
  const int type = GetParam();
  const fs::path dir = record("take1", type, 5);
  Expected<std::unique_ptr<SessionReader>> opened = SessionReader::open(dir, {.decode_all = true});
  ASSERT_TRUE(opened.ok()) << opened.error();
  const SessionReader& reader = *opened.value();
  EXPECT_EQ(reader.manifest().software_version, MOCAP_TEST_VERSION);
  ASSERT_EQ(reader.cameras().size(), 2u);
  EXPECT_EQ(reader.cameras()[1].name, "right");
  ASSERT_EQ(reader.rig().size(), 2u);
  EXPECT_NEAR(reader.rig()[1].translation.x(), rig()[1].translation.x(), 1e-9);
  EXPECT_TRUE(reader.notes().empty());
  ASSERT_EQ(reader.sets().size(), 5u);
  for (std::size_t n = 0; n < 5; ++n) {
    const FrameSet original = makeSet(n, type);
    EXPECT_EQ(reader.sets()[n].sequence, original.sequence);
    EXPECT_EQ(reader.sets()[n].timestamp_ns, original.timestamp_ns);
    for (int c = 0; c < 2; ++c) {
      ASSERT_EQ(reader.sets()[n].frames[c].has_value(), original.frames[c].has_value()) << n << " " << c;
      if (!original.frames[c]) continue;
      Expected<Frame> frame = reader.readFrame(n, c);
      ASSERT_TRUE(frame.ok()) << frame.error();
      const Frame& want = *original.frames[c];
      EXPECT_EQ(frame.value().camera, c);
      EXPECT_EQ(frame.value().sequence, want.sequence);
      EXPECT_EQ(frame.value().timestamp_ns, want.timestamp_ns);
      EXPECT_EQ(frame.value().dropped_before, want.dropped_before);
      EXPECT_EQ(frame.value().corrupt, want.corrupt);
      ASSERT_EQ(frame.value().image.type(), type);
      EXPECT_EQ(cv::norm(frame.value().image, want.image, cv::NORM_INF), 0.0);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(GrayAndBgr, SessionRoundTrip, ::testing::Values(CV_8UC1, CV_8UC3),
                         [](const ::testing::TestParamInfo<int>& param) {
                           return param.param == CV_8UC1 ? "Gray" : "Bgr";
                         });

TEST_F(SessionTest, TruncatedCommitLineDropsOnlyTheLastSet) {
  const fs::path dir = record("cut", CV_8UC1, 5);
  truncateFile(dir / kSetsFile, 3);  // the process died mid-append of set 4's commit line
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(dir);
  ASSERT_TRUE(reader.ok()) << reader.error();
  EXPECT_EQ(reader.value()->sets().size(), 4u);
  EXPECT_THAT(reader.value()->notes().front(), HasSubstr("truncated last line"));
}

TEST_F(SessionTest, SetCutShortBeforeItsCommitIsIgnored) {
  const fs::path dir = record("cut", CV_8UC1, 5);
  // Died after set 4's camera-0 image and index line, before camera 1's: truncated index line,
  // missing image and no commit line.
  std::string sets;
  {
    std::ifstream in(dir / kSetsFile);
    sets.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  sets.erase(sets.rfind('\n', sets.size() - 2) + 1);
  std::ofstream(dir / kSetsFile, std::ios::trunc) << sets;
  fs::remove(dir / "cam1" / "000003.png");
  truncateFile(dir / "cam1" / kIndexFile, 10);
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(dir, {.decode_all = true});
  ASSERT_TRUE(reader.ok()) << reader.error();
  EXPECT_EQ(reader.value()->sets().size(), 4u);
  EXPECT_EQ(reader.value()->notes().size(), 2u);  // the truncated line, the uncommitted frame
}

TEST_F(SessionTest, KilledRecorderProcessLeavesAReadableSession) {
  const fs::path dir = root_ / "killed";
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // The child records until killed; it never returns into the test framework.
    Recorder recorder(root_, {.queue_sets = 8, .durability = Durability::kProcessCrash});
    if (!recorder.open("killed", rig(), cameras(kPixelBgr)).ok()) ::_exit(1);
    for (uint64_t n = 0;; ++n) {
      FrameSet set = makeSet(n % 4 == 2 ? 1 : n, CV_8UC3);  // always both cameras
      set.sequence = n;
      recorder.write(set);
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  }
  // Kill once at least 20 sets are committed (generous timeout, no timing assertion).
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  for (;;) {
    std::ifstream in(dir / kSetsFile);
    const auto lines = std::count(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>(), '\n');
    if (lines > 20 || std::chrono::steady_clock::now() > give_up) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(dir, {.decode_all = true});
  ASSERT_TRUE(reader.ok()) << reader.error();
  EXPECT_GE(reader.value()->sets().size(), 20u);
  for (std::size_t i = 0; i < reader.value()->sets().size(); ++i) {
    if (i > 0) {
      EXPECT_GT(reader.value()->sets()[i].sequence, reader.value()->sets()[i - 1].sequence);
    }
    for (int c = 0; c < 2; ++c) ASSERT_TRUE(reader.value()->readFrame(i, c).ok()) << i << " " << c;
  }
}

TEST_F(SessionTest, MissingManifestIsNamed) {
  fs::create_directories(root_ / "empty");
  EXPECT_THAT(openError(root_ / "empty"), HasSubstr("manifest.yaml: missing"));
}

TEST_F(SessionTest, BadManifestFieldIsNamed) {
  const fs::path dir = record("bad", CV_8UC1, 2);
  editManifest(dir, "width: " + std::to_string(kWidth), "width: -3");
  const std::string error = openError(dir);
  EXPECT_THAT(error, HasSubstr("manifest.yaml"));
  EXPECT_THAT(error, HasSubstr("cameras[0].width"));
  EXPECT_THAT(error, HasSubstr("-3"));
}

TEST_F(SessionTest, StoresTheBodyModelAndTrackerSettingsItWasTrackedWith) {
  const BodyModel body = builtinHumanModel();
  const std::vector<std::pair<std::string, std::string>> settings = {
      {"method", "factored"}, {"evaluations", "2000"}, {"refine", "0.4"}, {"refine_hold", "true"}};
  Recorder recorder(root_);
  ASSERT_TRUE(
      recorder.open("with_body", rig(), cameras(kPixelGray), tracked(&body, settings)).ok());
  recorder.write(makeSet(0, CV_8UC1));
  ASSERT_TRUE(recorder.close().ok());
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(recorder.sessionPath());
  ASSERT_TRUE(reader.ok()) << reader.error();
  ASSERT_NE(reader.value()->bodyModel(), nullptr);
  EXPECT_EQ(reader.value()->bodyModel()->name, body.name);
  EXPECT_EQ(reader.value()->bodyModel()->dofs.size(), body.dofs.size());
  EXPECT_EQ(reader.value()->bodyModel()->points.size(), body.points.size());
  EXPECT_EQ(reader.value()->trackerSettings(), settings);

  Expected<std::unique_ptr<SessionReader>> without = SessionReader::open(record("without", CV_8UC1, 1));
  ASSERT_TRUE(without.ok()) << without.error();
  EXPECT_EQ(without.value()->bodyModel(), nullptr);
  EXPECT_TRUE(without.value()->trackerSettings().empty());
  EXPECT_FALSE(fs::exists(without.value()->path() / kBodyModelFile));
}

// A subject tracked with a body not its own (the fake scene's track_subject_body: false, or a
// fitted body applied): the truth's poses are of the subject's body, which the session stores
// beside the tracked one. Without it, the truth is of the tracked body.
TEST_F(SessionTest, StoresTheBodyTheTruthIsOfWhenNotTheTrackedOne) {
  const BodyModel tracked_body = builtinHumanModel();
  const BodyModel subject = scaledBodyModel(tracked_body, 0.9);
  std::vector<std::string> names;
  for (const Dof& dof : tracked_body.dofs) names.push_back(dof.name);
  SessionTracking tracking = tracked(&tracked_body, {}, names);
  tracking.truth_body = &subject;
  Recorder recorder(root_);
  ASSERT_TRUE(recorder.open("subject", rig(), cameras(kPixelGray), tracking).ok());
  recorder.write(makeSet(0, CV_8UC1), {0, tracked_body.neutralPose()});
  ASSERT_TRUE(recorder.close().ok());
  {
    Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(recorder.sessionPath());
    ASSERT_TRUE(reader.ok()) << reader.error();
    ASSERT_NE(reader.value()->truthBodyModel(), nullptr);
    EXPECT_NEAR(reader.value()->truthBodyModel()->segments[0].offset.z(),
                subject.segments[0].offset.z(), 1e-9);
    EXPECT_NEAR(reader.value()->bodyModel()->segments[0].offset.z(),
                tracked_body.segments[0].offset.z(), 1e-9);
  }

  // A truth body whose DOFs are not the tracked body's cannot be the truth's.
  const BodyModel hand = builtinHandModel();
  std::ofstream(recorder.sessionPath() / kTruthBodyModelFile, std::ios::trunc)
      << formatBodyModel(hand);
  EXPECT_THAT(openError(recorder.sessionPath()),
              HasSubstr("truth_body.yaml: its DOFs are not those of the tracked body"));
  editManifest(recorder.sessionPath(), "truth_body_model: truth_body.yaml",
               "truth_body_model: ../truth_body.yaml");
  EXPECT_THAT(openError(recorder.sessionPath()),
              HasSubstr("truth_body_model: '../truth_body.yaml' is not a file name"));

  Recorder own(root_);
  ASSERT_TRUE(own.open("own", rig(), cameras(kPixelGray), tracked(&tracked_body, {}, names)).ok());
  ASSERT_TRUE(own.close().ok());
  EXPECT_FALSE(fs::exists(own.sessionPath() / kTruthBodyModelFile));
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(own.sessionPath());
  ASSERT_TRUE(reader.ok()) << reader.error();
  EXPECT_EQ(reader.value()->truthBodyModel(), reader.value()->bodyModel());
}

TEST_F(SessionTest, BadBodyModelIsNamed) {
  const BodyModel body = builtinHandModel();
  Recorder recorder(root_);
  ASSERT_TRUE(recorder.open("bad_body", rig(), cameras(kPixelGray), tracked(&body)).ok());
  ASSERT_TRUE(recorder.close().ok());
  std::ofstream(recorder.sessionPath() / kBodyModelFile, std::ios::trunc)
      << "name: hand\nsegments:\n  - name: palm\n    shape: {type: blob}\n";
  const std::string error = openError(recorder.sessionPath());
  EXPECT_THAT(error, HasSubstr("body.yaml"));
  EXPECT_THAT(error, HasSubstr("shape.type"));

  // A manifest pointing outside the session is refused before anything is read.
  editManifest(recorder.sessionPath(), "body_model: body.yaml", "body_model: ../body.yaml");
  EXPECT_THAT(openError(recorder.sessionPath()), HasSubstr("body_model: '../body.yaml' is not a file name"));
}

TEST_F(SessionTest, TrackerSettingsThatAreNotAMapOfValuesAreNamed) {
  Recorder recorder(root_);
  ASSERT_TRUE(recorder
                  .open("bad_tracker", rig(), cameras(kPixelGray),
                        tracked(nullptr, {{"evaluations", "800"}}))
                  .ok());
  ASSERT_TRUE(recorder.close().ok());
  editManifest(recorder.sessionPath(), "evaluations: 800", "evaluations: [800, 900]");
  EXPECT_THAT(openError(recorder.sessionPath()), HasSubstr("manifest.yaml: tracker.evaluations: expected a single value"));
}

// A background model of the test cameras' size whose pixels say which one it is.
std::shared_ptr<const BackgroundModel> background(float level, int type) {
  const int channels = type == CV_8UC1 ? 1 : 3;
  BackgroundModel model{cv::Mat(kHeight, kWidth, CV_32FC(channels), cv::Scalar::all(level)),
                        cv::Mat(kHeight, kWidth, CV_32FC(channels), cv::Scalar::all(2.5))};
  return std::make_shared<const BackgroundModel>(std::move(model));
}

TEST_F(SessionTest, StoresTheBackgroundsItsSilhouettesWereExtractedAgainst) {
  Recorder recorder(root_);
  ASSERT_TRUE(recorder.open("backgrounds", rig(), cameras(kPixelGray)).ok());
  recorder.writeBackground(0, 0, background(40, CV_8UC1));  // camera 0's from the start; 1 none
  for (int n = 0; n < 3; ++n) recorder.write(makeSet(n, CV_8UC1));
  recorder.writeBackground(1, 103, background(90, CV_8UC1));  // captured during the recording
  recorder.writeBackground(0, 3, background(91, CV_8UC1));
  for (int n = 3; n < 5; ++n) recorder.write(makeSet(n, CV_8UC1));
  recorder.writeBackground(0, 5, nullptr);  // its extraction failed: thresholded from frame 5
  ASSERT_TRUE(recorder.close().ok());
  EXPECT_EQ(recorder.stats().sets_written, 5u);

  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(recorder.sessionPath());
  ASSERT_TRUE(reader.ok()) << reader.error();
  const std::vector<SessionBackground>& stored = reader.value()->backgrounds();
  ASSERT_EQ(stored.size(), 4u);
  const struct {
    uint64_t from;
    int camera;
    std::string file;
    float level;  // of the mean; 0: no background
  } expected[] = {{0, 0, "cam0/background_000000.yml", 40},
                  {103, 1, "cam1/background_000103.yml", 90},
                  {3, 0, "cam0/background_000003.yml", 91},
                  {5, 0, "", 0}};
  for (std::size_t i = 0; i < stored.size(); ++i) {
    EXPECT_EQ(stored[i].from_sequence, expected[i].from) << i;
    EXPECT_EQ(stored[i].camera, expected[i].camera) << i;
    EXPECT_EQ(stored[i].file, expected[i].file) << i;
    ASSERT_EQ(stored[i].model != nullptr, expected[i].level > 0) << i;
    if (!stored[i].model) continue;
    EXPECT_EQ(
        cv::norm(stored[i].model->mean, background(expected[i].level, CV_8UC1)->mean, cv::NORM_INF),
        0)
        << i;
    EXPECT_EQ(cv::norm(stored[i].model->stddev, background(0, CV_8UC1)->stddev, cv::NORM_INF), 0)
        << i;
  }
}

TEST_F(SessionTest, BadBackgroundsAreNamedWithTheirLine) {
  const auto recordWithBackground = [&](const std::string& name) {
    Recorder recorder(root_);
    EXPECT_TRUE(recorder.open(name, rig(), cameras(kPixelGray)).ok());
    recorder.writeBackground(0, 0, background(40, CV_8UC1));
    recorder.writeBackground(1, 0, background(50, CV_8UC1));
    recorder.write(makeSet(0, CV_8UC1));
    EXPECT_TRUE(recorder.close().ok());
    return recorder.sessionPath();
  };
  const fs::path lines = fs::path(kBackgroundsFile);
  {
    const fs::path dir = recordWithBackground("camera");
    std::ofstream(dir / lines, std::ios::app) << "7,2,background_000000.yml\n";
    EXPECT_THAT(
        openError(dir),
        HasSubstr("backgrounds.csv:4: camera '2' is not a camera of the session (2 cameras)"));
  }
  {
    const fs::path dir = recordWithBackground("back");
    std::ofstream(dir / lines, std::ios::app) << "9,1,background_000000.yml\n0,1,\n";
    EXPECT_THAT(openError(dir),
                HasSubstr("backgrounds.csv:5: from_sequence 0 goes back (camera 1)"));
  }
  {
    const fs::path dir = recordWithBackground("missing");
    fs::remove(dir / "cam1" / "background_000000.yml");
    const std::string error = openError(dir);
    EXPECT_THAT(error, HasSubstr("backgrounds.csv:3: "));
    EXPECT_THAT(error, HasSubstr("cam1/background_000000.yml"));
  }
  {
    const fs::path dir = recordWithBackground("colour");
    saveBackground((dir / "cam0" / "background_000000.yml").string(), *background(40, CV_8UC3));
    EXPECT_THAT(openError(dir),
                HasSubstr("background_000000.yml is 64x48 with 3 channel(s), camera 0 "
                          "is 64x48 GREY"));
  }
  {
    const fs::path dir = recordWithBackground("escape");
    std::ofstream(dir / lines, std::ios::app) << "3,0,../cam1/background_000000.yml\n";
    EXPECT_THAT(openError(dir),
                HasSubstr("file '../cam1/background_000000.yml' is not a file name"));
  }
  {  // a crash mid-append: the line is dropped and noted, the session opens
    const fs::path dir = recordWithBackground("cut");
    std::ofstream(dir / lines, std::ios::app) << "3,0,backgr";
    Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(dir);
    ASSERT_TRUE(reader.ok()) << reader.error();
    EXPECT_EQ(reader.value()->backgrounds().size(), 2u);
    EXPECT_THAT(reader.value()->notes(),
                ::testing::Contains(HasSubstr("backgrounds.csv: dropped a truncated last line")));
  }
}

// The true poses of a source that knows them come back exactly, keyed by the set's first frame.
TEST_F(SessionTest, StoresTheTruePosesOfASourceThatKnowsThem) {
  const BodyModel body = builtinHumanModel();
  std::vector<std::string> names;
  for (const Dof& dof : body.dofs) names.push_back(dof.name);
  Recorder recorder(root_);
  ASSERT_TRUE(
      recorder.open("truth", rig(), cameras(kPixelGray), tracked(&body, {}, names)).ok());
  std::vector<Eigen::VectorXd> poses;
  for (int n = 0; n < 4; ++n) {
    poses.push_back(Eigen::VectorXd::Random(static_cast<Eigen::Index>(body.dofs.size())) / 3.0);
    // Set 2 has its subject out of view: no truth.
    recorder.write(makeSet(n, CV_8UC1),
                   {static_cast<uint64_t>(n), n == 2 ? Eigen::VectorXd() : poses.back()});
  }
  ASSERT_TRUE(recorder.close().ok());
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(recorder.sessionPath());
  ASSERT_TRUE(reader.ok()) << reader.error();
  EXPECT_TRUE(reader.value()->hasTruth());
  for (uint64_t n = 0; n < 4; ++n) {
    const Eigen::VectorXd* truth = reader.value()->truth(n);
    ASSERT_EQ(truth != nullptr, n != 2) << n;
    if (truth) {
      EXPECT_EQ(*truth, poses[n]) << n;  // exactly: %.17g round-trips
    }
  }
  EXPECT_EQ(reader.value()->truth(99), nullptr);
  EXPECT_FALSE(SessionReader::open(record("without", CV_8UC1, 1)).value()->hasTruth());

  const fs::path lines = recorder.sessionPath() / kTruthFile;
  std::ofstream(lines, std::ios::app) << "7,0.5\n";
  EXPECT_THAT(openError(recorder.sessionPath()),
              HasSubstr("truth.csv:5: expected " + std::to_string(body.dofs.size() + 1) +
                        " columns, found 2"));
  std::string text;
  {
    std::ifstream in(lines);
    std::getline(in, text);  // the header alone, then a bad value
  }
  std::string row = "7";
  for (std::size_t d = 0; d < body.dofs.size(); ++d) row += d == 3 ? ",x" : ",0";
  std::ofstream(lines, std::ios::trunc) << text << "\n" << row << "\n";
  EXPECT_THAT(openError(recorder.sessionPath()),
              HasSubstr("truth.csv:2: " + body.dofs[3].name + ": 'x' is not a finite number"));
  std::ofstream(lines, std::ios::trunc) << "frame_sequence,a,b\n";
  EXPECT_THAT(openError(recorder.sessionPath()), HasSubstr("truth.csv:1: header is"));
}

TEST_F(SessionTest, BadIndexLineIsNamedWithItsLine) {
  const fs::path dir = record("bad", CV_8UC1, 3);
  std::ofstream(dir / "cam0" / kIndexFile, std::ios::app) << "12,x,3,0,0,000009.png,\n";
  const std::string error = openError(dir);
  EXPECT_THAT(error, HasSubstr("cam0/index.csv:5"));
  EXPECT_THAT(error, HasSubstr("camera_sequence 'x'"));
}

TEST_F(SessionTest, MissingImageIsNamedWithItsFrame) {
  const fs::path dir = record("bad", CV_8UC1, 4);
  fs::remove(dir / "cam1" / "000001.png");
  const std::string error = openError(dir);
  EXPECT_THAT(error, HasSubstr("cam1/000001.png"));
  EXPECT_THAT(error, HasSubstr("frame 101 of camera 1 (set 12)"));
  EXPECT_THAT(error, HasSubstr("missing"));
}

TEST_F(SessionTest, TruncatedPngFailsTheOpen) {
  const fs::path dir = record("bad", CV_8UC3, 4);
  truncateFile(dir / "cam0" / "000002.png", 100);
  const std::string error = openError(dir);
  EXPECT_THAT(error, HasSubstr("cam0/000002.png"));
  EXPECT_THAT(error, HasSubstr("truncated PNG"));
}

TEST_F(SessionTest, CorruptPngIsNamedWhenDecoded) {
  const fs::path dir = record("bad", CV_8UC3, 4);
  const fs::path image = dir / "cam0" / "000001.png";
  {
    // Garbage over the compressed data; signature, header and end stay intact.
    std::fstream file(image, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(60);
    const std::string garbage(200, '\x5a');
    file.write(garbage.data(), static_cast<std::streamsize>(garbage.size()));
  }
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(dir);
  ASSERT_TRUE(reader.ok()) << reader.error();  // the cheap check cannot see inside the data
  Expected<Frame> frame = reader.value()->readFrame(1, 0);
  ASSERT_FALSE(frame.ok());
  EXPECT_THAT(frame.error(), HasSubstr("cam0/000001.png: frame 1 of camera 0 (set 12)"));
  EXPECT_THAT(openError(dir, {.decode_all = true}), HasSubstr("cam0/000001.png"));
}

TEST_F(SessionTest, RefusesPathsOutsideTheRoot) {
  Recorder recorder(root_);
  const fs::path outside = root_.parent_path() / (root_.filename().string() + "_outside");
  fs::create_directories(outside);
  fs::create_directory_symlink(outside, root_ / "link");
  EXPECT_THAT(recorder.open("../escape", rig(), cameras(kPixelGray)).message(), HasSubstr("'..'"));
  EXPECT_THAT(recorder.open("a/../../escape", rig(), cameras(kPixelGray)).message(), HasSubstr("'..'"));
  EXPECT_THAT(recorder.open(outside / "abs", rig(), cameras(kPixelGray)).message(), HasSubstr("outside the recording root"));
  EXPECT_THAT(recorder.open("link/take", rig(), cameras(kPixelGray)).message(), HasSubstr("outside the recording root"));
  EXPECT_FALSE(fs::exists(outside / "take"));
  fs::remove_all(outside);
  EXPECT_TRUE(recorder.open(root_ / "inside", rig(), cameras(kPixelGray)).ok());  // absolute, inside
  EXPECT_TRUE(recorder.close().ok());
}

TEST_F(SessionTest, RefusesANonEmptyDirectory) {
  fs::create_directories(root_ / "used");
  std::ofstream(root_ / "used" / "file") << "x";
  Recorder recorder(root_);
  EXPECT_THAT(recorder.open("used", rig(), cameras(kPixelGray)).message(), HasSubstr("not empty"));
}

TEST_F(SessionTest, DropsSetsRatherThanBlockWhenTheDiskFallsBehind) {
  Recorder recorder(root_, {.queue_sets = 1});
  ASSERT_TRUE(recorder.open("busy", rig(), cameras(kPixelBgr)).ok());
  for (int n = 0; n < 300; ++n) {
    FrameSet set = makeSet(n == 2 ? 1 : n, CV_8UC3);
    set.sequence = static_cast<uint64_t>(n);
    recorder.write(set);
  }
  ASSERT_TRUE(recorder.close().ok());
  const RecorderStats stats = recorder.stats();
  EXPECT_EQ(stats.sets_received, 300u);
  EXPECT_GT(stats.sets_dropped, 0u);
  EXPECT_EQ(stats.sets_written + stats.sets_dropped, 300u);
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(recorder.sessionPath());
  ASSERT_TRUE(reader.ok()) << reader.error();
  EXPECT_EQ(reader.value()->sets().size(), stats.sets_written);
}

TEST_F(SessionTest, RejectsFramesThatDoNotMatchTheirCamera) {
  Recorder recorder(root_);
  ASSERT_TRUE(recorder.open("mismatch", rig(), cameras(kPixelGray)).ok());
  recorder.write(makeSet(0, CV_8UC3));  // BGR frames into a gray session
  ASSERT_TRUE(recorder.close().ok());
  EXPECT_EQ(recorder.stats().frames_rejected, 2u);
  EXPECT_EQ(recorder.stats().sets_written, 0u);
}

}  // namespace
}  // namespace mocap
