// YAML configuration parsing and checking. Unknown keys are refused too: a misspelt key silently
// ignored is a setting the operator believes is in force.
#include "server/config.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <memory>
#include <set>
#include <sstream>

#include <unistd.h>

#include <openssl/pem.h>
#include <openssl/x509.h>
#include <yaml-cpp/yaml.h>

#include "server/config_parser.h"
#include "tracker/model/body_model.h"
#include "tracker/motion/joint_map.h"

namespace mocap {

const char* const kDefaultConfigYaml = R"yaml(
# The fake two-camera scene: a synthetic body rendered into two virtual cameras.
cameras:
  - {driver: fake, device: scene, width: 780, height: 580, fps: 25}
  - {driver: fake, device: scene, width: 780, height: 580, fps: 25}
listen: 127.0.0.1:50051
)yaml";

std::optional<LogLevel> parseLogLevel(const std::string& name) {
  if (name == "debug") return LogLevel::kDebug;
  if (name == "info") return LogLevel::kInfo;
  if (name == "warning" || name == "warn") return LogLevel::kWarning;
  if (name == "error") return LogLevel::kError;
  return std::nullopt;
}

namespace {

using Bio = std::unique_ptr<BIO, decltype(&BIO_free)>;

std::string asnTime(const ASN1_TIME* time) {
  Bio out(BIO_new(BIO_s_mem()), BIO_free);
  ASN1_TIME_print(out.get(), time);
  char* text = nullptr;
  const long length = BIO_get_mem_data(out.get(), &text);
  return std::string(text, static_cast<std::size_t>(length));
}

using X509Ptr = std::unique_ptr<X509, decltype(&X509_free)>;

// The first PEM certificate in `path`, or null. No passphrase prompt: a daemon has no terminal to
// ask on, and must not wait for one.
int noPassphrase(char*, int, int, void*) { return 0; }
X509Ptr readPemCertificate(const std::string& path) {
  Bio file(BIO_new_file(path.c_str(), "r"), BIO_free);
  return X509Ptr(file ? PEM_read_bio_X509(file.get(), nullptr, noPassphrase, nullptr) : nullptr,
                 X509_free);
}

class ConfigParser : public ConfigReader {
 public:
  using ConfigReader::ConfigReader;

  // gRPC, given a certificate and key it cannot serve, only fails to bind, with no word of which
  // file is wrong: they are read here first.
  void checkTlsPair(const YAML::Node& tls, const std::string& cert_path,
                    const std::string& key_path) const {
    const X509Ptr cert = readPemCertificate(cert_path);
    if (!cert) fail(tls["cert"], "tls.cert", "no PEM certificate in " + cert_path);
    Bio key_file(BIO_new_file(key_path.c_str(), "r"), BIO_free);
    std::unique_ptr<EVP_PKEY, decltype(&EVP_PKEY_free)> key(
        key_file ? PEM_read_bio_PrivateKey(key_file.get(), nullptr, noPassphrase, nullptr)
                 : nullptr,
        EVP_PKEY_free);
    if (!key) {
      std::ifstream in(key_path);
      const std::string text((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
      fail(tls["key"], "tls.key",
           text.find("ENCRYPTED") != std::string::npos
               ? key_path +
                     " is encrypted, and the daemon cannot ask for its passphrase (decrypt "
                     "it with openssl pkey, readable by the daemon's user only)"
               : "no PEM private key in " + key_path);
    }
    if (X509_check_private_key(cert.get(), key.get()) != 1)
      fail(tls["key"], "tls.key", key_path + " is not the key of the certificate " + cert_path);
    if (X509_cmp_current_time(X509_get0_notAfter(cert.get())) < 0)
      fail(tls["cert"], "tls.cert",
           cert_path + " expired on " + asnTime(X509_get0_notAfter(cert.get())));
    if (X509_cmp_current_time(X509_get0_notBefore(cert.get())) > 0)
      fail(tls["cert"], "tls.cert",
           cert_path + " is not valid before " + asnTime(X509_get0_notBefore(cert.get())));
  }

  CameraConfig camera(const YAML::Node& node, const std::string& field, int index) const {
    onlyKeys(node, field,
             {"driver", "device", "width", "height", "fps", "pixel_format", "exposure_us",
              "gain_db", "trigger", "trigger_line"});
    CameraConfig c;
    c.index = index;
    if (!node["driver"]) fail(node, field + ".driver", "missing");
    c.driver = text(node["driver"], field + ".driver");
    // "fake" is the daemon's own synthetic scene (mocap_server.cpp), with or without a registered
    // fake driver.
    if (c.driver != "fake" && !DriverRegistry::instance().create(c.driver)) {
      std::string known;
      for (const std::string& name : DriverRegistry::instance().names())
        known += (known.empty() ? "" : ", ") + name;
      fail(node["driver"], field + ".driver",
           "no driver '" + c.driver + "' in this build (compiled in: " + known + ")");
    }
    if (node["device"]) c.device = text(node["device"], field + ".device");
    if (node["width"]) c.width = integer(node["width"], field + ".width", 16, 16384);
    if (node["height"]) c.height = integer(node["height"], field + ".height", 16, 16384);
    if (node["fps"]) c.fps = number(node["fps"], field + ".fps", 0.1, 1000);
    if (node["pixel_format"]) c.pixel_format = text(node["pixel_format"], field + ".pixel_format");
    if (node["exposure_us"])
      c.exposure_us = number(node["exposure_us"], field + ".exposure_us", 1, 10'000'000);
    if (node["gain_db"]) c.gain_db = number(node["gain_db"], field + ".gain_db", -100, 100);
    if (node["trigger"]) {
      const std::string trigger = text(node["trigger"], field + ".trigger");
      if (trigger == "free-run") {
        c.trigger = TriggerMode::kFreeRun;
      } else if (trigger == "software") {
        c.trigger = TriggerMode::kSoftware;
      } else if (trigger == "hardware") {
        c.trigger = TriggerMode::kHardwareLine;
      } else {
        fail(node["trigger"], field + ".trigger",
             "expected free-run, software or hardware, got '" + trigger + "'");
      }
    }
    if (node["trigger_line"]) c.trigger_line = text(node["trigger_line"], field + ".trigger_line");
    if (c.trigger == TriggerMode::kHardwareLine && c.trigger_line.empty())
      fail(node, field + ".trigger_line", "required with trigger: hardware");
    return c;
  }

  // The body model file `path` (not a built-in). Read here, so a bad model file is refused with
  // the configuration, naming the field.
  std::shared_ptr<const BodyModel> bodyFile(const YAML::Node& node, const std::string& path) const {
    try {
      return std::make_shared<const BodyModel>(loadBodyModel(path));
    } catch (const std::exception& e) {
      fail(node, "body_model", e.what());
    }
  }

  // The keys of a `tracker:` map, over the settings in `t`: the daemon's own, then the filter's
  // (their table, tracker/filters/filter_options.h).
  void trackerKeys(const YAML::Node& tracker, TrackerSettings& t) const {
    std::set<std::string> keys = {"method",          "threads",          "dofs",
                                  "start",           "lost_below",       "lost_after",
                                  "challenge_every", "trial_drop_margin"};
    for (const FilterOptionKey& option : filterOptionKeys()) keys.insert(option.key);
    onlyKeys(tracker, "tracker", keys);
    if (tracker["method"]) {
      t.method = text(tracker["method"], "tracker.method");
      if (t.method != "factored" && t.method != "condensation" && t.method != "annealed")
        fail(tracker["method"], "tracker.method",
             "expected factored, condensation or annealed, got '" + t.method + "'");
    }
    if (tracker["threads"]) t.threads = integer(tracker["threads"], "tracker.threads", 1, 256);
    for (const FilterOptionKey& option : filterOptionKeys()) {
      const YAML::Node node = tracker[option.key];
      if (!node) continue;
      const std::string field = std::string("tracker.") + option.key;
      if (!node.IsScalar()) fail(node, field, "expected a single value, got " + kindOf(node));
      try {
        option.set(t.filter, node.Scalar());
      } catch (const std::invalid_argument& e) {
        fail(node, field, e.what());
      }
    }
    if (tracker["dofs"]) {
      t.dofs = text(tracker["dofs"], "tracker.dofs");
      if (t.dofs != "all" && t.dofs != "gait")
        fail(tracker["dofs"], "tracker.dofs", "expected all or gait, got '" + t.dofs + "'");
    }
    if (tracker["start"]) {
      t.start = text(tracker["start"], "tracker.start");
      if (t.start != "auto" && t.start != "acquire" && t.start != "neutral")
        fail(tracker["start"], "tracker.start",
             "expected auto, acquire or neutral, got '" + t.start + "'");
    }
    if (tracker["lost_below"])
      t.lost_below = number(tracker["lost_below"], "tracker.lost_below", 0, 0.99);
    if (tracker["lost_after"])
      t.lost_after = integer(tracker["lost_after"], "tracker.lost_after", 1, 10'000);
    if (tracker["challenge_every"])
      t.challenge_every =
          integer(tracker["challenge_every"], "tracker.challenge_every", 0, 1'000'000);
    if (tracker["trial_drop_margin"])
      t.trial_drop_margin =
          number(tracker["trial_drop_margin"], "tracker.trial_drop_margin", 0, 1e9);
  }

  // `web: {listen: HOST:PORT, enabled: BOOL}`.
  WebSettings web(const YAML::Node& node) const {
    onlyKeys(node, "web", {"listen", "enabled"});
    WebSettings web;
    if (node["enabled"]) web.enabled = boolean(node["enabled"], "web.enabled");
    if (node["listen"]) {
      web.listen = text(node["listen"], "web.listen");
      if (web.listen.rfind(':') == std::string::npos)
        fail(node["listen"], "web.listen", "expected host:port, got '" + web.listen + "'");
    }
    return web;
  }

  // `recording: {images: lossless|compressed|none, jpeg_quality: N, min_free_mb: N}`.
  RecordingSettings recording(const YAML::Node& node) const {
    onlyKeys(node, "recording", {"images", "jpeg_quality", "min_free_mb"});
    RecordingSettings recording;
    if (node["images"]) {
      const std::string images = text(node["images"], "recording.images");
      const std::optional<ImageMode> mode = parseImageMode(images);
      if (!mode)
        fail(node["images"], "recording.images",
             "expected lossless, compressed or none, got '" + images + "'");
      recording.images = *mode;
    }
    if (node["jpeg_quality"])
      recording.jpeg_quality = integer(node["jpeg_quality"], "recording.jpeg_quality", 1, 100);
    if (node["min_free_mb"])
      recording.min_free_mb = integer(node["min_free_mb"], "recording.min_free_mb", 0, 100'000'000);
    return recording;
  }

  // `vmc: {send_to: [HOST:PORT, ...]}`. Not resolved here: a receiver's name may resolve only once
  // the network is up.
  VmcSettings vmc(const YAML::Node& node) const {
    onlyKeys(node, "vmc", {"send_to"});
    VmcSettings vmc;
    const YAML::Node list = node["send_to"];
    if (!list || list.IsNull()) return vmc;
    if (!list.IsSequence())
      fail(list, "vmc.send_to", "expected a list of host:port, got " + kindOf(list));
    for (std::size_t i = 0; i < list.size(); ++i)
      vmc.send_to.push_back(vmcTarget(list[i], "vmc.send_to[" + std::to_string(i) + "]"));
    return vmc;
  }

  // One receiver: HOST:PORT, an IPv6 address in brackets ([::1]:39539).
  VmcTarget vmcTarget(const YAML::Node& node, const std::string& field) const {
    const std::string entry = text(node, field);
    const std::size_t colon = entry.rfind(':');
    if (colon == std::string::npos) fail(node, field, "expected host:port, got '" + entry + "'");
    VmcTarget target;
    target.host = entry.substr(0, colon);
    const bool bracketed =
        target.host.size() > 2 && target.host.front() == '[' && target.host.back() == ']';
    if (bracketed) target.host = target.host.substr(1, target.host.size() - 2);
    if (!bracketed && target.host.find(':') != std::string::npos)
      fail(node, field, "an IPv6 address goes in brackets ([::1]:39539), got '" + entry + "'");
    const std::string port = entry.substr(colon + 1);
    if (target.host.empty() || target.host.find_first_of("[] ") != std::string::npos ||
        port.empty() || port.size() > 5 ||
        port.find_first_not_of("0123456789") != std::string::npos)
      fail(node, field, "expected host:port, got '" + entry + "'");
    target.port = std::stoi(port);
    if (target.port < 1 || target.port > 65535)
      fail(node, field, "the port must be between 1 and 65535, got " + port);
    return target;
  }

  // scene_subject_seed, scene_motion_units, scene_motion_joint_map: with a scene_motion only.
  void sceneSubjectKeys(const YAML::Node& root, ServerConfig& config) const {
    for (const char* key : {"scene_subject_seed", "scene_motion_units", "scene_motion_joint_map"})
      if (root[key] && config.scene_motion.empty())
        fail(root[key], key, "needs a scene_motion (the fake scene playing a recorded subject)");
    if (const YAML::Node seed = root["scene_subject_seed"]) {
      // Seeds are whole numbers up to 2^53, which a YAML number holds exactly.
      const double value = number(seed, "scene_subject_seed", 0, 9007199254740992.0);
      if (value != std::floor(value))
        fail(seed, "scene_subject_seed", "expected a whole number, got " + seed.Scalar());
      config.scene_subject_seed = static_cast<uint64_t>(value);
    }
    if (const YAML::Node units = root["scene_motion_units"]) {
      try {
        config.scene_motion_load.units = parseBvhUnits(text(units, "scene_motion_units"));
      } catch (const std::invalid_argument& e) {
        fail(units, "scene_motion_units", e.what());
      }
    }
    if (const YAML::Node map = root["scene_motion_joint_map"]) {
      config.scene_motion_load.joint_map = existingFile(map, "scene_motion_joint_map");
      try {
        loadJointMap(config.scene_motion_load.joint_map);  // checked against the skeleton later
      } catch (const std::exception& e) {
        fail(map, "scene_motion_joint_map", e.what());
      }
    }
  }

  // `cameras`: at least one, all at the first one's rate.
  void cameraKeys(const YAML::Node& root, ServerConfig& config) const {
    const YAML::Node cameras = root["cameras"];
    if (!cameras) fail(root, "cameras", "missing (at least one camera is needed)");
    if (!cameras.IsSequence() || cameras.size() == 0)
      fail(cameras, "cameras", "expected a non-empty list of cameras");
    for (std::size_t i = 0; i < cameras.size(); ++i) {
      config.cameras.push_back(
          camera(cameras[i], "cameras[" + std::to_string(i) + "]", static_cast<int>(i)));
    }
    for (std::size_t i = 1; i < config.cameras.size(); ++i) {
      if (config.cameras[i].fps != config.cameras[0].fps)
        fail(cameras[i]["fps"], "cameras[" + std::to_string(i) + "].fps",
             "every camera of the rig must run at the same rate as cameras[0]");
    }
  }

  // What is tracked and what the fake scene plays: calibration, body_model, scene_*.
  void sceneKeys(const YAML::Node& root, ServerConfig& config) const {
    if (root["calibration"])
      config.calibration_file = existingFile(root["calibration"], "calibration");
    if (root["body_model"]) {
      const std::string model = text(root["body_model"], "body_model");
      config.body_model =
          model.rfind("builtin:", 0) == 0 ? model : existingFile(root["body_model"], "body_model");
      if (model.rfind("builtin:", 0) == 0 && model != "builtin:hand" && model != "builtin:human")
        fail(root["body_model"], "body_model",
             "unknown built-in model (known: builtin:hand, builtin:human)");
      if (model.rfind("builtin:", 0) != 0)
        config.body_model_file = bodyFile(root["body_model"], config.body_model);
    }
    if (root["scene_motion"]) {
      config.scene_motion = existingFile(root["scene_motion"], "scene_motion");
      for (const CameraConfig& camera : config.cameras)
        if (camera.driver != "fake")
          fail(root["scene_motion"], "scene_motion",
               "only the fake scene plays a motion (cameras[" + std::to_string(camera.index) +
                   "] is " + camera.driver + ")");
      if (config.body_model == "builtin:hand")
        fail(root["body_model"], "body_model",
             "a scene_motion (BVH) drives a human body, not builtin:hand");
    }

    if (const YAML::Node empty = root["scene_empty_seconds"]) {
      config.scene_empty_seconds = number(empty, "scene_empty_seconds", 0, 3600);
      for (const CameraConfig& camera : config.cameras)
        if (camera.driver != "fake")
          fail(empty, "scene_empty_seconds",
               "only the fake scene can be empty (cameras[" + std::to_string(camera.index) +
                   "] is " + camera.driver + ")");
    }

    if (const YAML::Node slow = root["scene_slow_motion"]) {
      config.scene_slow_motion = number(slow, "scene_slow_motion", 1, 1000);
      for (const CameraConfig& camera : config.cameras)
        if (camera.driver != "fake")
          fail(slow, "scene_slow_motion",
               "only the fake scene plays in slow motion (cameras[" +
                   std::to_string(camera.index) + "] is " + camera.driver + ")");
    }

    // Only a played motion has a subject whose body was fitted, and a first pose to stand in.
    const auto needsMotion = [&](const char* key) {
      const YAML::Node node = root[key];
      if (node && config.scene_motion.empty())
        fail(node, key, "needs a scene_motion (the fake scene playing a recorded subject)");
      return node;
    };
    if (const YAML::Node seconds = needsMotion("scene_fit_pose_seconds")) {
      config.scene_fit_pose_seconds = number(seconds, "scene_fit_pose_seconds", 0, 3600);
      if (config.body_model_file && !config.body_model_file->fit_pose)
        fail(seconds, "scene_fit_pose_seconds",
             "the body model '" + config.body_model_file->name + "' (" + config.body_model +
                 ") has no fit_pose to stand in");
    }
    if (const YAML::Node track = needsMotion("track_subject_body"))
      config.track_subject_body = boolean(track, "track_subject_body");
    sceneSubjectKeys(root, config);
  }

  // recording_directory and background_directory: existing, and writable where written.
  void directoryKeys(const YAML::Node& root, ServerConfig& config) const {
    if (root["recording_directory"]) {
      const YAML::Node node = root["recording_directory"];
      const std::filesystem::path dir = resolve(text(node, "recording_directory"));
      std::error_code error;
      if (!std::filesystem::is_directory(dir, error))
        fail(node, "recording_directory", "not an existing directory: " + dir.string());
      config.recording_directory = std::filesystem::canonical(dir, error).string();
    }

    if (root["background_directory"]) {
      const YAML::Node node = root["background_directory"];
      const std::filesystem::path dir = resolve(text(node, "background_directory"));
      std::error_code error;
      if (!std::filesystem::is_directory(dir, error))
        fail(node, "background_directory", "not an existing directory: " + dir.string());
      // Found now rather than when the first capture cannot be saved.
      if (::access(dir.c_str(), W_OK | X_OK) != 0)
        fail(node, "background_directory", "not writable by the daemon: " + dir.string());
      config.background_directory = std::filesystem::canonical(dir, error).string();
    }
  }

  // Where silhouettes come from: silhouettes, before_background.
  void silhouetteKeys(const YAML::Node& root, ServerConfig& config) const {
    if (root["silhouettes"]) {
      const YAML::Node node = root["silhouettes"];
      const std::string source = text(node, "silhouettes");
      if (source == "extracted") {
        config.true_silhouettes = false;
      } else if (source == "ground_truth") {
        for (const CameraConfig& camera : config.cameras)
          if (camera.driver != "fake")
            fail(node, "silhouettes", "ground_truth needs the fake scene: only it knows the truth");
      } else {
        fail(node, "silhouettes", "expected extracted or ground_truth, got '" + source + "'");
      }
    }

    if (const YAML::Node node = root["before_background"]) {
      const std::string choice = text(node, "before_background");
      if (choice != "wait" && choice != "threshold")
        fail(node, "before_background", "expected wait or threshold, got '" + choice + "'");
      config.threshold_before_background = choice == "threshold";
    }
  }

  // tls and auth.
  void securityKeys(const YAML::Node& root, ServerConfig& config) const {
    if (const YAML::Node tls = root["tls"]) {
      onlyKeys(tls, "tls", {"cert", "key", "client_ca"});
      if (!tls["cert"] || !tls["key"]) fail(tls, "tls", "needs both 'cert' and 'key'");
      config.tls_cert_file = existingFile(tls["cert"], "tls.cert");
      config.tls_key_file = existingFile(tls["key"], "tls.key");
      checkTlsPair(tls, config.tls_cert_file, config.tls_key_file);
      if (tls["client_ca"]) {
        config.tls_client_ca_file = existingFile(tls["client_ca"], "tls.client_ca");
        if (!readPemCertificate(config.tls_client_ca_file))
          fail(tls["client_ca"], "tls.client_ca",
               "no PEM certificate in " + config.tls_client_ca_file);
      }
    }

    if (const YAML::Node auth = root["auth"]) {
      onlyKeys(auth, "auth", {"token", "token_file"});
      if (auth["token"] && auth["token_file"])
        fail(auth, "auth", "give either 'token' or 'token_file', not both");
      if (auth["token"]) config.bearer_token = text(auth["token"], "auth.token");
      if (auth["token_file"]) {
        std::ifstream in(existingFile(auth["token_file"], "auth.token_file"));
        std::getline(in, config.bearer_token);
        if (config.bearer_token.empty())
          fail(auth["token_file"], "auth.token_file", "the file's first line is empty");
      }
      if (config.bearer_token.size() < 16)
        fail(auth, "auth", "the token must be at least 16 characters");
    }
  }

  ServerConfig parse(const YAML::Node& root) const {
    ServerConfig config;
    config.source = source();
    onlyKeys(root, "",
             {"cameras",
              "calibration",
              "body_model",
              "tracker",
              "sync",
              "listen",
              "web",
              "vmc",
              "recording_directory",
              "recording",
              "background_directory",
              "silhouettes",
              "before_background",
              "tls",
              "auth",
              "log_level",
              "scene_motion",
              "scene_empty_seconds",
              "scene_slow_motion",
              "scene_fit_pose_seconds",
              "track_subject_body",
              "scene_subject_seed",
              "scene_motion_units",
              "scene_motion_joint_map"});

    cameraKeys(root, config);
    sceneKeys(root, config);

    if (config.body_model == "builtin:human" || !config.scene_motion.empty() ||
        (config.body_model_file && config.body_model_file->person))
      config.tracker = TrackerSettings::forPeople();
    if (const YAML::Node tracker = root["tracker"]) {
      trackerKeys(tracker, config.tracker);
      for (const auto& entry : tracker)
        config.tracker_keys.emplace_back(entry.first.Scalar(), entry.second.Scalar());
    }

    if (const YAML::Node sync = root["sync"]) {
      onlyKeys(sync, "sync", {"tolerance_ms", "deadline_ms"});
      if (sync["tolerance_ms"])
        config.sync.tolerance_ms = number(sync["tolerance_ms"], "sync.tolerance_ms", 0.01, 10'000);
      if (sync["deadline_ms"])
        config.sync.deadline_ms = number(sync["deadline_ms"], "sync.deadline_ms", 0.01, 60'000);
    }

    if (root["listen"]) {
      config.listen = text(root["listen"], "listen");
      if (config.listen.rfind(':') == std::string::npos)
        fail(root["listen"], "listen", "expected host:port, got '" + config.listen + "'");
    }

    directoryKeys(root, config);
    silhouetteKeys(root, config);
    securityKeys(root, config);
    if (root["web"]) config.web = web(root["web"]);
    if (root["recording"]) config.recording = recording(root["recording"]);
    if (root["vmc"]) config.vmc = vmc(root["vmc"]);

    if (root["log_level"]) {
      const std::string level = text(root["log_level"], "log_level");
      const std::optional<LogLevel> parsed = parseLogLevel(level);
      if (!parsed)
        fail(root["log_level"], "log_level",
             "expected debug, info, warning or error, got '" + level + "'");
      config.log_level = *parsed;
    }
    return config;
  }
};

}  // namespace

TrackerSettings TrackerSettings::forPeople() {
  TrackerSettings people;
  people.filter = humanFilterDefaults();
  people.filter.evaluations_per_frame = kHumanEvaluations;
  return people;
}

std::vector<std::pair<std::string, std::string>> TrackerSettings::keyValues() const {
  std::vector<std::pair<std::string, std::string>> keys = {{"method", method}};
  for (const FilterOptionKey& option : filterOptionKeys())
    keys.emplace_back(option.key, option.get(filter));
  keys.insert(keys.end(), {{"dofs", dofs},
                           {"start", start},
                           {"lost_below", shortestText(lost_below)},
                           {"lost_after", std::to_string(lost_after)},
                           {"challenge_every", std::to_string(challenge_every)},
                           {"trial_drop_margin", shortestText(trial_drop_margin)}});
  return keys;
}

TrackerSettings replayTrackerSettings(
    const ServerConfig& config, const std::vector<std::pair<std::string, std::string>>& stored,
    const std::string& source) {
  const auto asMap = [](const std::vector<std::pair<std::string, std::string>>& keys) {
    YAML::Node map(YAML::NodeType::Map);
    for (const auto& [key, value] : keys) map[key] = value;
    return map;
  };
  TrackerSettings settings;
  ConfigParser(source, {}).trackerKeys(asMap(stored), settings);
  settings.threads = config.tracker.threads;
  ConfigParser(config.source, {}).trackerKeys(asMap(config.tracker_keys), settings);
  return settings;
}

ServerConfig parseConfig(const std::string& yaml_text, const std::string& source,
                         const std::string& base_directory) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(source + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  if (!root.IsDefined() || root.IsNull()) throw ConfigError(source + ": the file is empty");
  return ConfigParser(source, base_directory).parse(root);
}

ServerConfig loadConfigFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the configuration file");
  std::stringstream text;
  text << in.rdbuf();
  const std::filesystem::path base = std::filesystem::absolute(path).parent_path();
  return parseConfig(text.str(), path, base.string());
}

}  // namespace mocap
