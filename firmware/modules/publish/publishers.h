// Where navigation output goes: UDP sockets (the MFNS pose and health datagrams of
// pose_message.h, or MAVLink 2, mavlink.h) and the poses CSV of DESIGN.md. All are opened at
// start; after that, sending and logging use no heap and never block the frame loop: a failed
// send is counted and dropped.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <span>

#include "common/limits.h"
#include "firmware/modules/publish/mavlink.h"
#include "firmware/modules/publish/pose_message.h"

namespace mfns::fw {

enum class PublishStatus : unsigned char {
  kOk = 0,
  kBadAddress,   // not udp://HOST:PORT (after mavlink+), or HOST does not resolve to IPv4, or port 0 / > 65535
  kSocketError,  // socket() or connect() failed
  kWouldBlock,   // the socket buffer is full: the datagram is dropped
  kSendError,    // sendto failed otherwise
  kNotOpen,
  kFileError,    // the log could not be opened, written or renamed
  kBadScheme,    // an output that is neither udp:// nor mavlink+udp://
  kTooMany,      // more outputs than limits::kMaxOutputs
};
const char* ToString(PublishStatus s);

struct PublishCounters {
  std::uint64_t sent = 0;
  std::uint64_t would_block = 0;
  std::uint64_t send_errors = 0;
  std::uint64_t log_rows = 0;
  std::uint64_t log_errors = 0;
};

// UDP datagrams to one IPv4 destination. Open resolves the host (getaddrinfo: "localhost" or a
// literal) at start; the socket is non-blocking.
class UdpPublisher {
 public:
  UdpPublisher() = default;
  ~UdpPublisher();
  UdpPublisher(const UdpPublisher&) = delete;
  UdpPublisher& operator=(const UdpPublisher&) = delete;

  PublishStatus Open(const char* url);  // "udp://HOST:PORT"
  PublishStatus Send(std::span<const std::uint8_t> datagram);
  void Close();
  bool is_open() const { return fd_ >= 0; }
  const PublishCounters& counters() const { return counters_; }

 private:
  int fd_ = -1;
  PublishCounters counters_;
};

// What an output speaks, from its URL's scheme: udp:// the MFNS datagrams, mavlink+udp://
// MAVLink 2 (HEARTBEAT and ODOMETRY, mavlink.h).
enum class OutputProtocol : unsigned char { kMfns = 0, kMavlink, kCount };
const char* ToString(OutputProtocol p);  // "udp", "mavlink+udp"
// kOk with *protocol and *udp_url (the "udp://HOST:PORT" part of url, for UdpPublisher::Open);
// kBadScheme for any other scheme.
PublishStatus ParseOutputUrl(const char* url, OutputProtocol* protocol, const char** udp_url);

// Every --output of mfns-navd (up to limits::kMaxOutputs, any mix of protocols), each with its
// socket and, for MAVLink, its stream state. Pose goes to every output in its protocol;
// Health to the MFNS ones (MAVLink has its HEARTBEAT, sent by the stream).
class Outputs {
 public:
  Outputs() = default;
  Outputs(const Outputs&) = delete;
  Outputs& operator=(const Outputs&) = delete;

  // At start: opens one more output. kBadScheme, kTooMany, or UdpPublisher::Open's status.
  PublishStatus Add(const char* url, const MavlinkConfig& mavlink = {});
  void Pose(const PoseRecord& r);
  void Health(const HealthRecord& h);
  // The frame set's blobs and identities (BlobsMessage) to every MFNS output (viewers).
  void Blobs(const BlobsRecord& r);
  // One page of the beacons' health (BeaconHealthMessage) to every MFNS output.
  void BeaconHealth(const BeaconHealthRecord& r);
  bool wants_health() const;  // an MFNS output is open
  int count() const { return count_; }
  OutputProtocol protocol(int i) const { return slots_[static_cast<std::size_t>(i)].protocol; }
  const PublishCounters& counters(int i) const { return slots_[static_cast<std::size_t>(i)].udp.counters(); }
  const MavlinkStream& mavlink(int i) const { return slots_[static_cast<std::size_t>(i)].mavlink; }

 private:
  struct Slot {
    OutputProtocol protocol = OutputProtocol::kMfns;
    UdpPublisher udp;
    MavlinkStream mavlink;
  };
  std::array<Slot, limits::kMaxOutputs> slots_{};
  int count_ = 0;
  std::array<std::uint8_t, kPoseMessageBytes> pose_bytes_{};
  std::array<std::uint8_t, kHealthMessageBytes> health_bytes_{};
  std::array<std::uint8_t, kMaxBlobsMessageBytes> blobs_bytes_{};
  std::array<std::uint8_t, kMaxBeaconHealthMessageBytes> beacon_health_bytes_{};
  void SendMfns(std::span<const std::uint8_t> datagram);  // to every MFNS output
};

// The poses CSV (DESIGN.md): frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,
// n_beacons,rms_px, plus the extension columns `reason` (NavReason's text) and
// `flagged_beacons` (the beacons beacon health flags at that frame set, "12:inconsistent
// 40:missing", empty when none; readers find columns by name, README "Extensions"). Rows go to "<path>.partial" and are flushed per frame set (a crash keeps
// what was logged). Close renames it to <path> only when every write, flush, fsync and the close
// succeeded, so <path> only ever holds a complete log and a failed run never replaces a good
// one: after a failure (a full disk: the last row may be cut mid-number) later rows are dropped
// and counted, and Close leaves <path> untouched and the .partial for inspection. Destroying an
// open PoseLog without Close (a start that failed) also leaves <path> untouched. A path that
// is a device, FIFO or socket (/dev/null, /dev/stdout) is written in place, never renamed over.
class PoseLog {
 public:
  PoseLog() = default;
  ~PoseLog();
  PoseLog(const PoseLog&) = delete;
  PoseLog& operator=(const PoseLog&) = delete;

  PublishStatus Open(const char* path);
  // kFileError when this row or an earlier one could not be written (the row is dropped).
  PublishStatus Write(const PoseRecord& r, const char* flagged_beacons = "");
  // Finishes the log: kOk only when <path> now holds every row; kFileError otherwise (nothing
  // renamed; first_error() says why).
  PublishStatus Close();
  // Closes the file without renaming it (<path> untouched, the .partial kept).
  void Abandon();
  bool is_open() const { return file_ != nullptr; }
  bool failed() const { return first_errno_ != 0; }
  int first_error() const { return first_errno_; }  // errno of the first failure, 0 when none
  const char* partial_path() const { return partial_; }
  const PublishCounters& counters() const { return counters_; }

 private:
  PublishStatus Fail();  // records errno and counts the failure

  std::FILE* file_ = nullptr;
  int first_errno_ = 0;
  bool in_place_ = false;  // the path is a device, FIFO or socket: written directly, never renamed
  char path_[limits::kMaxPathChars] = {};
  char partial_[limits::kMaxPathChars + 16] = {};
  char buffer_[8192] = {};
  PublishCounters counters_;
};

}  // namespace mfns::fw
