#include "firmware/modules/publish/publishers.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "common/rotation/rotation.h"

namespace mfns::fw {

const char* ToString(PublishStatus s) {
  switch (s) {
    case PublishStatus::kOk: return "ok";
    case PublishStatus::kBadAddress: return "bad address (expected [mavlink+]udp://HOST:PORT, HOST IPv4, PORT 1..65535)";
    case PublishStatus::kSocketError: return "socket error";
    case PublishStatus::kWouldBlock: return "socket buffer full, datagram dropped";
    case PublishStatus::kSendError: return "send failed";
    case PublishStatus::kNotOpen: return "not open";
    case PublishStatus::kFileError: return "log file error";
    case PublishStatus::kBadScheme: return "unknown scheme (expected udp://HOST:PORT or mavlink+udp://HOST:PORT)";
    case PublishStatus::kTooMany: return "too many outputs";
  }
  return "unknown";
}

UdpPublisher::~UdpPublisher() { Close(); }

PublishStatus UdpPublisher::Open(const char* url) {
  Close();
  constexpr char kScheme[] = "udp://";
  if (url == nullptr || std::strncmp(url, kScheme, sizeof(kScheme) - 1) != 0) return PublishStatus::kBadAddress;
  const char* host = url + sizeof(kScheme) - 1;
  const char* colon = std::strrchr(host, ':');
  if (colon == nullptr || colon == host) return PublishStatus::kBadAddress;
  char host_buf[256] = {};
  const auto host_len = static_cast<std::size_t>(colon - host);
  if (host_len >= sizeof(host_buf)) return PublishStatus::kBadAddress;
  std::memcpy(host_buf, host, host_len);
  char* end = nullptr;
  const long port = std::strtol(colon + 1, &end, 10);
  if (end == colon + 1 || *end != '\0' || port <= 0 || port > 65535) return PublishStatus::kBadAddress;

  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* res = nullptr;
  if (getaddrinfo(host_buf, nullptr, &hints, &res) != 0 || res == nullptr) return PublishStatus::kBadAddress;
  sockaddr_in addr{};
  std::memcpy(&addr, res->ai_addr, sizeof(addr));
  freeaddrinfo(res);
  addr.sin_port = htons(static_cast<std::uint16_t>(port));

  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) return PublishStatus::kSocketError;
  // connect() fixes the destination once: send() then needs no address per datagram.
  if (::connect(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    Close();
    return PublishStatus::kSocketError;
  }
  return PublishStatus::kOk;
}

PublishStatus UdpPublisher::Send(std::span<const std::uint8_t> datagram) {
  if (fd_ < 0) return PublishStatus::kNotOpen;
  const ssize_t n = ::send(fd_, datagram.data(), datagram.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
  if (n == static_cast<ssize_t>(datagram.size())) {
    ++counters_.sent;
    return PublishStatus::kOk;
  }
  if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
    ++counters_.would_block;
    return PublishStatus::kWouldBlock;
  }
  // ECONNREFUSED (nobody listening yet) and the like: count and go on.
  ++counters_.send_errors;
  return PublishStatus::kSendError;
}

void UdpPublisher::Close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

const char* ToString(OutputProtocol p) {
  switch (p) {
    case OutputProtocol::kMfns: return "udp";
    case OutputProtocol::kMavlink: return "mavlink+udp";
    case OutputProtocol::kCount: break;
  }
  return "unknown";
}

PublishStatus ParseOutputUrl(const char* url, OutputProtocol* protocol, const char** udp_url) {
  constexpr char kMavlink[] = "mavlink+";
  constexpr std::size_t kMavlinkChars = sizeof(kMavlink) - 1;
  if (url == nullptr) return PublishStatus::kBadScheme;
  const bool mavlink = std::strncmp(url, kMavlink, kMavlinkChars) == 0;
  const char* udp = mavlink ? url + kMavlinkChars : url;
  if (std::strncmp(udp, "udp://", 6) != 0) return PublishStatus::kBadScheme;
  *protocol = mavlink ? OutputProtocol::kMavlink : OutputProtocol::kMfns;
  *udp_url = udp;
  return PublishStatus::kOk;
}

PublishStatus Outputs::Add(const char* url, const MavlinkConfig& mavlink) {
  OutputProtocol protocol = OutputProtocol::kMfns;
  const char* udp_url = nullptr;
  const PublishStatus s = ParseOutputUrl(url, &protocol, &udp_url);
  if (s != PublishStatus::kOk) return s;
  if (count_ >= limits::kMaxOutputs) return PublishStatus::kTooMany;
  Slot& slot = slots_[static_cast<std::size_t>(count_)];
  const PublishStatus o = slot.udp.Open(udp_url);
  if (o != PublishStatus::kOk) return o;
  slot.protocol = protocol;
  slot.mavlink = MavlinkStream(mavlink);
  ++count_;
  return PublishStatus::kOk;
}

void Outputs::Pose(const PoseRecord& r) {
  bool encoded = false;  // the MFNS datagram once for every output that takes it
  for (int i = 0; i < count_; ++i) {
    Slot& slot = slots_[static_cast<std::size_t>(i)];
    if (slot.protocol == OutputProtocol::kMavlink) {
      const int n = slot.mavlink.Next(r);
      for (int p = 0; p < n; ++p) slot.udp.Send(slot.mavlink.packet(p));
      continue;
    }
    if (!encoded) EncodePose(r, pose_bytes_);
    encoded = true;
    slot.udp.Send(pose_bytes_);
  }
}

void Outputs::Health(const HealthRecord& h) {
  bool encoded = false;
  for (int i = 0; i < count_; ++i) {
    Slot& slot = slots_[static_cast<std::size_t>(i)];
    if (slot.protocol != OutputProtocol::kMfns) continue;
    if (!encoded) EncodeHealth(h, health_bytes_);
    encoded = true;
    slot.udp.Send(health_bytes_);
  }
}

void Outputs::Blobs(const BlobsRecord& r) {
  if (wants_health()) SendMfns(std::span<const std::uint8_t>(blobs_bytes_.data(), EncodeBlobs(r, blobs_bytes_)));
}

void Outputs::BeaconHealth(const BeaconHealthRecord& r) {
  if (wants_health())
    SendMfns(std::span<const std::uint8_t>(beacon_health_bytes_.data(), EncodeBeaconHealth(r, beacon_health_bytes_)));
}

void Outputs::SendMfns(std::span<const std::uint8_t> datagram) {
  for (int i = 0; i < count_; ++i) {
    Slot& slot = slots_[static_cast<std::size_t>(i)];
    if (slot.protocol == OutputProtocol::kMfns) slot.udp.Send(datagram);
  }
}

bool Outputs::wants_health() const {
  for (int i = 0; i < count_; ++i)
    if (slots_[static_cast<std::size_t>(i)].protocol == OutputProtocol::kMfns) return true;
  return false;
}

// Not Close: a PoseLog destroyed while open belongs to a run that did not finish (a failed
// start returns through here), and its log must not replace the previous one.
PoseLog::~PoseLog() { Abandon(); }

PublishStatus PoseLog::Fail() {
  if (first_errno_ == 0) first_errno_ = errno != 0 ? errno : EIO;
  ++counters_.log_errors;
  return PublishStatus::kFileError;
}

PublishStatus PoseLog::Open(const char* path) {
  Abandon();
  first_errno_ = 0;
  if (path == nullptr || std::strlen(path) >= sizeof(path_)) return PublishStatus::kFileError;
  std::strncpy(path_, path, sizeof(path_) - 1);
  // A device, FIFO or socket at the path (--log /dev/null, /dev/stdout) is written in place:
  // renaming a file over it would replace the node itself (as root, /dev/null became a file).
  struct stat st {};
  in_place_ = ::stat(path_, &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode);
  if (in_place_) std::snprintf(partial_, sizeof(partial_), "%s", path_);
  else std::snprintf(partial_, sizeof(partial_), "%s.partial", path_);
  errno = 0;
  file_ = std::fopen(partial_, "w");
  if (file_ == nullptr) return Fail();
  std::setvbuf(file_, buffer_, _IOFBF, sizeof(buffer_));  // our buffer: no heap in stdio
  if (std::fputs("frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px,reason,flagged_beacons\n", file_) < 0) {
    return Fail();
  }
  return PublishStatus::kOk;
}

PublishStatus PoseLog::Write(const PoseRecord& r, const char* flagged_beacons) {
  if (file_ == nullptr) return PublishStatus::kNotOpen;
  // After a failure the file ends in a cut row: appending would bury it mid-file.
  if (failed()) return Fail();
  const Eigen::Vector3d p_mm = r.r_w_wb * 1e3;
  EulerAngles e = MatrixToEuler(r.q_w_b.toRotationMatrix().transpose());  // of C_b_w
  if (!r.q_w_b.coeffs().allFinite()) e.phi = e.theta = e.psi = std::numeric_limits<double>::quiet_NaN();  // no pose
  errno = 0;
  const int n = std::fprintf(file_, "%u,%llu,%s,%.4f,%.4f,%.4f,%.6f,%.6f,%.6f,%u,%.4f,%s,%s\n", r.frame_set,
                             static_cast<unsigned long long>(r.t_capture_ns), ToString(r.status), p_mm.x(), p_mm.y(),
                             p_mm.z(), RadToDeg(e.phi), RadToDeg(e.theta), RadToDeg(e.psi), r.num_beacons,
                             static_cast<double>(r.residual_rms_px), ToString(r.reason),
                             flagged_beacons != nullptr ? flagged_beacons : "");
  if (n < 0 || std::fflush(file_) != 0) return Fail();
  ++counters_.log_rows;
  return PublishStatus::kOk;
}

PublishStatus PoseLog::Close() {
  if (file_ == nullptr) return failed() ? PublishStatus::kFileError : PublishStatus::kOk;
  errno = 0;
  // (fsync of a device or a pipe fails with EINVAL: nothing to make durable there.)
  bool ok = !failed() && std::fflush(file_) == 0 && (in_place_ || ::fsync(fileno(file_)) == 0) &&
            std::ferror(file_) == 0;
  if (!ok) Fail();
  errno = 0;
  const bool closed = std::fclose(file_) == 0;  // false: e.g. a deferred write error
  file_ = nullptr;
  if (ok && !closed) Fail();
  if (!ok || !closed) return PublishStatus::kFileError;
  errno = 0;
  if (!in_place_ && std::rename(partial_, path_) != 0) return Fail();
  return PublishStatus::kOk;
}

void PoseLog::Abandon() {
  if (file_ != nullptr) std::fclose(file_);
  file_ = nullptr;
}

}  // namespace mfns::fw
