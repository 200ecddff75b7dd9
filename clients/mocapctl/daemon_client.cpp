// Connection to mocapd for mocapctl.
#include "clients/mocapctl/daemon_client.h"

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace mocapctl {

std::vector<std::string> parseDaemonFlags(int argc, char** argv, DaemonFlags& flags) {
  if (const char* token = std::getenv("MOCAP_TOKEN")) flags.token = token;
  std::vector<std::string> rest;
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    std::string* target = arg == "--server"     ? &flags.server
                          : arg == "--token"    ? &flags.token
                          : arg == "--tls-ca"   ? &flags.tls_ca
                          : arg == "--tls-cert" ? &flags.tls_cert
                          : arg == "--tls-key"  ? &flags.tls_key
                                                : nullptr;
    if (!target) {
      rest.push_back(arg);
      continue;
    }
    if (i + 1 >= argc) throw std::runtime_error(arg + " needs a value");
    *target = argv[++i];
  }
  return rest;
}

namespace {

std::string readPem(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot read");
  std::stringstream pem;
  pem << in.rdbuf();
  return pem.str();
}

}  // namespace

DaemonClient::DaemonClient(const DaemonFlags& flags) : token_(flags.token) {
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (flags.tls_cert.empty() != flags.tls_key.empty())
    throw std::runtime_error("--tls-cert and --tls-key go together");
  if (!flags.tls_cert.empty() && flags.tls_ca.empty())
    throw std::runtime_error("--tls-cert needs --tls-ca (the daemon's certificate to trust)");
  if (!flags.tls_ca.empty()) {
    grpc::SslCredentialsOptions tls;
    tls.pem_root_certs = readPem(flags.tls_ca);
    if (!flags.tls_cert.empty()) {
      tls.pem_cert_chain = readPem(flags.tls_cert);
      tls.pem_private_key = readPem(flags.tls_key);
    }
    credentials = grpc::SslCredentials(tls);
  }
  grpc::ChannelArguments arguments;
  arguments.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  arguments.SetInt(GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES, 16 * 1024);
  stub_ = mocap::v1::MocapService::NewStub(
      grpc::CreateCustomChannel(flags.server, credentials, arguments));
}

std::unique_ptr<grpc::ClientContext> DaemonClient::context() const {
  auto context = std::make_unique<grpc::ClientContext>();
  if (!token_.empty()) context->AddMetadata("authorization", "Bearer " + token_);
  return context;
}

void check(const grpc::Status& status, const std::string& what) {
  if (status.ok()) return;
  static const char* const kCodes[] = {
      "OK", "CANCELLED", "UNKNOWN", "INVALID_ARGUMENT", "DEADLINE_EXCEEDED", "NOT_FOUND",
      "ALREADY_EXISTS", "PERMISSION_DENIED", "RESOURCE_EXHAUSTED", "FAILED_PRECONDITION",
      "ABORTED", "OUT_OF_RANGE", "UNIMPLEMENTED", "INTERNAL", "UNAVAILABLE", "DATA_LOSS",
      "UNAUTHENTICATED"};
  const int code = static_cast<int>(status.error_code());
  const std::string name = code >= 0 && code <= 16 ? kCodes[code] : std::to_string(code);
  throw std::runtime_error(what + ": " + name + ": " + status.error_message());
}

}  // namespace mocapctl
