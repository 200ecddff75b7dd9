// What every mocapctl subcommand that talks to mocapd shares: the --server/--token/--tls-ca/
// --timeout flags, the channel, the per-call credentials and each request's deadline.
//
// Every request but the pose stream has a deadline: a daemon that accepts the connection and then
// hangs would otherwise hang the command, and any script that runs it, for ever. Each bound is
// generous for what the daemon does before it answers, and finite; --timeout overrides them all.
//
// Channel arguments that keep a slow reader near live: the daemon drops a subscriber's oldest
// poses only once its write is stuck, and a write gets stuck only when the client's HTTP/2 flow
// control window is full. With the defaults (BDP probing on, large windows) megabytes of poses can
// sit in the client's buffers, seconds behind. So the pose channel turns BDP probing off
// (GRPC_ARG_HTTP2_BDP_PROBE = 0) and keeps the stream's window small
// (GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES = 16 KiB, a few poses): a slow reader then sees poses a
// few frames old, with Pose.missed_before telling it how many it lost.
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "mocap/v1/mocap.grpc.pb.h"

namespace mocapctl {

struct DaemonFlags {
  std::string server = "127.0.0.1:50051";
  std::string token;   // --token, or $MOCAP_TOKEN
  std::string tls_ca;  // --tls-ca PEM file: connect with TLS, trusting that CA
  // --tls-cert / --tls-key PEM files: the client's certificate and key, for a daemon that asks
  // for one (tls.client_ca); both or neither, with --tls-ca.
  std::string tls_cert;
  std::string tls_key;
  // --timeout SECONDS: how long each request waits for the daemon's answer, instead of its own
  // bound (DaemonClient's k...Timeout); empty: those.
  std::string timeout;
};

// Parses argv[2...]: the daemon flags are taken out, the rest is returned in order. Throws
// std::runtime_error on a flag without its value.
std::vector<std::string> parseDaemonFlags(int argc, char** argv, DaemonFlags& flags);

class DaemonClient {
 public:
  using Stub = mocap::v1::MocapService::Stub;

  // How long a request may wait for its answer, by what the daemon does before it answers.
  // Reads its state or sets a flag (GetStatus, GetSkeleton, Reacquire): at once, unless the host
  // is saturated or the connection slow to set up.
  static constexpr std::chrono::seconds kQuickTimeout{10};
  // Opens a session: checks the free space, creates its folders and writes the rig, the body and
  // the index headers, which a slow or busy disk can take seconds over.
  static constexpr std::chrono::seconds kRecordingStartTimeout{30};
  // Closes a session: the writers first encode and write every queued frame set (8 by default,
  // tens of milliseconds a frame for lossless images, longer on a slow card), then sync the
  // indexes. A busy disk can take a minute over that; a hung daemon never answers.
  static constexpr std::chrono::seconds kRecordingStopTimeout{120};

  // Throws std::runtime_error on unusable TLS flags or --timeout.
  explicit DaemonClient(const DaemonFlags& flags);
  Stub& stub() { return *stub_; }
  // A context carrying the bearer token, if any, and no deadline: for the pose stream.
  std::unique_ptr<grpc::ClientContext> context() const;

  // One unary request: `rpc` (e.g. &Stub::GetStatus) with the token, answered within `timeout`
  // (or --timeout). Throws std::runtime_error naming `what` unless the answer is OK; past the
  // deadline, the error says so and names the daemon's address.
  template <typename Request, typename Response>
  void call(const char* what,
            grpc::Status (Stub::*rpc)(grpc::ClientContext*, const Request&, Response*),
            const Request& request, Response& response, std::chrono::seconds timeout) {
    const std::chrono::milliseconds bound = timeout_.value_or(timeout);
    const auto deadline = std::chrono::system_clock::now() + bound;
    std::unique_ptr<grpc::ClientContext> context = this->context();
    context->set_deadline(deadline);
    checkAnswer((stub_.get()->*rpc)(context.get(), request, &response), what, deadline, bound);
  }

 private:
  // As check(), but a DEADLINE_EXCEEDED at or past `deadline` is this client giving up (the
  // daemon's own DEADLINE_EXCEEDED, as a background capture's when frames stop, comes earlier).
  void checkAnswer(const grpc::Status& status, const char* what,
                   std::chrono::system_clock::time_point deadline,
                   std::chrono::milliseconds bound) const;

  std::string server_;
  std::string token_;
  std::optional<std::chrono::milliseconds> timeout_;  // --timeout
  std::unique_ptr<Stub> stub_;
};

// Throws std::runtime_error("<what>: <code>: <message>") unless `status` is OK.
void check(const grpc::Status& status, const std::string& what);

}  // namespace mocapctl
