// What every mocapctl subcommand that talks to mocapd shares: the --server/--token/--tls-ca
// flags, the channel and the per-call credentials.
//
// Channel arguments that keep a slow reader near live: the daemon drops a subscriber's oldest
// poses only once its write is stuck, and a write gets stuck only when the client's HTTP/2 flow
// control window is full. With the defaults (BDP probing on, large windows) megabytes of poses can
// sit in the client's buffers, seconds behind. So the pose channel turns BDP probing off
// (GRPC_ARG_HTTP2_BDP_PROBE = 0) and keeps the stream's window small
// (GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES = 16 KiB, a few poses): a slow reader then sees poses a
// few frames old, with Pose.missed_before telling it how many it lost.
#pragma once

#include <memory>
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
};

// Parses argv[2...]: the daemon flags are taken out, the rest is returned in order. Throws
// std::runtime_error on a flag without its value.
std::vector<std::string> parseDaemonFlags(int argc, char** argv, DaemonFlags& flags);

class DaemonClient {
 public:
  explicit DaemonClient(const DaemonFlags& flags);
  mocap::v1::MocapService::Stub& stub() { return *stub_; }
  // A context carrying the bearer token, if any.
  std::unique_ptr<grpc::ClientContext> context() const;

 private:
  std::string token_;
  std::unique_ptr<mocap::v1::MocapService::Stub> stub_;
};

// Throws std::runtime_error("<what>: <code>: <message>") unless `status` is OK.
void check(const grpc::Status& status, const std::string& what);

}  // namespace mocapctl
