// Connection to mocapd for mocapctl.
#include "clients/mocapctl/daemon_client.h"

#include <algorithm>
#include <charconv>
#include <cmath>
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
                          : arg == "--timeout"  ? &flags.timeout
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

// --timeout's seconds (a fraction allowed) as a duration; throws unless a number above zero.
std::chrono::milliseconds parseTimeout(const std::string& text) {
  double seconds = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), seconds);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(seconds) ||
      seconds <= 0 || seconds > 86'400)
    throw std::runtime_error("--timeout: seconds above 0, at most a day (got '" + text + "')");
  return std::max(std::chrono::milliseconds(1),
                  std::chrono::milliseconds(std::llround(seconds * 1000)));
}

// "120 s", "0.5 s".
std::string secondsText(std::chrono::milliseconds duration) {
  std::ostringstream text;
  text << std::chrono::duration<double>(duration).count() << " s";
  return text.str();
}

std::string codeName(grpc::StatusCode code) {
  static const char* const kCodes[] = {"OK",
                                       "CANCELLED",
                                       "UNKNOWN",
                                       "INVALID_ARGUMENT",
                                       "DEADLINE_EXCEEDED",
                                       "NOT_FOUND",
                                       "ALREADY_EXISTS",
                                       "PERMISSION_DENIED",
                                       "RESOURCE_EXHAUSTED",
                                       "FAILED_PRECONDITION",
                                       "ABORTED",
                                       "OUT_OF_RANGE",
                                       "UNIMPLEMENTED",
                                       "INTERNAL",
                                       "UNAVAILABLE",
                                       "DATA_LOSS",
                                       "UNAUTHENTICATED"};
  const int index = static_cast<int>(code);
  return index >= 0 && index <= 16 ? kCodes[index] : std::to_string(index);
}

}  // namespace

DaemonClient::DaemonClient(const DaemonFlags& flags) : server_(flags.server), token_(flags.token) {
  if (!flags.timeout.empty()) timeout_ = parseTimeout(flags.timeout);
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

void DaemonClient::checkAnswer(const grpc::Status& status, const char* what,
                               std::chrono::system_clock::time_point deadline,
                               std::chrono::milliseconds bound) const {
  if (status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED &&
      std::chrono::system_clock::now() >= deadline) {
    throw std::runtime_error(std::string(what) + ": DEADLINE_EXCEEDED: no answer from mocapd at " +
                             server_ + " within " + secondsText(bound) +
                             " (is it hung or overloaded? --timeout SECONDS waits longer)");
  }
  check(status, what);
}

void check(const grpc::Status& status, const std::string& what) {
  if (status.ok()) return;
  throw std::runtime_error(what + ": " + codeName(status.error_code()) + ": " +
                           status.error_message());
}

}  // namespace mocapctl
