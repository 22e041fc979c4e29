// Tests only: a UDP socket bound to an ephemeral port on 127.0.0.1, for outputs under test to
// send to (header-only; POSIX sockets).
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>

#include <string>

namespace mfns::testing {

// The socket's fd and *port its port number as text; -1 on failure. recv_timeout_s > 0 sets
// SO_RCVTIMEO, so that a receive that never comes fails the test instead of hanging it.
inline int LoopbackUdpSocket(std::string* port, int recv_timeout_s = 0) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof(addr);
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0)
    return -1;
  if (recv_timeout_s > 0) {
    timeval tv{recv_timeout_s, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
  }
  *port = std::to_string(ntohs(addr.sin_port));
  return fd;
}

}  // namespace mfns::testing
