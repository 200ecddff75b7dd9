// The VMC output: the `vmc:` configuration key; the pure conversion of poses to VMC frames (known
// poses); the real sender to a liblo receiver on loopback, checked against the poses' segment
// orientations converted by the tests' own matrices; and the daemon on the fake scene sending to
// that receiver.
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <functional>
#include <map>
#include <mutex>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lo/lo.h>

#include "server/config.h"
#include "server/mocap_server.h"
#include "server/server_test_support.h"
#include "server/vmc_frame.h"
#include "server/vmc_sender.h"
#include "tracker/model/builtin_models.h"
#include "tracker/model/kinematics.h"

namespace mocap {
namespace {

using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

// ---- The configuration key ----

ServerConfig parseWithVmc(const std::string& vmc) {
  return parseConfig(std::string(kDefaultConfigYaml) + "vmc: " + vmc + "\n", "test.yaml", ".");
}

std::string errorOf(const std::string& vmc) {
  try {
    parseWithVmc(vmc);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(VmcConfigTest, ReadsTheReceivers) {
  EXPECT_TRUE(parseConfig(kDefaultConfigYaml, "test.yaml", ".").vmc.send_to.empty());
  EXPECT_TRUE(parseWithVmc("{send_to: []}").vmc.send_to.empty());
  const ServerConfig config =
      parseWithVmc(R"({send_to: ["127.0.0.1:39539", "avatar.local:39540", "[::1]:39541"]})");
  ASSERT_EQ(config.vmc.send_to.size(), 3u);
  EXPECT_EQ(config.vmc.send_to[0].host, "127.0.0.1");
  EXPECT_EQ(config.vmc.send_to[0].port, 39539);
  EXPECT_EQ(config.vmc.send_to[1].text(), "avatar.local:39540");
  EXPECT_EQ(config.vmc.send_to[2].host, "::1");
  EXPECT_EQ(config.vmc.send_to[2].text(), "[::1]:39541");
}

TEST(VmcConfigTest, RefusesABadEntryNamingIt) {
  EXPECT_EQ(errorOf(R"({send_to: ["127.0.0.1:39539", "127.0.0.1"]})"),
            "test.yaml:7: vmc.send_to[1]: expected host:port, got '127.0.0.1'");
  EXPECT_EQ(errorOf(R"({send_to: [":39539"]})"),
            "test.yaml:7: vmc.send_to[0]: expected host:port, got ':39539'");
  EXPECT_EQ(errorOf(R"({send_to: ["host:port"]})"),
            "test.yaml:7: vmc.send_to[0]: expected host:port, got 'host:port'");
  EXPECT_EQ(errorOf(R"({send_to: ["127.0.0.1:70000"]})"),
            "test.yaml:7: vmc.send_to[0]: the port must be between 1 and 65535, got 70000");
  EXPECT_EQ(errorOf(R"({send_to: ["::1:39539"]})"),
            "test.yaml:7: vmc.send_to[0]: an IPv6 address goes in brackets ([::1]:39539), got "
            "'::1:39539'");
  EXPECT_EQ(errorOf(R"({send_to: "127.0.0.1:39539"})"),
            "test.yaml:7: vmc.send_to: expected a list of host:port, got '127.0.0.1:39539'");
  EXPECT_NE(errorOf(R"({sendto: ["127.0.0.1:39539"]})").find("vmc.sendto: unknown key"),
            std::string::npos);
}

// ---- The conversion, on known poses ----

// The tests' own statement of the conventions (server/vmc_frame.h), as matrices: the tracker's
// world (Z up, the body facing +Y) to Unity's (Y up, +Z forward): x stays, y and z swap.
const Matrix3d kToUnity = (Matrix3d() << 1, 0, 0, 0, 0, 1, 0, 1, 0).finished();

// In the T-pose the right arm points along +X: its zero-pose direction down the arm (-Z) turns to
// +X about the forward axis; the left arm to -X.
Matrix3d tposeOf(const std::string& segment) {
  Matrix3d right;
  right << 0, 0, -1, 0, 1, 0, 1, 0, 0;
  if (segment == "r_upper_arm" || segment == "r_forearm") return right;
  if (segment == "l_upper_arm" || segment == "l_forearm") return right.transpose();
  return Matrix3d::Identity();
}

// Unity's humanoid hierarchy for the bones sent (the bones between, at rest, left out), and the
// body segment each one is.
const std::map<std::string, std::pair<std::string, std::string>> kBones = {
    {"Hips", {"", "pelvis"}},
    {"Spine", {"Hips", "chest"}},
    {"Head", {"Spine", "head"}},
    {"RightUpperLeg", {"Hips", "r_thigh"}},
    {"RightLowerLeg", {"RightUpperLeg", "r_shin"}},
    {"RightFoot", {"RightLowerLeg", "r_foot"}},
    {"LeftUpperLeg", {"Hips", "l_thigh"}},
    {"LeftLowerLeg", {"LeftUpperLeg", "l_shin"}},
    {"LeftFoot", {"LeftLowerLeg", "l_foot"}},
    {"RightUpperArm", {"Spine", "r_upper_arm"}},
    {"RightLowerArm", {"RightUpperArm", "r_forearm"}},
    {"LeftUpperArm", {"Spine", "l_upper_arm"}},
    {"LeftLowerArm", {"LeftUpperArm", "l_forearm"}},
};

double degrees(double d) { return d * M_PI / 180; }

// The angle between two rotations (either sign of a quaternion).
double angleBetween(const Quaterniond& a, const Quaterniond& b) {
  return a.normalized().angularDistance(b.normalized());
}

Pose poseOf(const BodyModel& body, const Eigen::VectorXd& q) {
  KinematicsData data(body);
  forwardKinematics(body, data, q);
  Pose pose;
  pose.dofs = q;
  pose.points = pointPositions(body, data);
  for (const Eigen::Isometry3d& world : data.world)
    pose.orientations.emplace_back(world.rotation());
  return pose;
}

class VmcFrameTest : public ::testing::Test {
 protected:
  // The neutral pose with `dofs` set (degrees).
  Eigen::VectorXd pose(const std::map<std::string, double>& dofs) const {
    Eigen::VectorXd q = body_.neutralPose();
    for (const auto& [name, value] : dofs) q[body_.dofIndex(name)] = degrees(value);
    return q;
  }
  Eigen::VectorXd tpose(std::map<std::string, double> dofs = {}) const {
    dofs.emplace("r_shoulder_abd", 90);
    dofs.emplace("l_shoulder_abd", 90);
    return pose(dofs);
  }
  VmcFrame frameOf(const Eigen::VectorXd& q) const {
    return vmcFrame(rig_, body_, poseOf(body_, q), 1.5);
  }
  static const VmcBonePose& bone(const VmcFrame& frame, const std::string& name) {
    for (const VmcBonePose& bone : frame.bones)
      if (bone.name == name) return bone;
    throw std::out_of_range("no bone " + name);
  }

  const BodyModel body_ = builtinHumanModel();
  const VmcRig rig_ = makeVmcRig(body_);
};

TEST_F(VmcFrameTest, TheTPoseIsTheRestEveryBoneUnrotated) {
  const VmcFrame frame = frameOf(tpose());
  EXPECT_TRUE(frame.tracking);
  EXPECT_EQ(frame.time_s, 1.5);
  ASSERT_EQ(frame.bones.size(), kBones.size());
  for (const VmcBonePose& bone : frame.bones) {
    EXPECT_TRUE(kBones.count(bone.name)) << bone.name;
    EXPECT_LT(angleBetween(bone.rotation, Quaterniond::Identity()), 1e-9) << bone.name;
  }
  EXPECT_EQ(frame.bones[0].name, "Hips");
  // The pelvis stands 0.92 m above the floor: Unity's y.
  EXPECT_TRUE(bone(frame, "Hips").position.isApprox(Vector3d(0, 0.92, 0), 1e-12));
  // T-pose offsets from the parent bone, in Unity's frame: the right side along +x, up along +y.
  EXPECT_TRUE(bone(frame, "Spine").position.isApprox(Vector3d(0, 0.17, 0), 1e-12));
  EXPECT_TRUE(bone(frame, "RightUpperLeg").position.isApprox(Vector3d(0.09, 0, 0), 1e-12));
  EXPECT_TRUE(bone(frame, "RightUpperArm").position.isApprox(Vector3d(0.19, 0.31, 0), 1e-12));
  EXPECT_TRUE(bone(frame, "RightLowerArm").position.isApprox(Vector3d(0.29, 0, 0), 1e-12));
  EXPECT_TRUE(bone(frame, "LeftLowerArm").position.isApprox(Vector3d(-0.29, 0, 0), 1e-12));
}

TEST_F(VmcFrameTest, TheZeroPoseHangsTheUpperArmsDown) {
  const VmcFrame frame = frameOf(pose({}));
  // A quarter turn about Unity's forward axis (z), each arm down: x right, so the right arm by -90
  // degrees, the left by +90.
  const double h = std::sqrt(0.5);
  EXPECT_LT(angleBetween(bone(frame, "RightUpperArm").rotation, Quaterniond(h, 0, 0, -h)), 1e-9);
  EXPECT_LT(angleBetween(bone(frame, "LeftUpperArm").rotation, Quaterniond(h, 0, 0, h)), 1e-9);
  EXPECT_TRUE((bone(frame, "RightUpperArm").rotation * Vector3d::UnitX())
                  .isApprox(-Vector3d::UnitY(), 1e-9));
  // The forearms hang with them: no rotation of their own.
  EXPECT_LT(angleBetween(bone(frame, "RightLowerArm").rotation, Quaterniond::Identity()), 1e-9);
}

TEST_F(VmcFrameTest, AnElbowBentAQuarterTurnTurnsTheForearmForward) {
  const VmcFrame frame = frameOf(tpose({{"r_elbow_flex", 90}}));
  // In Unity's left-handed frame, -90 degrees about y turns the arm's +x to the body's forward +z.
  const double h = std::sqrt(0.5);
  const Quaterniond forearm = bone(frame, "RightLowerArm").rotation;
  EXPECT_LT(angleBetween(forearm, Quaterniond(h, 0, -h, 0)), 1e-9) << forearm.coeffs().transpose();
  EXPECT_TRUE((forearm * Vector3d::UnitX()).isApprox(Vector3d::UnitZ(), 1e-9));
  for (const VmcBonePose& other : frame.bones) {
    if (other.name == "RightLowerArm") continue;
    EXPECT_LT(angleBetween(other.rotation, Quaterniond::Identity()), 1e-9) << other.name;
  }
}

TEST_F(VmcFrameTest, TurningLeftTurnsTheHipsLeftInUnity) {
  // root_yaw +90 degrees about the tracker's up: facing +Y turns to face -X, the body's left.
  const VmcFrame frame = frameOf(tpose({{"root_yaw", 90}}));
  const Quaterniond hips = bone(frame, "Hips").rotation;
  EXPECT_TRUE((hips * Vector3d::UnitZ()).isApprox(-Vector3d::UnitX(), 1e-9));
  EXPECT_TRUE((hips * Vector3d::UnitY()).isApprox(Vector3d::UnitY(), 1e-9));
  EXPECT_LT(angleBetween(bone(frame, "Spine").rotation, Quaterniond::Identity()), 1e-9);
}

TEST_F(VmcFrameTest, LostFramesAndBodiesWithoutAHumanSayNothingOfBones) {
  const VmcFrame lost = vmcLostFrame(2.0);
  EXPECT_FALSE(lost.tracking);
  EXPECT_EQ(lost.time_s, 2.0);
  EXPECT_TRUE(lost.bones.empty());
  EXPECT_TRUE(makeVmcRig(builtinHandModel()).empty());
  EXPECT_THROW(vmcFrame(rig_, body_, Pose(), 0), std::invalid_argument);
}

// ---- The sender, to a liblo receiver on loopback ----

struct Message {
  std::string address;
  std::string name;            // the first argument of Root/Pos and Bone/Pos
  std::vector<double> values;  // the numbers, in order
};
using Bundle = std::vector<Message>;

// A liblo server thread on a port the system picks, collecting whole bundles.
class Receiver {
 public:
  Receiver() : thread_(lo_server_thread_new(nullptr, nullptr)) {
    lo_server_add_bundle_handlers(lo_server_thread_get_server(thread_), &Receiver::bundleStarts,
                                  &Receiver::bundleEnds, this);
    lo_server_thread_add_method(thread_, nullptr, nullptr, &Receiver::onMessage, this);
    lo_server_thread_start(thread_);
  }
  ~Receiver() {
    lo_server_thread_stop(thread_);
    lo_server_thread_free(thread_);
  }
  int port() const { return lo_server_thread_get_port(thread_); }
  VmcTarget target() const { return {"127.0.0.1", port()}; }

  // The bundles received, once `keep` has accepted `count` of them (a failure after 60 s).
  std::vector<Bundle> waitFor(std::size_t count, const std::function<bool(const Bundle&)>& keep) {
    std::unique_lock lock(mutex_);
    const auto kept = [&] {
      std::vector<Bundle> bundles;
      for (const Bundle& bundle : bundles_)
        if (keep(bundle)) bundles.push_back(bundle);
      return bundles;
    };
    const bool enough =
        arrived_.wait_for(lock, std::chrono::seconds(60), [&] { return kept().size() >= count; });
    EXPECT_TRUE(enough) << "received " << bundles_.size() << " bundles";
    return kept();
  }
  std::size_t received() {
    std::lock_guard lock(mutex_);
    return bundles_.size();
  }

 private:
  static int bundleStarts(lo_timetag, void* self) {
    static_cast<Receiver*>(self)->current_.clear();
    return 0;
  }
  static int bundleEnds(void* self) {
    Receiver& receiver = *static_cast<Receiver*>(self);
    std::lock_guard lock(receiver.mutex_);
    receiver.bundles_.push_back(std::move(receiver.current_));
    receiver.arrived_.notify_all();
    return 0;
  }
  static int onMessage(const char* path, const char* types, lo_arg** argv, int argc, lo_message,
                       void* self) {
    Message message{path, "", {}};
    // liblo's arguments are 4-byte aligned and lo_arg (a union with doubles) wants 8: copy the
    // values out rather than read them through the union.
    for (int i = 0; i < argc; ++i) {
      if (types[i] == LO_STRING) message.name = reinterpret_cast<const char*>(argv[i]);
      if (types[i] == LO_FLOAT) {
        float value;
        std::memcpy(&value, argv[i], sizeof value);
        message.values.push_back(value);
      }
      if (types[i] == LO_INT32) {
        int32_t value;
        std::memcpy(&value, argv[i], sizeof value);
        message.values.push_back(value);
      }
    }
    static_cast<Receiver*>(self)->current_.push_back(std::move(message));
    return 0;
  }

  lo_server_thread thread_;
  Bundle current_;  // the receiver's thread only
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::vector<Bundle> bundles_;
};

const Message* findMessage(const Bundle& bundle, const std::string& address,
                           const std::string& name = "") {
  for (const Message& message : bundle)
    if (message.address == address && message.name == name) return &message;
  return nullptr;
}

bool tracking(const Bundle& bundle) {
  const Message* ok = findMessage(bundle, "/VMC/Ext/OK");
  return ok && ok->values == std::vector<double>{1};
}

// A pose within the body's limits, every DOF drawn at random.
Eigen::VectorXd randomPose(const BodyModel& body, std::mt19937& random) {
  Eigen::VectorXd q(body.dofs.size());
  for (std::size_t d = 0; d < body.dofs.size(); ++d) {
    const Dof& dof = body.dofs[d];
    const double span = dof.type == DofType::kTranslation ? 0.5 : degrees(60);
    const double low = std::max(dof.min, -span), high = std::min(dof.max, span);
    q[static_cast<long>(d)] = std::uniform_real_distribution<double>(low, high)(random);
  }
  return q;
}

// Checks one received bundle against the pose it was sent for: composing the bones' local
// rotations down Unity's hierarchy gives, for every bone, its segment's world orientation from the
// T-pose in Unity's frame, kToUnity (R T^-1) kToUnity^-1.
void expectBundleOf(const Bundle& bundle, const BodyModel& body, const Pose& pose) {
  EXPECT_TRUE(tracking(bundle));
  ASSERT_NE(findMessage(bundle, "/VMC/Ext/T"), nullptr);
  const Message* root = findMessage(bundle, "/VMC/Ext/Root/Pos", "root");
  ASSERT_NE(root, nullptr);
  EXPECT_EQ(root->values, (std::vector<double>{0, 0, 0, 0, 0, 0, 1}));
  std::map<std::string, Quaterniond> world;
  for (const auto& [name, parent_and_segment] : kBones) {
    const auto& [parent, segment] = parent_and_segment;
    // Parents first: std::map orders names, so walk up instead.
    std::vector<std::string> chain = {name};
    while (!kBones.at(chain.back()).first.empty()) chain.push_back(kBones.at(chain.back()).first);
    Quaterniond composed = Quaterniond::Identity();
    for (auto bone = chain.rbegin(); bone != chain.rend(); ++bone) {
      const Message* message = findMessage(bundle, "/VMC/Ext/Bone/Pos", *bone);
      ASSERT_NE(message, nullptr) << *bone;
      ASSERT_EQ(message->values.size(), 7u);
      const std::vector<double>& v = message->values;
      composed = composed * Quaterniond(v[6], v[3], v[4], v[5]);
    }
    const int s = body.segmentIndex(segment);
    const Matrix3d expected = kToUnity * pose.orientations[s].toRotationMatrix() *
                              tposeOf(segment).transpose() * kToUnity.transpose();
    EXPECT_LT(angleBetween(composed, Quaterniond(expected)), 1e-5) << name;
    world[name] = composed;
  }
  // The Hips where the pelvis is.
  const std::vector<double>& hips = findMessage(bundle, "/VMC/Ext/Bone/Pos", "Hips")->values;
  const Vector3d pelvis = kToUnity * pose.points[body.pointIndex("pelvis")];
  EXPECT_LT((Vector3d(hips[0], hips[1], hips[2]) - pelvis).norm(), 1e-5);
}

class VmcSenderTest : public ::testing::Test {
 protected:
  std::unique_ptr<VmcSender> startSender(std::vector<VmcTarget> targets) {
    auto sender = std::make_unique<VmcSender>(
        std::move(targets), [this] { return body_; },
        [this](const std::string& message) { warnings_.push_back(message); });
    EXPECT_TRUE(sender->start().ok());
    return sender;
  }

  std::shared_ptr<const BodyModel> body_ = std::make_shared<const BodyModel>(builtinHumanModel());
  std::vector<std::string> warnings_;
  Receiver receiver_;
};

TEST_F(VmcSenderTest, EachPoseArrivesAsOneBundleOfItsBonesInUnitysFrame) {
  std::unique_ptr<VmcSender> sender = startSender({receiver_.target()});
  std::mt19937 random(7);
  for (std::size_t i = 1; i <= 5; ++i) {
    const Pose pose = poseOf(*body_, randomPose(*body_, random));
    sender->offer(std::make_shared<const Pose>(pose));
    const std::vector<Bundle> bundles = receiver_.waitFor(i, tracking);
    ASSERT_EQ(bundles.size(), i);
    expectBundleOf(bundles.back(), *body_, pose);
    // The bones after OK, T and the root.
    EXPECT_EQ(bundles.back().size(), 3 + kBones.size());
  }
  sender->stop();
  EXPECT_TRUE(warnings_.empty());
}

TEST_F(VmcSenderTest, SaysItIsNotTrackingWhileNoPoseComes) {
  std::unique_ptr<VmcSender> sender = startSender({receiver_.target()});
  const std::vector<Bundle> lost =
      receiver_.waitFor(1, [](const Bundle& bundle) { return !tracking(bundle); });
  ASSERT_EQ(lost.size(), 1u);
  const Bundle& bundle = lost.front();
  ASSERT_NE(findMessage(bundle, "/VMC/Ext/OK"), nullptr);
  EXPECT_EQ(findMessage(bundle, "/VMC/Ext/OK")->values, std::vector<double>{0});
  EXPECT_EQ(findMessage(bundle, "/VMC/Ext/Bone/Pos", "Hips"), nullptr);
  ASSERT_NE(findMessage(bundle, "/VMC/Ext/T"), nullptr);
  EXPECT_GT(findMessage(bundle, "/VMC/Ext/T")->values.at(0), 0.5);
}

TEST_F(VmcSenderTest, AReceiverThatIsNotThereTakesNothingFromTheOthers) {
  // Nobody listens on the second one's port (bound, then closed), nor resolves the third's name.
  const int closed_port = [] {
    lo_server server = lo_server_new(nullptr, nullptr);
    const int port = lo_server_get_port(server);
    lo_server_free(server);
    return port;
  }();
  std::unique_ptr<VmcSender> sender = startSender(
      {{"127.0.0.1", closed_port}, receiver_.target(), {"no-such-host.invalid", 39539}});
  ASSERT_EQ(warnings_.size(), 1u);
  EXPECT_NE(warnings_[0].find("no-such-host.invalid:39539"), std::string::npos) << warnings_[0];
  const Pose pose = poseOf(*body_, body_->neutralPose());
  for (int i = 0; i < 3; ++i) {
    sender->offer(std::make_shared<const Pose>(pose));
    receiver_.waitFor(static_cast<std::size_t>(i + 1), tracking);
  }
  EXPECT_EQ(receiver_.waitFor(3, tracking).size(), 3u);
}

TEST(VmcEncodingTest, TheBundleFitsOneDatagram) {
  const BodyModel body = builtinHumanModel();
  const VmcFrame frame = vmcFrame(makeVmcRig(body), body, poseOf(body, body.neutralPose()), 0);
  // Below an Ethernet frame's UDP payload, so a bundle is never fragmented.
  EXPECT_LT(encodeVmcBundle(frame).size(), 1472u);
}

// ---- The daemon ----

TEST(VmcDaemonTest, TheDaemonOnTheFakeWalkSendsItsPoses) {
  Receiver receiver;
  ServerConfig config = test::walkingPersonConfig();
  config.tracker.filter.evaluations_per_frame = 200;  // the poses' quality is not the point
  config.vmc.send_to = {receiver.target()};
  const std::unique_ptr<MocapServer> server = test::startServer(config);
  ASSERT_NE(server, nullptr);
  const std::vector<Bundle> bundles = receiver.waitFor(5, tracking);
  server->shutdown();
  ASSERT_GE(bundles.size(), 5u);
  for (const Bundle& bundle : bundles) {
    EXPECT_EQ(bundle.size(), 3 + kBones.size());
    const Message* hips = findMessage(bundle, "/VMC/Ext/Bone/Pos", "Hips");
    ASSERT_NE(hips, nullptr);
    // Unity's y is up: the pelvis of a person walking.
    EXPECT_GT(hips->values.at(1), 0.6);
    EXPECT_LT(hips->values.at(1), 1.2);
  }
}

}  // namespace
}  // namespace mocap
