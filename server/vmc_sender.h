// Sends the tracked poses to avatar apps (VSeeFace, Warudo, EVMC4U, VMC4B) over the VMC protocol,
// OSC over UDP: one bundle per pose to every receiver of the `vmc.send_to` list, and a bundle
// saying "not tracking" each second while no pose comes (the subject lost, or not found yet).
//
// A slow or absent receiver never delays the tracker or the other subscribers: the publisher thread
// only hands the newest pose to the sender (latest wins), and the sender's own thread converts it
// (server/vmc_frame.h), encodes it with liblo and sends it on a non-blocking UDP socket, so a
// datagram the network cannot take at once is dropped, never waited for. The sockets are the
// sender's own, not liblo's: liblo's block, and sending from a liblo server binds a port on every
// interface.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <sys/socket.h>

#include "drivers/status.h"
#include "server/handoff.h"
#include "server/pose_publisher.h"
#include "server/vmc_frame.h"
#include "server/vmc_target.h"
#include "tracker/model/body_model.h"

namespace mocap {

// The bundle of one frame, OSC as liblo writes it: /VMC/Ext/OK, /VMC/Ext/T, /VMC/Ext/Root/Pos, then
// one /VMC/Ext/Bone/Pos per bone (its name, position xyz, rotation xyzw, 32-bit floats).
std::vector<uint8_t> encodeVmcBundle(const VmcFrame& frame);

class VmcSender final : public PoseSubscriber {
 public:
  // The body a pose is of (the pipeline's tracked body): called on the sender's thread when a pose
  // of another body version comes.
  using TrackedBody = std::function<std::shared_ptr<const BodyModel>()>;
  using Warn = std::function<void(const std::string& message)>;

  // How long without a pose before the sender says it is not tracking, and how often it says so.
  static constexpr std::chrono::milliseconds kLostAfter{1000};

  // `warn` reports, once per episode, a receiver that cannot be resolved or reached.
  VmcSender(std::vector<VmcTarget> targets, TrackedBody tracked_body, Warn warn);
  ~VmcSender() override;
  VmcSender(const VmcSender&) = delete;
  VmcSender& operator=(const VmcSender&) = delete;

  // Resolves the receivers, opens the sockets and starts the sender's thread. A receiver that does
  // not resolve is warned about and left out; the error names the receivers when none is left.
  Status start();
  // Sends what is pending and joins the thread. Idempotent.
  void stop();

  // PoseSubscriber, on the publisher thread: only replaces the pending pose.
  void offer(const SharedPose& pose) override;
  void finish() override;

  uint64_t bundlesSent() const { return bundles_sent_; }

 private:
  struct Receiver {
    std::string name;  // host:port, for messages
    sockaddr_storage address{};
    socklen_t length = 0;
    int socket = -1;       // the sender's socket of the address's family
    bool failing = false;  // warned about; reset by the next datagram it takes
  };

  void run();
  void send(const VmcFrame& frame);
  // The frame of `pose`, with the rig of its body (made again when the body changed).
  VmcFrame frameOf(const Pose& pose);
  // /VMC/Ext/T: seconds since start().
  double secondsSinceStart() const;

  std::vector<VmcTarget> targets_;
  TrackedBody tracked_body_;
  Warn warn_;
  std::vector<Receiver> receivers_;
  int socket_v4_ = -1, socket_v6_ = -1;
  Handoff<SharedPose> poses_{Handoff<SharedPose>::Mode::kLatestWins};
  std::thread thread_;
  std::chrono::steady_clock::time_point start_;
  std::atomic<uint64_t> bundles_sent_{0};

  // Sender thread only: the body of the last pose and its rig.
  uint32_t body_version_ = 0;
  std::shared_ptr<const BodyModel> body_;
  VmcRig rig_;
};

}  // namespace mocap
