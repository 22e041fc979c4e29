// One interface for every source of camera frames: V4L2 devices (firmware/drivers/v4l2), a
// replayed frames directory (firmware/drivers/replay) and frames pushed in process (tests, the
// simulator; firmware/lib/in_process_source.h).
//
// The navigation loop, once per frame set:
//     trigger.Fire();                                      // firmware/drivers/gpio (if wired)
//     for (int k = 0; k < source.num_cameras(); ++k) {
//       FrameView v;
//       SourceStatus s = source.Acquire(k, timeout_ms, &v);
//       if (s == SourceStatus::kOk) { Process(v); source.Release(k); }
//       else if (s == SourceStatus::kEndOfStream) ...     // no more frames, ever
//       else ...                                          // no frame of camera k in this set
//     }
//
// Contract
// - Start() reserves every buffer (memory, mappings, file descriptors). After Start no method
//   allocates heap memory; every loop is bounded. Start() on a started source restarts it.
// - Acquire(k, timeout_ms, out) waits at most about timeout_ms (V4L2: poll; a bounded number of
//   EINTR retries may each wait again) for camera k's next frame. Only kOk fills *out and lends
//   the frame: its pixels stay valid and unchanged until Release(k). Every other status leaves
//   *out untouched and lends nothing (the source has already given any unusable buffer back).
// - One frame per camera may be lent at a time (Acquire on a camera that holds one: kBusy);
//   frames of different cameras may be held together.
// - Release(k) gives camera k's frame back; a no-op when camera k holds none.
// - Reset(k) brings one camera back after the loop set it aside (V4L2: close and reopen the
//   device; the others keep streaming). Stop() releases everything; Stop() twice is harmless.
//   Both end the lending of the cameras they touch: views of those cameras become invalid.
// - Frames of one camera come in capture order; FrameView::sequence is the driver's frame
//   counter (replay: the frame number), so frames of one set can be matched across cameras.
// - counters(k) is a plain struct that health reporting reads at any time between calls.
// - Not thread-safe: one thread drives a source.
#pragma once

#include <array>
#include <cstdint>

#include "common/limits.h"
#include "firmware/lib/frame.h"

namespace mfns::fw {

enum class SourceStatus : unsigned char {
  kOk = 0,
  // Acquire: no frame of this camera now; the stream goes on.
  kTimeout,       // nothing arrived within the timeout
  kDropped,       // a frame arrived unusable (driver error flag, unknown clock, short) and was
                  // given back; see the counters for which
  kMissingFrame,  // replay: this camera has no file for this frame
  kBadFrame,      // replay: this camera's file is malformed or changed size (Start: the
                  // first frame, which sizes the camera's buffer, is malformed)
  // Acquire: the camera needs attention.
  kError,         // the driver failed (poll/DQBUF/QBUF error); the loop may Reset the camera
  kEndOfStream,   // no more frames will come (replay finished, in-process source closed)
  // Misuse.
  kNotStarted,    // Acquire/Reset before Start or after Stop
  kBadCamera,     // camera index outside [0, num_cameras())
  kBusy,          // Acquire while this camera still holds a frame: Release first
  // Start/Reset.
  kBadConfig,      // configuration invalid (paths, sizes, counts, rate, truth.csv)
  kOpenFailed,     // a device, folder or file could not be opened or holds nothing
  kNotCapture,     // the device is not a single-planar video capture device with streaming
  kFormatRefused,  // the driver (or the first frame) changed the size or pixel format
  kNoBuffers,      // too few/many buffers, or QUERYBUF/mmap failed
  kStreamFailed,   // QBUF or STREAMON failed
};
const char* ToString(SourceStatus s);

// Per-camera counters; each failure mode has its own. Reset to zero by Start().
struct SourceCounters {
  std::uint64_t frames = 0;           // frames lent with kOk
  std::uint64_t drops = 0;            // frames lost, from gaps in the driver's sequence numbers
  std::uint64_t timeouts = 0;         // kTimeout
  std::uint64_t driver_errors = 0;    // failed syscalls: kError (and failed QBUF on Release)
  std::uint64_t error_buffers = 0;    // buffers flagged V4L2_BUF_FLAG_ERROR: kDropped
  std::uint64_t unknown_clock = 0;    // frames not stamped with CLOCK_MONOTONIC (replay: no
                                      // truth.csv row): kDropped
  std::uint64_t short_buffers = 0;    // bytesused below the negotiated image size: kDropped
  std::uint64_t sequence_resets = 0;  // the sequence number went backwards (driver restart)
  std::uint64_t eintr_retries = 0;    // syscalls retried after EINTR
  std::uint64_t missing_files = 0;    // replay: kMissingFrame
  std::uint64_t bad_files = 0;        // replay: kBadFrame
};

// Counts frames lost between consecutive driver sequence numbers (wrap-around safe): a jump
// from s to s + 1 + n adds n to counters->drops; a step backwards adds one sequence reset.
class SequenceTracker {
 public:
  void Reset() { has_last_ = false; }
  void Observe(std::uint32_t sequence, SourceCounters* counters);

 private:
  bool has_last_ = false;
  std::uint32_t last_ = 0;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;

  virtual SourceStatus Start() = 0;
  virtual SourceStatus Acquire(int camera, int timeout_ms, FrameView* out) = 0;
  virtual void Release(int camera) = 0;
  virtual SourceStatus Reset(int camera) = 0;
  virtual void Stop() = 0;

  int num_cameras() const { return num_cameras_; }
  // Counters of camera k; an all-zero struct for k outside [0, num_cameras()).
  const SourceCounters& counters(int camera) const;

 protected:
  // num_cameras is clamped to [0, limits::kMaxCameras].
  explicit FrameSource(int num_cameras);
  bool ValidCamera(int camera) const { return camera >= 0 && camera < num_cameras_; }
  SourceCounters& mutable_counters(int camera) { return counters_[static_cast<unsigned>(camera)]; }
  void ResetCounters() { counters_ = {}; }

 private:
  int num_cameras_ = 0;
  std::array<SourceCounters, limits::kMaxCameras> counters_{};
};

}  // namespace mfns::fw
