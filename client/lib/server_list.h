// `--server a,b,c` (issue 12, scale-out): several glintd replicas behind one gRPC channel whose
// round_robin load-balancing policy sends each call to the next ready server. One large batch
// is then spread over them by sending its chunks as separate calls (GlintClient::Evaluate).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace glint::client {

struct ServerTarget {
  std::string target;        // what grpc::CreateCustomChannel gets
  size_t servers = 1;        // addresses in the list
  bool round_robin = false;  // more than one: the channel uses the round_robin policy
};

// A single address ("127.0.0.1:50051", "dns:///glint:50051", "unix:/path") is returned as is.
// A comma-separated list of host:port entries becomes gRPC's static multi-address target:
// "ipv4:10.0.0.1:50051,10.0.0.2:50051" (host names resolved with getaddrinfo to their first
// IPv4 address), or "ipv6:[::1]:50051,..." when every host is a bracketed IPv6 literal.
// Throws std::invalid_argument naming the entry on an empty entry, one without a port, a
// scheme inside a list, a mix of IPv4 and IPv6, or a name that does not resolve.
ServerTarget ParseServerList(const std::string &address);

// The entries of a comma-separated list ({address} for one address), for what must reach every
// replica rather than the next one (uploading a normal map).
std::vector<std::string> SplitServerList(const std::string &address);

}  // namespace glint::client
