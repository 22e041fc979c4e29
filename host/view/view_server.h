// mfns-view's two sockets: the UDP port where mfns-navd's datagrams arrive (--listen) and the
// HTTP server of the page (--http). Host only; allocates; threads of their own.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <thread>

#include "host/view/view_cli.h"
#include "host/view/view_state.h"

namespace httplib {
class Server;
}

namespace mfns::host {

// One datagram: a pose (type 1), health (type 2) or blobs (type 3) message of pose_message.h
// goes to the state; anything else is counted as bad with its reason.
void DispatchDatagram(std::span<const std::uint8_t> datagram, ViewState* state);

// Receives datagrams on a UDP port until Stop (or destruction).
class DatagramListener {
 public:
  // Binds at once: throws UserError "--listen: ..." when the address does not resolve or bind.
  DatagramListener(const HostPort& where, ViewState* state);
  ~DatagramListener();
  DatagramListener(const DatagramListener&) = delete;
  DatagramListener& operator=(const DatagramListener&) = delete;
  int port() const { return port_; }
  void Start();
  void Stop();

 private:
  void Loop();
  ViewState* state_;
  int fd_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// Serves the page (/), its state (/state.json) and the map (/rig.json).
class PageServer {
 public:
  // Binds at once: throws UserError "--http: ..." when it cannot.
  PageServer(const HostPort& where, ViewState* state);
  ~PageServer();
  PageServer(const PageServer&) = delete;
  PageServer& operator=(const PageServer&) = delete;
  int port() const { return port_; }
  void Start();
  void Stop();

 private:
  std::unique_ptr<httplib::Server> server_;
  int port_ = 0;
  std::thread thread_;
};

// The page (view_page.html, embedded at build time).
extern const char* const kViewPageHtml;

}  // namespace mfns::host
