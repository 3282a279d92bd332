#include "client/lib/server_list.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <sys/socket.h>

#include <sstream>
#include <stdexcept>
#include <vector>

namespace glint::client {
namespace {

std::string Resolve4(const std::string &host, const std::string &entry) {
  in_addr literal{};
  if (inet_pton(AF_INET, host.c_str(), &literal) == 1) return host;
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo *found = nullptr;
  const int rc = getaddrinfo(host.c_str(), nullptr, &hints, &found);
  if (rc != 0 || found == nullptr) {
    throw std::invalid_argument("--server: cannot resolve '" + host + "' of entry '" + entry +
                                "' to an IPv4 address (" + gai_strerror(rc) + ")");
  }
  char text[INET_ADDRSTRLEN] = {};
  inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in *>(found->ai_addr)->sin_addr, text,
            sizeof text);
  freeaddrinfo(found);
  return text;
}

}  // namespace

std::vector<std::string> SplitServerList(const std::string &address) {
  if (address.find(',') == std::string::npos) return {address};
  std::vector<std::string> entries;
  std::stringstream in(address);
  for (std::string entry; std::getline(in, entry, ',');) entries.push_back(entry);
  if (address.back() == ',') entries.emplace_back();
  return entries;
}

ServerTarget ParseServerList(const std::string &address) {
  if (address.find(',') == std::string::npos) return {address, 1, false};
  const std::vector<std::string> entries = SplitServerList(address);
  bool any4 = false, any6 = false;
  std::string list;
  for (const std::string &entry : entries) {
    if (entry.empty())
      throw std::invalid_argument("--server " + address + ": an empty entry in the list");
    if (entry.find("://") != std::string::npos || entry.rfind("ipv4:", 0) == 0 ||
        entry.rfind("ipv6:", 0) == 0 || entry.rfind("unix:", 0) == 0 ||
        entry.rfind("dns:", 0) == 0) {
      throw std::invalid_argument("--server " + address + ": entry '" + entry +
                                  "' has a scheme; a list takes host:port entries only");
    }
    const size_t colon = entry.rfind(':');
    if (colon == std::string::npos || colon + 1 == entry.size() || colon == 0)
      throw std::invalid_argument("--server " + address + ": entry '" + entry +
                                  "' is not host:port");
    const std::string host = entry.substr(0, colon), port = entry.substr(colon + 1);
    if (port.find_first_not_of("0123456789") != std::string::npos)
      throw std::invalid_argument("--server " + address + ": entry '" + entry +
                                  "' has a port that is not a number");
    std::string item;
    if (host.front() == '[' && host.back() == ']') {
      any6 = true;
      item = entry;
    } else {
      any4 = true;
      item = Resolve4(host, entry) + ":" + port;
    }
    list += (list.empty() ? "" : ",") + item;
  }
  if (any4 && any6)
    throw std::invalid_argument("--server " + address +
                                ": mixes IPv4 and IPv6 entries; gRPC's static list takes one");
  return {(any6 ? "ipv6:" : "ipv4:") + list, entries.size(), true};
}

}  // namespace glint::client
