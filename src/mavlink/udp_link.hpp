// A UDP endpoint for MAVLink over IPv4, the way PX4 SITL and companions talk: each datagram
// carries whole frames. Non-blocking receive with a timeout; POSIX sockets.
#pragma once

#include <netinet/in.h>

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace ridgeline::mavlink {

class UdpLink {
 public:
  /// Listens on address:port (the vehicle's side). Replies go to whoever sent last.
  /// Throws std::runtime_error naming the address, port and the system's reason.
  static UdpLink listen(const std::string& address, std::uint16_t port);
  /// Talks to host:port from an ephemeral local port (the companion's side).
  static UdpLink connect(const std::string& host, std::uint16_t port);

  UdpLink(UdpLink&& other) noexcept;
  UdpLink& operator=(UdpLink&& other) noexcept;
  UdpLink(const UdpLink&) = delete;
  UdpLink& operator=(const UdpLink&) = delete;
  ~UdpLink();

  /// Sends one datagram to the peer; false (and nothing sent) while no peer is known.
  bool send(std::span<const std::uint8_t> bytes);
  /// Waits up to timeout_s for one datagram; empty on timeout.
  std::vector<std::uint8_t> receive(double timeout_s);
  bool has_peer() const { return has_peer_; }
  std::uint16_t local_port() const;
  /// Sends to host:port until a datagram arrives (listen(): then the sender is the peer).
  /// Throws std::runtime_error when host does not resolve.
  void set_peer(const std::string& host, std::uint16_t port);
  /// "ADDRESS:PORT" of the peer, or "(no peer yet)".
  std::string peer_text() const;
  /// The socket, for poll() over several links; owned by the link.
  int native_handle() const { return fd_; }

 private:
  UdpLink() = default;
  int fd_ = -1;
  sockaddr_in peer_{};
  bool has_peer_ = false;
  bool follow_sender_ = false;  // listen(): the peer is the last sender
};

/// "HOST:PORT" → host and port; throws ridgeline::InputError (field `--udp`) with the reason.
std::pair<std::string, std::uint16_t> parse_host_port(const std::string& text);

}  // namespace ridgeline::mavlink
