// A receiver of the VMC output (server/vmc_sender.h), as the configuration's `vmc.send_to` names
// it. Its own header so the configuration and the sender share it without depending on each other.
#pragma once

#include <string>

namespace mocap {

struct VmcTarget {
  std::string host;  // a name or an address (an IPv6 address without its brackets)
  int port = 0;

  // host:port, an IPv6 address in brackets.
  std::string text() const {
    const bool ipv6 = host.find(':') != std::string::npos;
    return (ipv6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
  }
};

}  // namespace mocap
