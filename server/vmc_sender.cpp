// The VMC sender: OSC bundles encoded with liblo, sent on non-blocking UDP sockets from the
// sender's own thread.
#include "server/vmc_sender.h"

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include <lo/lo.h>
#include <netdb.h>
#include <unistd.h>

namespace mocap {
namespace {

void addVector(lo_message message, const Eigen::Vector3d& v) {
  for (int i = 0; i < 3; ++i) lo_message_add_float(message, static_cast<float>(v[i]));
}

void addRotation(lo_message message, const Eigen::Quaterniond& q) {
  for (const double c : {q.x(), q.y(), q.z(), q.w()})
    lo_message_add_float(message, static_cast<float>(c));
}

lo_message transformMessage(const std::string& name, const Eigen::Vector3d& position,
                            const Eigen::Quaterniond& rotation) {
  lo_message message = lo_message_new();
  lo_message_add_string(message, name.c_str());
  addVector(message, position);
  addRotation(message, rotation);
  return message;
}

int openSocket(int family) {
  return ::socket(family, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
}

}  // namespace

std::vector<uint8_t> encodeVmcBundle(const VmcFrame& frame) {
  lo_bundle bundle = lo_bundle_new(LO_TT_IMMEDIATE);
  lo_message ok = lo_message_new();
  lo_message_add_int32(ok, frame.tracking ? 1 : 0);
  lo_bundle_add_message(bundle, "/VMC/Ext/OK", ok);
  lo_message time = lo_message_new();
  lo_message_add_float(time, static_cast<float>(frame.time_s));
  lo_bundle_add_message(bundle, "/VMC/Ext/T", time);
  lo_bundle_add_message(bundle, "/VMC/Ext/Root/Pos",
                        transformMessage("root", frame.root_position, frame.root_rotation));
  for (const VmcBonePose& bone : frame.bones)
    lo_bundle_add_message(bundle, "/VMC/Ext/Bone/Pos",
                          transformMessage(bone.name, bone.position, bone.rotation));
  std::size_t length = lo_bundle_length(bundle);
  std::vector<uint8_t> bytes(length);
  lo_bundle_serialise(bundle, bytes.data(), &length);
  lo_bundle_free_recursive(bundle);  // and its messages
  bytes.resize(length);
  return bytes;
}

VmcSender::VmcSender(std::vector<VmcTarget> targets, TrackedBody tracked_body, Warn warn)
    : targets_(std::move(targets)),
      tracked_body_(std::move(tracked_body)),
      warn_(std::move(warn)) {}

VmcSender::~VmcSender() { stop(); }

Status VmcSender::start() {
  start_ = std::chrono::steady_clock::now();
  for (const VmcTarget& target : targets_) {
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_DGRAM;
    hints.ai_flags = AI_NUMERICSERV;
    addrinfo* found = nullptr;
    const std::string port = std::to_string(target.port);
    if (const int error = ::getaddrinfo(target.host.c_str(), port.c_str(), &hints, &found)) {
      warn_("vmc.send_to: " + target.text() + ": " + ::gai_strerror(error) + "; not sent to");
      continue;
    }
    int& socket = found->ai_family == AF_INET6 ? socket_v6_ : socket_v4_;
    if (socket < 0) socket = openSocket(found->ai_family);
    if (socket >= 0) {
      Receiver receiver;
      receiver.name = target.text();
      std::memcpy(&receiver.address, found->ai_addr, found->ai_addrlen);
      receiver.length = found->ai_addrlen;
      receiver.socket = socket;
      receivers_.push_back(std::move(receiver));
    } else {
      warn_("vmc.send_to: " + target.text() + ": no UDP socket: " + std::strerror(errno));
    }
    ::freeaddrinfo(found);
  }
  if (receivers_.empty()) return Status::Error("vmc.send_to: no receiver to send to");
  thread_ = std::thread([this] { run(); });
  return Status::Ok();
}

void VmcSender::stop() {
  poses_.close();
  if (thread_.joinable()) thread_.join();
  for (int* socket : {&socket_v4_, &socket_v6_}) {
    if (*socket >= 0) ::close(*socket);
    *socket = -1;
  }
}

void VmcSender::offer(const SharedPose& pose) { poses_.push(pose); }

void VmcSender::finish() { poses_.close(); }

double VmcSender::secondsSinceStart() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void VmcSender::run() {
  while (true) {
    const std::optional<SharedPose> pose = poses_.pop(kLostAfter);
    if (pose) {
      send(frameOf(**pose));
    } else if (poses_.closed()) {
      break;
    } else {
      send(vmcLostFrame(secondsSinceStart()));
    }
  }
}

VmcFrame VmcSender::frameOf(const Pose& pose) {
  if (!body_ || pose.body_version != body_version_) {
    body_ = tracked_body_();
    body_version_ = pose.body_version;
    rig_ = body_ ? makeVmcRig(*body_) : VmcRig();
  }
  // The body tracked now: after a switch, possibly a newer one than the pose's, which differs only
  // in proportions (the next pose is of it).
  try {
    if (body_) return vmcFrame(rig_, *body_, pose, secondsSinceStart());
  } catch (const std::invalid_argument&) {
  }
  return vmcLostFrame(secondsSinceStart());
}

void VmcSender::send(const VmcFrame& frame) {
  const std::vector<uint8_t> bundle = encodeVmcBundle(frame);
  for (Receiver& receiver : receivers_) {
    const ssize_t sent =
        ::sendto(receiver.socket, bundle.data(), bundle.size(), MSG_DONTWAIT | MSG_NOSIGNAL,
                 reinterpret_cast<const sockaddr*>(&receiver.address), receiver.length);
    if (sent >= 0) {
      receiver.failing = false;
      continue;
    }
    // A full socket buffer drops this bundle: the next pose replaces it anyway.
    if (errno == EAGAIN || errno == EWOULDBLOCK || receiver.failing) continue;
    receiver.failing = true;
    warn_("vmc: sending to " + receiver.name + ": " + std::strerror(errno));
  }
  ++bundles_sent_;
}

}  // namespace mocap
