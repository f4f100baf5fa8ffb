#include "mavlink/udp_link.hpp"

#include <arpa/inet.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include <fmt/format.h>

#include "core/error.hpp"

namespace ridgeline::mavlink {
namespace {

sockaddr_in resolve(const std::string& host, std::uint16_t port) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  const int rc = ::getaddrinfo(host.c_str(), nullptr, &hints, &found);
  if (rc != 0 || found == nullptr)
    throw std::runtime_error(fmt::format("udp: cannot resolve '{}': {}", host, gai_strerror(rc)));
  sockaddr_in addr{};
  std::memcpy(&addr, found->ai_addr, sizeof(addr));
  ::freeaddrinfo(found);
  addr.sin_port = htons(port);
  return addr;
}

int open_socket() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(fmt::format("udp: socket(): {}", std::strerror(errno)));
  return fd;
}

}  // namespace

std::pair<std::string, std::uint16_t> parse_host_port(const std::string& text) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size())
    throw InputError("--udp", fmt::format("'{}' is not HOST:PORT (e.g. 127.0.0.1:14540)", text));
  const std::string port_text = text.substr(colon + 1);
  int port = 0;
  for (const char c : port_text) {
    if (c < '0' || c > '9' || port > 65535)
      throw InputError("--udp", fmt::format("port '{}' is not a number in 1..65535", port_text));
    port = port * 10 + (c - '0');
  }
  if (port < 1 || port > 65535)
    throw InputError("--udp", fmt::format("port '{}' is not a number in 1..65535", port_text));
  return {text.substr(0, colon), static_cast<std::uint16_t>(port)};
}

UdpLink UdpLink::listen(const std::string& address, std::uint16_t port) {
  UdpLink link;
  link.fd_ = open_socket();
  const sockaddr_in addr = resolve(address, port);
  if (::bind(link.fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0)
    throw std::runtime_error(
        fmt::format("udp: cannot listen on {}:{}: {}", address, port, std::strerror(errno)));
  link.follow_sender_ = true;
  return link;
}

UdpLink UdpLink::connect(const std::string& host, std::uint16_t port) {
  UdpLink link;
  link.fd_ = open_socket();
  link.peer_ = resolve(host, port);
  link.has_peer_ = true;
  return link;
}

void UdpLink::set_peer(const std::string& host, std::uint16_t port) {
  peer_ = resolve(host, port);
  has_peer_ = true;
}

std::string UdpLink::peer_text() const {
  if (!has_peer_) return "(no peer yet)";
  char text[INET_ADDRSTRLEN] = {};
  ::inet_ntop(AF_INET, &peer_.sin_addr, text, sizeof(text));
  return fmt::format("{}:{}", text, ntohs(peer_.sin_port));
}

UdpLink::UdpLink(UdpLink&& o) noexcept
    : fd_(o.fd_), peer_(o.peer_), has_peer_(o.has_peer_), follow_sender_(o.follow_sender_) {
  o.fd_ = -1;
}

UdpLink& UdpLink::operator=(UdpLink&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = o.fd_;
    peer_ = o.peer_;
    has_peer_ = o.has_peer_;
    follow_sender_ = o.follow_sender_;
    o.fd_ = -1;
  }
  return *this;
}

UdpLink::~UdpLink() {
  if (fd_ >= 0) ::close(fd_);
}

bool UdpLink::send(std::span<const std::uint8_t> bytes) {
  if (!has_peer_) return false;
  const ssize_t n = ::sendto(fd_, bytes.data(), bytes.size(), 0,
                             reinterpret_cast<const sockaddr*>(&peer_), sizeof(peer_));
  // A lost datagram is what UDP does; the next period's message replaces it. ECONNREFUSED
  // (the peer is not up yet) is reported by Linux on a later call, and is no reason to stop.
  return n == static_cast<ssize_t>(bytes.size());
}

std::vector<std::uint8_t> UdpLink::receive(double timeout_s) {
  pollfd p{fd_, POLLIN, 0};
  const int timeout_ms = static_cast<int>(std::ceil(std::max(0.0, timeout_s) * 1000.0));
  if (::poll(&p, 1, timeout_ms) <= 0 || (p.revents & POLLIN) == 0) return {};
  std::vector<std::uint8_t> buffer(65536);
  sockaddr_in from{};
  socklen_t from_len = sizeof(from);
  const ssize_t n = ::recvfrom(fd_, buffer.data(), buffer.size(), 0,
                               reinterpret_cast<sockaddr*>(&from), &from_len);
  if (n <= 0) return {};
  buffer.resize(static_cast<std::size_t>(n));
  if (follow_sender_) {
    peer_ = from;
    has_peer_ = true;
  }
  return buffer;
}

std::uint16_t UdpLink::local_port() const {
  sockaddr_in addr{};
  socklen_t len = sizeof(addr);
  if (::getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len) != 0) return 0;
  return ntohs(addr.sin_port);
}

}  // namespace ridgeline::mavlink
