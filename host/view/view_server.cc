#include "host/view/view_server.h"

#include <arpa/inet.h>
#include <httplib.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>

#include "host/util/user_error.h"

namespace mfns::host {

void DispatchDatagram(std::span<const std::uint8_t> d, ViewState* state) {
  // The type byte (offset 5) picks the decoder; each checks magic, version, size and CRC.
  const std::uint8_t type = d.size() > 5 ? d[5] : 0;
  if (type == 2) {
    fw::HealthRecord h;
    const fw::MessageStatus s = fw::DecodeHealth(d, &h);
    if (s == fw::MessageStatus::kOk) state->SetHealth(h);
    else state->CountBadDatagram(s);
    return;
  }
  if (type == 4) {  // beacon health pages: checked, not shown by the page yet
    fw::BeaconHealthRecord b;
    const fw::MessageStatus s = fw::DecodeBeaconHealth(d, &b);
    if (s != fw::MessageStatus::kOk) state->CountBadDatagram(s);
    return;
  }
  if (type == 3) {
    fw::BlobsRecord b;
    const fw::MessageStatus s = fw::DecodeBlobs(d, &b);
    if (s == fw::MessageStatus::kOk) state->SetBlobs(b);
    else state->CountBadDatagram(s);
    return;
  }
  fw::PoseRecord r;
  const fw::MessageStatus s = fw::DecodePose(d, &r);
  if (s == fw::MessageStatus::kOk) state->AddPose(ViewPoseFromRecord(r));
  else state->CountBadDatagram(s);
}

DatagramListener::DatagramListener(const HostPort& where, ViewState* state) : state_(state) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* res = nullptr;
  if (getaddrinfo(where.host.c_str(), nullptr, &hints, &res) != 0 || res == nullptr)
    throw UserError("--listen: host '" + OneLine(where.host) + "' does not resolve to an IPv4 address");
  sockaddr_in addr{};
  std::memcpy(&addr, res->ai_addr, sizeof(addr));
  freeaddrinfo(res);
  addr.sin_port = htons(static_cast<std::uint16_t>(where.port));
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0 || ::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    const std::string why = std::strerror(errno);
    if (fd_ >= 0) ::close(fd_);
    throw UserError("--listen: cannot bind udp://" + where.host + ":" + std::to_string(where.port) + ": " + why);
  }
  socklen_t len = sizeof(addr);
  ::getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  port_ = ntohs(addr.sin_port);
}

DatagramListener::~DatagramListener() {
  Stop();
  ::close(fd_);
}

void DatagramListener::Start() { thread_ = std::thread([this] { Loop(); }); }

void DatagramListener::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void DatagramListener::Loop() {
  std::array<std::uint8_t, 65536> buffer{};
  while (!stop_) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;  // a timeout (Stop is checked) or EINTR
    const ssize_t n = ::recv(fd_, buffer.data(), buffer.size(), 0);
    if (n >= 0) DispatchDatagram(std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(n)), state_);
  }
}

PageServer::PageServer(const HostPort& where, ViewState* state) : server_(std::make_unique<httplib::Server>()) {
  server_->Get("/", [](const httplib::Request&, httplib::Response& res) {
    res.set_content(kViewPageHtml, "text/html; charset=utf-8");
  });
  server_->Get("/state.json", [state](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_content(state->Json().dump(), "application/json");
  });
  server_->Get("/rig.json", [state](const httplib::Request&, httplib::Response& res) {
    res.set_content(state->RigJson().dump(), "application/json");
  });
  // SO_REUSEADDR only: httplib's default adds SO_REUSEPORT, with which a second mfns-view on the
  // same port would bind too and silently take half the requests.
  server_->set_socket_options([](int fd) {
    int yes = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  port_ = where.port == 0 ? server_->bind_to_any_port(where.host) : (server_->bind_to_port(where.host, where.port) ? where.port : -1);
  if (port_ <= 0)
    throw UserError("--http: cannot serve on " + where.host + ":" + std::to_string(where.port) +
                    " (in use, or not an address of this machine)");
}

PageServer::~PageServer() { Stop(); }

void PageServer::Start() { thread_ = std::thread([this] { server_->listen_after_bind(); }); }

void PageServer::Stop() {
  server_->stop();
  if (thread_.joinable()) thread_.join();
}

}  // namespace mfns::host
