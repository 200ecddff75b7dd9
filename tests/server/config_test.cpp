// Configuration parsing: the embedded default, the defaults for people, and bad values refused with
// file, line, field and reason.
#include "server/config.h"

#include <filesystem>
#include <fstream>
#include <string>
#include <tuple>
#include <utility>

#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "drivers/builtin_drivers.h"
#include "server/tls_test_support.h"
#include "tracker/filters/filter.h"

namespace mocap {
namespace {

using ::testing::HasSubstr;

std::string errorOf(const std::string& yaml) {
  try {
    parseConfig(yaml, "test.yaml", ".");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(ConfigTest, EmbeddedDefaultIsTheFakeTwoCameraScene) {
  const ServerConfig config = parseConfig(kDefaultConfigYaml, "default", ".");
  ASSERT_EQ(config.cameras.size(), 2u);
  for (const CameraConfig& camera : config.cameras) {
    EXPECT_EQ(camera.driver, "fake");
    EXPECT_EQ(camera.width, 780);
    EXPECT_EQ(camera.height, 580);
    EXPECT_EQ(camera.fps, 25.0);
  }
  EXPECT_EQ(config.listen, "127.0.0.1:50051");
  EXPECT_TRUE(config.bearer_token.empty());
}

TEST(ConfigTest, TrackerOptionsForPeople) {
  const ServerConfig config = parseConfig(
      "cameras:\n  - {driver: fake, width: 780, height: 580}\n"
      "tracker: {evaluations: 2000, inject: segment, injection: 0.05, lookahead: body, refine: 0.4,"
      " refine_hold: true, refine_plant: true, refine_swap: true, refine_restarts: 0.14,"
      " refine_facing_prior: 16, refine_max: 30, refine_unexplained: true, dofs: gait}\n",
      "test.yaml", ".");
  EXPECT_EQ(config.tracker.filter.refine.max_evaluations, 30);
  EXPECT_EQ(config.tracker.filter.lookahead, FilterOptions::Lookahead::kBody);
  EXPECT_EQ(config.tracker.dofs, "gait");
  EXPECT_EQ(config.tracker.filter.refine.share, 0.4);
  EXPECT_TRUE(config.tracker.filter.refine.hold);
  EXPECT_TRUE(config.tracker.filter.refine.plant);
  EXPECT_TRUE(config.tracker.filter.refine.swap.enabled);
  EXPECT_EQ(config.tracker.filter.refine.restart_share, 0.14);
  EXPECT_EQ(config.tracker.filter.refine.facing_prior, 16);
  EXPECT_TRUE(config.tracker.filter.refine.unexplained);
  // Unset, they are the paper's filter.
  const ServerConfig plain = parseConfig(kDefaultConfigYaml, "default", ".");
  EXPECT_EQ(plain.tracker.filter.lookahead, FilterOptions::Lookahead::kNone);
  EXPECT_EQ(plain.tracker.filter.refine.share, 0);
  EXPECT_EQ(plain.tracker.filter.refine.max_evaluations, 0);
  EXPECT_FALSE(plain.tracker.filter.refine.hold);
  EXPECT_FALSE(plain.tracker.filter.refine.plant);
  EXPECT_FALSE(plain.tracker.filter.refine.swap.enabled);
  EXPECT_EQ(plain.tracker.filter.refine.restart_share, 0);
  EXPECT_EQ(plain.tracker.filter.refine.facing_prior, 0);
  EXPECT_FALSE(plain.tracker.filter.refine.unexplained);
  EXPECT_EQ(plain.tracker.dofs, "all");
}

// refine_swap: knees exchanges only the knees (the option measured in docs/human.md); true the
// whole legs. A recorded session keeps which.
TEST(ConfigTest, RefineSwapKneesExchangesOnlyTheKnees) {
  const std::string cameras = "cameras:\n  - {driver: fake, width: 780, height: 580}\n";
  const ServerConfig knees =
      parseConfig(cameras + "tracker: {refine_swap: knees}\n", "test.yaml", ".");
  EXPECT_TRUE(knees.tracker.filter.refine.swap.enabled);
  EXPECT_TRUE(knees.tracker.filter.refine.swap.enabled);
  EXPECT_TRUE(knees.tracker.filter.refine.swap.knees_only);
  const ServerConfig legs =
      parseConfig(cameras + "tracker: {refine_swap: true}\n", "test.yaml", ".");
  EXPECT_TRUE(legs.tracker.filter.refine.swap.enabled);
  EXPECT_FALSE(legs.tracker.filter.refine.swap.knees_only);

  // The margin the exchanged pose must gain: the filter's unless set, and kept by a session.
  EXPECT_EQ(knees.tracker.filter.refine.swap.margin, FilterOptions().refine.swap.margin);
  const ServerConfig strict = parseConfig(
      cameras + "tracker: {refine_swap: knees, refine_swap_margin: 1234.5}\n", "test.yaml", ".");
  EXPECT_EQ(strict.tracker.filter.refine.swap.margin, 1234.5);

  const ServerConfig plain = parseConfig(cameras, "replay.yaml", ".");
  const TrackerSettings replayed =
      replayTrackerSettings(plain, knees.tracker.keyValues(), "session/manifest.yaml");
  EXPECT_TRUE(replayed.filter.refine.swap.knees_only);
  EXPECT_EQ(replayTrackerSettings(plain, strict.tracker.keyValues(), "session/manifest.yaml")
                .filter.refine.swap.margin,
            1234.5);
  const ServerConfig off = parseConfig(cameras + "tracker: {refine_swap: false}\n", "r.yaml", ".");
  EXPECT_FALSE(replayTrackerSettings(off, knees.tracker.keyValues(), "session/manifest.yaml")
                   .filter.refine.swap.knees_only);  // the configuration's own key wins
}

TEST(ConfigTest, APersonGetsThePeopleDefaultsUnlessTheTrackerSaysOtherwise) {
  const std::string cameras = "cameras:\n  - {driver: fake, width: 780, height: 580}\n";
  const ServerConfig person =
      parseConfig(cameras + "body_model: builtin:human\n", "test.yaml", ".");
  EXPECT_EQ(person.tracker.filter.evaluations_per_frame, 2000);
  EXPECT_EQ(person.tracker.filter.injection.redraw, InjectionOptions::Redraw::kSegment);
  EXPECT_EQ(person.tracker.filter.injection.share, 0.05);
  EXPECT_EQ(person.tracker.filter.lookahead, FilterOptions::Lookahead::kBody);
  EXPECT_EQ(person.tracker.filter.refine.share, 0.4);
  EXPECT_TRUE(person.tracker.filter.refine.hold);
  EXPECT_TRUE(person.tracker.filter.refine.plant);
  EXPECT_FALSE(person.tracker.filter.refine.swap.enabled);  // measured, not kept (docs/human.md)
  EXPECT_EQ(person.tracker.filter.refine.restart_share, 0.14);
  EXPECT_EQ(person.tracker.filter.refine.facing_prior, 16);
  EXPECT_EQ(person.tracker.filter.refine.uncross, 10);

  const ServerConfig tuned = parseConfig(
      cameras + "body_model: builtin:human\ntracker: {evaluations: 800, refine_hold: false}\n",
      "test.yaml", ".");
  EXPECT_EQ(tuned.tracker.filter.evaluations_per_frame, 800);
  EXPECT_FALSE(tuned.tracker.filter.refine.hold);
  EXPECT_EQ(tuned.tracker.filter.lookahead,
            FilterOptions::Lookahead::kBody);  // the keys not given keep the people defaults

  const ServerConfig hand = parseConfig(cameras + "body_model: builtin:hand\n", "test.yaml", ".");
  EXPECT_EQ(hand.tracker.filter.evaluations_per_frame, 375);
  EXPECT_EQ(hand.tracker.filter.lookahead, FilterOptions::Lookahead::kNone);
}

TEST(ConfigTest, ABodyModelFileSaysWhetherItIsAPerson) {
  // A subject's fitted body, as a user would install it: the file's `kind: person` chooses the
  // people defaults, as builtin:human does.
  const std::string models = std::string(MOCAP_SOURCE_DIR) + "/tracker/models/";
  const std::string cameras = "cameras:\n  - {driver: fake, width: 780, height: 580}\n";
  const ServerConfig person =
      parseConfig(cameras + "body_model: " + models + "human.yaml\n", "test.yaml", ".");
  EXPECT_EQ(person.tracker.filter.evaluations_per_frame, 2000);
  EXPECT_EQ(person.tracker.filter.lookahead, FilterOptions::Lookahead::kBody);
  const ServerConfig hand =
      parseConfig(cameras + "body_model: " + models + "hand.yaml\n", "test.yaml", ".");
  EXPECT_EQ(hand.tracker.filter.evaluations_per_frame, 375);
  EXPECT_EQ(hand.tracker.filter.lookahead, FilterOptions::Lookahead::kNone);
  // Each file read once, here; the server tracks that model (end_to_end_test).
  ASSERT_TRUE(person.body_model_file && hand.body_model_file);
  EXPECT_TRUE(person.body_model_file->person);
  EXPECT_FALSE(hand.body_model_file->person);
  EXPECT_FALSE(
      parseConfig(cameras + "body_model: builtin:human\n", "test.yaml", ".").body_model_file);

  // A model file that does not load is refused with the configuration.
  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / "config_kind";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "broken.yaml") << "kind: horse\nsegments: [{name: a}]\n";
  try {
    parseConfig(cameras + "body_model: broken.yaml\n", "test.yaml", dir);
    ADD_FAILURE() << "a broken body model file was accepted";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), testing::HasSubstr("test.yaml:3: body_model: "));
    EXPECT_THAT(e.what(), testing::HasSubstr("broken.yaml:1: kind: expected person or other"));
  }
}

TEST(ConfigTest, AReplayTracksWithTheSessionsSettingsUnderTheConfigurationsOwnKeys) {
  TrackerSettings recorded = TrackerSettings::forPeople();
  recorded.filter.seed = 7;
  recorded.threads = 8;
  recorded.filter.injection.share =
      0.1 + 0.2;  // not the shortest decimal: must still read back exactly
  recorded.dofs = "gait";
  recorded.filter.refine.swap.enabled =
      true;  // not the people default: must come back from the session
  recorded.filter.refine.max_evaluations = 30;                               // likewise
  recorded.filter.refine.unexplained = !recorded.filter.refine.unexplained;  // likewise
  recorded.challenge_every = 25;                                             // likewise
  recorded.trial_drop_margin = 12.5;                                         // likewise
  const std::string cameras = "cameras:\n  - {driver: fake, width: 780, height: 580}\n";

  // A configuration without tracker keys: the session's settings, the configuration's threads.
  const ServerConfig plain = parseConfig(cameras, "replay.yaml", ".");
  const TrackerSettings as_recorded =
      replayTrackerSettings(plain, recorded.keyValues(), "session/manifest.yaml");
  EXPECT_EQ(as_recorded.method, recorded.method);
  EXPECT_EQ(as_recorded.filter.evaluations_per_frame, 2000);
  EXPECT_EQ(as_recorded.filter.injection.share, recorded.filter.injection.share);
  EXPECT_EQ(as_recorded.filter.injection.redraw, InjectionOptions::Redraw::kSegment);
  EXPECT_EQ(as_recorded.filter.seed, 7u);
  EXPECT_EQ(as_recorded.filter.lookahead, FilterOptions::Lookahead::kBody);
  EXPECT_EQ(as_recorded.filter.refine.share, 0.4);
  EXPECT_TRUE(as_recorded.filter.refine.hold);
  EXPECT_TRUE(as_recorded.filter.refine.plant);
  EXPECT_TRUE(as_recorded.filter.refine.swap.enabled);
  EXPECT_EQ(as_recorded.filter.refine.restart_share, 0.14);
  EXPECT_EQ(as_recorded.filter.refine.max_evaluations, 30);
  EXPECT_EQ(as_recorded.filter.refine.unexplained, recorded.filter.refine.unexplained);
  EXPECT_EQ(as_recorded.dofs, "gait");
  EXPECT_EQ(as_recorded.challenge_every, 25);
  EXPECT_EQ(as_recorded.trial_drop_margin, 12.5);
  EXPECT_EQ(as_recorded.threads, 1);

  // Keys the configuration sets itself win.
  const ServerConfig tuned =
      parseConfig(cameras + "tracker: {threads: 2, evaluations: 800, refine_hold: false}\n",
                  "replay.yaml", ".");
  const TrackerSettings overridden =
      replayTrackerSettings(tuned, recorded.keyValues(), "session/manifest.yaml");
  EXPECT_EQ(overridden.filter.evaluations_per_frame, 800);
  EXPECT_FALSE(overridden.filter.refine.hold);
  EXPECT_EQ(overridden.threads, 2);
  EXPECT_EQ(overridden.filter.lookahead, FilterOptions::Lookahead::kBody);

  // A bad stored setting is named with the session's manifest.
  const auto errorOfStored = [&](std::vector<std::pair<std::string, std::string>> stored) {
    try {
      replayTrackerSettings(plain, stored, "session/manifest.yaml");
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_THAT(errorOfStored({{"lookahead", "ahead"}}),
              HasSubstr("session/manifest.yaml: tracker.lookahead: expected none or body"));
  EXPECT_THAT(errorOfStored({{"speed", "3"}}), HasSubstr("tracker.speed: unknown key"));
}

TEST(ConfigTest, BadValuesNameFileLineFieldAndReason) {
  registerBuiltinDrivers(DriverRegistry::instance());  // the real cameras' keys are checked too
  const std::string cameras = "cameras:\n  - {driver: fake, width: 780, height: 580}\n";
  const std::string walk = MOCAP_SHARED_DIR "/data/motion/cmu_131_01_walk.bvh";
  // (configuration, what its error must say)
  const std::pair<std::string, std::string> cases[] = {
      {cameras + "tracker:\n  evaluations: -5\n",
       "test.yaml:4: tracker.evaluations: must be between 1 and"},
      {cameras + "tracker: {method: magic}\n",
       "tracker.method: expected factored, condensation or annealed"},
      {cameras + "tracker: {inject: limbs}\n",
       "tracker.inject: expected dof or segment, got 'limbs'"},
      {cameras + "tracker: {lookahead: ahead}\n",
       "tracker.lookahead: expected none or body, got 'ahead'"},
      {cameras + "tracker: {refine: 1.5}\n", "tracker.refine: must be between 0 and 0.99"},
      {cameras + "tracker: {refine_max: -1}\n", "tracker.refine_max: must be between 0 and"},
      {cameras + "tracker: {refine_hold: maybe}\n", "tracker.refine_hold"},
      {cameras + "tracker: {refine_plant: 2}\n", "tracker.refine_plant"},
      {cameras + "tracker: {refine_swap: yes please}\n",
       "tracker.refine_swap: expected true, false or knees, got 'yes please'"},
      {cameras + "tracker: {refine_swap_margin: -5}\n",
       "tracker.refine_swap_margin: must be between 0 and"},
      {cameras + "tracker: {refine_restarts: 2}\n",
       "tracker.refine_restarts: must be between 0 and 1"},
      {cameras + "tracker: {refine_facing_prior: -1}\n", "tracker.refine_facing_prior: must be"},
      {cameras + "tracker: {refine_uncross: -1}\n", "tracker.refine_uncross: must be"},
      {cameras + "tracker: {refine_unexplained: often}\n", "tracker.refine_unexplained"},
      {cameras + "tracker: {dofs: arms}\n", "tracker.dofs: expected all or gait, got 'arms'"},
      {cameras + "tracker: {start: somewhere}\n",
       "tracker.start: expected auto, acquire or neutral, got 'somewhere'"},
      {cameras + "tracker: {lost_below: 1}\n", "tracker.lost_below: must be between 0 and 0.99"},
      {cameras + "tracker: {lost_after: 0}\n", "tracker.lost_after: must be between 1 and"},
      {cameras + "tracker: {challenge_every: -1}\n",
       "tracker.challenge_every: must be between 0 and"},
      {cameras + "tracker: {trial_drop_margin: -1}\n",
       "tracker.trial_drop_margin: must be between 0 and"},
      {cameras + "listen: nowhere\n", "test.yaml:3: listen:"},
      {cameras + "listen: {host: 127.0.0.1}\n",
       "test.yaml:3: listen: expected a non-empty string, got a map"},
      {cameras + "listen:\n", "listen: expected a non-empty string, got nothing"},
      {cameras + "tracker: {evaluations: [1, 2]}\n",
       "tracker.evaluations: expected a single value, got a list"},
      {cameras + "trackr: {}\n", "trackr: unknown key"},
      {"cameras:\n  - {driver: nosuch}\n", "cameras[0].driver: no driver 'nosuch'"},
      {"cameras: []\n", "cameras: expected a non-empty list"},
      {cameras + "  - {driver: fake, width: 780, height: 580, fps: 30}\n",
       "cameras[1].fps: every camera of the rig must run at the same rate"},
      {cameras + "calibration: /no/such/rig.yaml\n", "calibration: no such file"},
      {cameras + "auth: {token: short}\n", "at least 16 characters"},
      {cameras + "recording_directory: /no/such/dir\n",
       "recording_directory: not an existing directory"},
      {cameras + "tls: {cert: /no/cert.pem}\n", "tls: needs both 'cert' and 'key'"},
      {"cameras: [\n", "test.yaml:"},
      {cameras + "background_directory: /no/such/dir\n",
       "test.yaml:3: background_directory: not an existing directory"},
      {cameras + "silhouettes: guessed\n",
       "test.yaml:3: silhouettes: expected extracted or ground_truth"},
      {cameras + "body_model: builtin:horse\n",
       "body_model: unknown built-in model (known: builtin:hand, builtin:human)"},
      {cameras + "scene_empty_seconds: -1\n", "scene_empty_seconds: must be between 0 and 3600"},
      {"cameras:\n  - {driver: v4l2, device: /dev/video0}\nscene_empty_seconds: 2\n",
       "test.yaml:3: scene_empty_seconds: only the fake scene can be empty (cameras[0] is v4l2)"},
      {cameras + "scene_slow_motion: 0.5\n", "scene_slow_motion: must be between 1 and 1000"},
      {"cameras:\n  - {driver: v4l2, device: /dev/video0}\nscene_slow_motion: 4\n",
       "test.yaml:3: scene_slow_motion: only the fake scene plays in slow motion (cameras[0] is "
       "v4l2)"},
      {cameras + "scene_motion: /no/such/walk.bvh\n",
       "test.yaml:3: scene_motion: no such file: /no/such/walk.bvh"},
      {cameras + "body_model: builtin:hand\nscene_motion: " + walk + "\n",
       "body_model: a scene_motion (BVH) drives a human body, not builtin:hand"},
  };
  for (const auto& [yaml, expected] : cases)
    EXPECT_THAT(errorOf(yaml), HasSubstr(expected)) << yaml;
}

// gRPC given a certificate and key it cannot serve only fails to bind; the configuration names
// the file and what is wrong with it instead, and does not wait for a passphrase.
TEST(ConfigTest, ATlsCertificateAndKeyAreCheckedBeforeTheyAreServed) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("mocap_config_tls_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const test::TlsFiles good = test::writeSelfSignedCertificate(dir, "good");
  const test::TlsFiles other = test::writeSelfSignedCertificate(dir, "other");
  const test::TlsFiles expired = test::writeSelfSignedCertificate(dir, "expired", -3, -1);
  const test::TlsFiles future = test::writeSelfSignedCertificate(dir, "future", 1, 3);
  const test::TlsFiles locked = test::writeSelfSignedCertificate(dir, "locked", -1, 2, "secret");
  const std::string not_pem = (dir / "notes.txt").string();
  std::ofstream(not_pem) << "not a certificate\n";
  const std::string cameras = "cameras:\n  - {driver: fake, width: 780, height: 580}\n";
  auto tls = [&](const std::string& cert, const std::string& key) {
    return cameras + "tls:\n  cert: " + cert + "\n  key: " + key + "\n";
  };

  const ServerConfig config = parseConfig(tls(good.cert, good.key), "test.yaml", ".");
  EXPECT_EQ(config.tls_cert_file, good.cert);
  EXPECT_EQ(config.tls_key_file, good.key);
  // (certificate, key, what the error must say)
  const std::tuple<std::string, std::string, std::string> cases[] = {
      {not_pem, good.key, "test.yaml:4: tls.cert: no PEM certificate in " + not_pem},
      {good.key, good.key, "tls.cert: no PEM certificate in " + good.key},
      {good.cert, not_pem, "test.yaml:5: tls.key: no PEM private key in " + not_pem},
      {good.cert, good.cert, "tls.key: no PEM private key in " + good.cert},
      {good.cert, locked.key,
       "tls.key: " + locked.key + " is encrypted, and the daemon cannot ask for its passphrase"},
      {good.cert, other.key,
       "tls.key: " + other.key + " is not the key of the certificate " + good.cert},
      {expired.cert, expired.key, "tls.cert: " + expired.cert + " expired on "},
      {future.cert, future.key, "tls.cert: " + future.cert + " is not valid before "},
  };
  for (const auto& [cert, key, expected] : cases)
    EXPECT_THAT(errorOf(tls(cert, key)), HasSubstr(expected)) << cert << " " << key;
  // The authority clients' certificates must come from (mutual TLS): a PEM certificate.
  EXPECT_TRUE(config.tls_client_ca_file.empty());
  EXPECT_EQ(
      parseConfig(tls(good.cert, good.key) + "  client_ca: " + other.cert + "\n", "test.yaml", ".")
          .tls_client_ca_file,
      other.cert);
  EXPECT_THAT(errorOf(tls(good.cert, good.key) + "  client_ca: " + not_pem + "\n"),
              HasSubstr("test.yaml:6: tls.client_ca: no PEM certificate in " + not_pem));
  std::filesystem::remove_all(dir);
}

// A scene_motion's subject can first stand in the body's fit pose, and the tracker can be made
// to track the configured body rather than the subject's; both keys need a scene_motion.
TEST(ConfigTest, TheFitPoseSecondsAndTheTrackedBodyOfASceneMotion) {
  const std::string cameras = "cameras:\n  - {driver: fake, width: 780, height: 580}\n";
  const std::string walk = MOCAP_SHARED_DIR "/data/motion/cmu_131_01_walk.bvh";
  const ServerConfig plain = parseConfig(cameras + "scene_motion: " + walk + "\n", "t.yaml", ".");
  EXPECT_EQ(plain.scene_fit_pose_seconds, 0);
  EXPECT_TRUE(plain.track_subject_body);
  const ServerConfig fitting = parseConfig(cameras + "scene_motion: " + walk +
                                               "\nscene_fit_pose_seconds: 4.5\n"
                                               "track_subject_body: false\n",
                                           "t.yaml", ".");
  EXPECT_EQ(fitting.scene_fit_pose_seconds, 4.5);
  EXPECT_FALSE(fitting.track_subject_body);

  // A body model file without a fit pose has nothing to stand in.
  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / "config_fit_pose";
  std::filesystem::create_directories(dir);
  {
    std::ifstream in(MOCAP_SOURCE_DIR "/tracker/models/human.yaml");
    std::ofstream out(dir / "no_fit_pose.yaml");
    for (std::string line; std::getline(in, line);)
      if (line.rfind("fit_pose:", 0) != 0) out << line << "\n";
  }
  const std::string no_fit_pose = (dir / "no_fit_pose.yaml").string();
  const std::pair<std::string, std::string> cases[] = {
      {cameras + "scene_fit_pose_seconds: 3\n",
       "test.yaml:3: scene_fit_pose_seconds: needs a scene_motion (the fake scene playing a "
       "recorded subject)"},
      {cameras + "track_subject_body: false\n",
       "test.yaml:3: track_subject_body: needs a scene_motion"},
      {cameras + "scene_motion: " + walk + "\nscene_fit_pose_seconds: -2\n",
       "test.yaml:4: scene_fit_pose_seconds: must be between 0 and 3600, got -2"},
      {cameras + "scene_motion: " + walk + "\nscene_fit_pose_seconds: soon\n",
       "test.yaml:4: scene_fit_pose_seconds: expected a number, got 'soon'"},
      {cameras + "scene_motion: " + walk + "\ntrack_subject_body: perhaps\n",
       "test.yaml:4: track_subject_body: expected true or false, got 'perhaps'"},
      {cameras + "body_model: " + no_fit_pose + "\nscene_motion: " + walk +
           "\nscene_fit_pose_seconds: 3\n",
       "test.yaml:5: scene_fit_pose_seconds: the body model 'human' (" + no_fit_pose +
           ") has no fit_pose to stand in"},
  };
  for (const auto& [yaml, expected] : cases)
    EXPECT_THAT(errorOf(yaml), HasSubstr(expected)) << yaml;
}

// A scene_motion can be shown as a simulated person (scene_subject_seed) and read in a given
// length unit with a joint map (scene_motion_units, scene_motion_joint_map); all three need a
// scene_motion, and a bad value is refused naming its key.
TEST(ConfigTest, TheSceneSubjectAndHowTheSceneMotionIsRead) {
  const std::string cameras = "cameras:\n  - {driver: fake, width: 780, height: 580}\n";
  const std::string walk = MOCAP_SHARED_DIR "/data/motion/cmu_131_01_walk.bvh";
  const std::string map = MOCAP_SOURCE_DIR "/tracker/models/joint_maps/cgspeed.yaml";
  const ServerConfig plain = parseConfig(cameras + "scene_motion: " + walk + "\n", "t.yaml", ".");
  EXPECT_FALSE(plain.scene_subject_seed);
  EXPECT_EQ(plain.scene_motion_load.units, BvhUnits::kAuto);
  EXPECT_TRUE(plain.scene_motion_load.joint_map.empty());
  const ServerConfig product = parseConfig(cameras + "scene_motion: " + walk +
                                               "\nscene_subject_seed: 12\nscene_motion_units: cmu\n"
                                               "scene_motion_joint_map: " +
                                               map + "\n",
                                           "t.yaml", ".");
  ASSERT_TRUE(product.scene_subject_seed);
  EXPECT_EQ(*product.scene_subject_seed, 12u);
  EXPECT_EQ(product.scene_motion_load.units, BvhUnits::kCmu);
  EXPECT_EQ(product.scene_motion_load.joint_map, map);

  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / "config_subject";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "bad_map.yaml") << "joints: [1, 2\n";
  const std::string bad_map = (dir / "bad_map.yaml").string();
  const std::string motion = cameras + "scene_motion: " + walk + "\n";
  const std::pair<std::string, std::string> cases[] = {
      {cameras + "scene_subject_seed: 3\n",
       "test.yaml:3: scene_subject_seed: needs a scene_motion (the fake scene playing a recorded "
       "subject)"},
      {cameras + "scene_motion_units: cm\n",
       "test.yaml:3: scene_motion_units: needs a scene_motion"},
      {cameras + "scene_motion_joint_map: " + map + "\n",
       "test.yaml:3: scene_motion_joint_map: needs a scene_motion"},
      {motion + "scene_subject_seed: -1\n", "test.yaml:4: scene_subject_seed: must be between 0"},
      {motion + "scene_subject_seed: 2.5\n",
       "test.yaml:4: scene_subject_seed: expected a whole number, got 2.5"},
      {motion + "scene_subject_seed: anyone\n",
       "test.yaml:4: scene_subject_seed: expected a number, got 'anyone'"},
      {motion + "scene_motion_units: furlongs\n",
       "test.yaml:4: scene_motion_units: BVH units: expected one of"},
      {motion + "scene_motion_joint_map: /no/such/map.yaml\n",
       "test.yaml:4: scene_motion_joint_map: no such file: /no/such/map.yaml"},
      {motion + "scene_motion_joint_map: " + bad_map + "\n",
       "test.yaml:4: scene_motion_joint_map: " + bad_map},
  };
  for (const auto& [yaml, expected] : cases)
    EXPECT_THAT(errorOf(yaml), HasSubstr(expected)) << yaml;
}

TEST(ConfigTest, SilhouetteSourceAndBackgroundDirectory) {
  const std::string cameras = "cameras:\n  - {driver: fake, width: 780, height: 580}\n";
  EXPECT_EQ(
      parseConfig(cameras + "scene_empty_seconds: 2.5\n", "test.yaml", ".").scene_empty_seconds,
      2.5);
  EXPECT_EQ(parseConfig(cameras + "scene_slow_motion: 4\n", "test.yaml", ".").scene_slow_motion, 4);
  EXPECT_EQ(parseConfig(cameras, "test.yaml", ".").scene_slow_motion, 1);
  EXPECT_TRUE(parseConfig(cameras, "test.yaml", ".").true_silhouettes);
  EXPECT_TRUE(
      parseConfig(cameras + "silhouettes: ground_truth\n", "test.yaml", ".").true_silhouettes);
  // Relative to the configuration's directory, like every path in it.
  const std::filesystem::path base = std::filesystem::temp_directory_path();
  const ServerConfig extracted = parseConfig(
      cameras + "silhouettes: extracted\nbackground_directory: .\n", "test.yaml", base.string());
  EXPECT_FALSE(extracted.true_silhouettes);
  EXPECT_EQ(extracted.background_directory, std::filesystem::canonical(base).string());
  // Until a background exists: nothing to track by default, thresholded images if asked.
  EXPECT_FALSE(extracted.threshold_before_background);
  EXPECT_TRUE(parseConfig(cameras + "before_background: threshold\n", "test.yaml", ".")
                  .threshold_before_background);
  EXPECT_FALSE(parseConfig(cameras + "before_background: wait\n", "test.yaml", ".")
                   .threshold_before_background);
  EXPECT_THAT(errorOf(cameras + "before_background: guess\n"),
              HasSubstr("test.yaml:3: before_background: expected wait or threshold, got 'guess'"));
}

TEST(ConfigTest, HowSessionsAreRecorded) {
  const std::string cameras = "cameras:\n  - {driver: fake, width: 780, height: 580}\n";
  const RecordingSettings defaults = parseConfig(cameras, "test.yaml", ".").recording;
  EXPECT_EQ(defaults.images, ImageMode::kLossless);
  EXPECT_EQ(defaults.jpeg_quality, 90);
  EXPECT_EQ(defaults.min_free_mb, 512);
  const RecordingSettings set =
      parseConfig(cameras + "recording: {images: compressed, jpeg_quality: 75, min_free_mb: 0}\n",
                  "test.yaml", ".")
          .recording;
  EXPECT_EQ(set.images, ImageMode::kCompressed);
  EXPECT_EQ(set.jpeg_quality, 75);
  EXPECT_EQ(set.min_free_mb, 0);
  EXPECT_EQ(parseConfig(cameras + "recording: {images: none}\n", "test.yaml", ".").recording.images,
            ImageMode::kNone);
  EXPECT_THAT(errorOf(cameras + "recording: {images: video}\n"),
              HasSubstr("test.yaml:3: recording.images: expected lossless, compressed or none, "
                        "got 'video'"));
  EXPECT_THAT(errorOf(cameras + "recording: {jpeg_quality: 101}\n"),
              HasSubstr("recording.jpeg_quality: must be between 1 and 100"));
  EXPECT_THAT(errorOf(cameras + "recording: {min_free_mb: -1}\n"),
              HasSubstr("recording.min_free_mb: must be between 0 and"));
  EXPECT_THAT(errorOf(cameras + "recording: {floor: 3}\n"),
              HasSubstr("recording.floor: unknown key"));
}

}  // namespace
}  // namespace mocap
