// Replay of a frames directory (DESIGN.md): <dir>/frames/<camera>/<frame:06d>.pgm, binary PGM
// mono8 or mono16, camera folders named after the rig's cameras; timestamps from the t_ns
// column of <dir>/truth.csv (header "frame,t_ns,..."), or frame / frame_rate_hz when there is
// no truth.csv. FrameSource's contract applies (firmware/lib/frame_source.h).
//
// Start: scans each camera folder once (the sequence is frames 0 .. the highest frame number
// found in any camera), reads truth.csv, and reserves one buffer per camera sized from its
// first frame (at most limits::kMaxImageBytes). After Start: open/pread/close only, no heap.
//
// Acquire(k): camera k's next frame, read into camera k's buffer; timeout_ms is ignored (files
// do not wait). Each camera is its own stream, so a missing or bad file of one camera does not
// hold up the others:
//   - no file for this frame -> kMissingFrame (counters.missing_files)
//   - malformed file (see pgm.h), or a size/format other than the first frame's -> kBadFrame
//     (counters.bad_files)
//   - truth.csv present but without this frame's row -> kDropped (counters.unknown_clock)
//   - past the last frame -> kEndOfStream
// The frame counts as consumed in every case; FrameView::sequence is the frame number and
// t_source is TimestampSource::kTruth.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "common/limits.h"
#include "common/rig/rig.h"
#include "firmware/lib/frame_source.h"

namespace mfns::fw {

struct ReplayConfig {
  const char* dir = nullptr;  // the replay directory; borrowed, must outlive the source
  int num_cameras = 0;        // [1, limits::kMaxCameras]
  // Folder name of camera k under <dir>/frames (the rig's camera name); borrowed.
  std::array<const char*, limits::kMaxCameras> camera_names{};
  // Expected image size of camera k (the rig's); 0 accepts the first frame's size.
  std::array<int, limits::kMaxCameras> width{};
  std::array<int, limits::kMaxCameras> height{};
  // Used when <dir>/truth.csv does not exist: t_ns = round(frame * 1e9 / frame_rate_hz).
  // Without truth.csv and without a rate (<= 0), Start fails with kBadConfig.
  double frame_rate_hz = 0.0;
  // Deliver each frame at its recorded time after the first (as cameras would: CLOCK_MONOTONIC
  // sleeps), not as fast as they can be read. For demos and for tests of a running navd.
  bool realtime = false;
};

// Names and sizes from the rig (the names are borrowed from rig: it must outlive the config).
ReplayConfig ReplayConfigFromRig(const Rig& rig, const char* dir, double frame_rate_hz = 0.0);

class ReplaySource final : public FrameSource {
 public:
  explicit ReplaySource(const ReplayConfig& config);

  // kBadConfig (config, or an unreadable/malformed truth.csv: no frame or t_ns column, a
  // non-numeric or duplicated entry), kOpenFailed (a camera folder missing or without frames),
  // kBadFrame (a camera's first frame is malformed: nothing to size its buffer from),
  // kFormatRefused (a first frame's size differs from the configured one).
  SourceStatus Start() override;
  SourceStatus Acquire(int camera, int timeout_ms, FrameView* out) override;
  void Release(int camera) override;
  SourceStatus Reset(int camera) override;  // nothing to reopen: kOk once started
  void Stop() override;

  int num_frames() const { return num_frames_; }  // after Start
  bool timestamps_from_truth() const { return has_truth_; }
  // The file of the last failure of Start or Acquire and why ("<path>: not a regular file"),
  // "" when none: callers name it in their one-line errors.
  const char* problem() const { return problem_.data(); }

 private:
  struct Camera {
    std::array<char, limits::kMaxPathChars + 1> path{};  // "<dir>/frames/<name>/" + file
    int name_at = 0;          // where "<frame:06d>.pgm" is written in path
    std::vector<std::uint8_t> buffer;  // reserved at Start
    int width = 0;
    int height = 0;
    PixelFormat format = PixelFormat::kMono8;
    int next = 0;             // next frame number
    bool held = false;
  };

  SourceStatus ScanCamera(int k, int* first_frame, int* last_frame);
  SourceStatus ReadTruth();
  SourceStatus SizeBuffer(int k, int first_frame);
  void SetFrameName(Camera* cam, int frame) const;
  void SetProblem(const char* path, const char* why);

  ReplayConfig config_;
  void Pace(std::uint64_t t_ns);

  bool started_ = false;
  std::uint64_t pace_t0_ = 0, pace_wall0_ = 0;  // realtime: first frame's time and its wall clock
  bool has_truth_ = false;
  int num_frames_ = 0;
  std::vector<std::uint64_t> t_ns_;  // per frame; kNoTime when truth.csv has no row
  std::array<Camera, limits::kMaxCameras> cams_{};
  std::array<char, limits::kMaxPathChars + 64> problem_{};
};

}  // namespace mfns::fw
