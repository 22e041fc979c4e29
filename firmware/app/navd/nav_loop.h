// The frame-set loop of mfns-navd: trigger, acquire every camera, detect blobs in place,
// navigate, publish pose and health, keep the per-camera and timing counters. Everything is
// reserved by the constructor and Start (construct it at start, e.g. with std::make_unique);
// Step() never allocates, never throws and is bounded.
//
// Health (DESIGN.md "Time"): a camera whose Acquire fails camera_timeouts_to_set_aside times in
// a row is set aside (the others go on, status degraded) and retried with Reset every
// camera_retry_every frame sets. Each frame set has a processing deadline (from the end of
// acquisition to the publish); a miss counts a slip and the worst time is kept.
#pragma once

#include <array>
#include <cstdint>

#include "common/rig/rig.h"
#include "firmware/drivers/gpio/gpio_trigger.h"
#include "firmware/lib/frame_source.h"
#include "firmware/modules/detect/detect.h"
#include "firmware/app/navd/navigator.h"
#include "firmware/lib/monotonic_clock.h"
#include "firmware/modules/publish/publishers.h"

namespace mfns::fw {

struct NavLoopConfig {
  int timeout_ms = 160;
  double deadline_ms = 53.8;  // the frame period: a frame set's deadline, and the time step given to
                              // a frame set whose timestamp is not after the last (CheckClock)
  double sigma_px = 0.15;
  int camera_timeouts_to_set_aside = 3;
  int camera_retry_every = 19;
  int health_every = 19;
  std::uint64_t param_generation = 0;
  DetectOptions detect;
  NavigatorOptions navigator;
  // A known start pose (the dock): the first frame set with >= 3 beacons is a fix, without
  // the acquisition over frames that lost-in-space needs when few beacons are in view.
  bool has_initial_pose = false;
  BodyPose initial_pose;
  double initial_sigma_m = 0.01, initial_sigma_rad = 0.0175;  // its 1-sigma errors
  // A reload keeps the track: the last pose seeds the new rig's with these 1-sigma errors
  // (a new calibration moves the solved pose by millimetres and milliradians).
  double reload_sigma_m = 0.01, reload_sigma_rad = 0.01;
  // Windowed detection while tracking (issue 20 item 1; --no-windowed-detection turns it off):
  // with a pose from the last frame set (fix or degraded), each camera's frame is detected only
  // in windows about the pixels of the beacons projected at that pose carried one frame set on
  // at the velocity of the last two (NavLoop::WindowPose: both must be posed, else full frames;
  // half-size below), plus
  // stripe (frame set mod detection_stripes) of DetectionStripe with stripe_margin_px rows of
  // margin, so that every row is scanned once every detection_stripes frame sets (a blob the map
  // does not predict, a reflection, is found within that many, detect.h). Lost or acquiring,
  // or more beacons predicted in a camera than windows allow: full frames.
  bool windowed_detection = true;
  int window_half_px = 48;       // the spot (a few px) plus a change of velocity and the poses' noise,
  double window_sigmas = 3.0;    // plus this many image sigmas of the beacon under the pose's
  int max_window_half_px = 256;  // covariance (SolveResult), up to this half-size in all
  int detection_stripes = 8;
  int stripe_margin_px = 24;
};

enum class StepStatus : unsigned char { kOk = 0, kEndOfStream, kNotStarted };

// The stages of a frame set, timed on the monotonic clock (LoopCounters::stage_*): under QEMU's
// `-icount shift=0` the guest's clock advances 1 ns per instruction, so the same counters are
// the instructions each stage executes on the emulated board (issue 20 item 4).
enum class Stage : unsigned char {
  kAcquire = 0,  // FrameSource::Acquire of every camera: waiting for the frames (live), reading them (replay)
  kDetect,       // blob detection in place, every camera (BlobDetector::Detect, windowed or full)
  kNavigate,     // the clock checks and Navigator::Step (identification, solve, beacon health)
  kPublish,      // pose, blobs, health and beacon-health records to the outputs and the log
  kCount
};
inline constexpr int kNumStages = static_cast<int>(Stage::kCount);
const char* ToString(Stage s);  // "acquire", "detect", "navigate", "publish"

struct CameraSupervision {
  int consecutive_failures = 0;
  bool set_aside = false;
  std::uint64_t set_aside_at = 0;  // frame set index
  std::uint64_t set_asides = 0, resets = 0, reset_failures = 0;
  std::uint16_t blobs_last = 0;
  std::uint64_t detect_errors = 0;  // frames whose detection gave no blob list
  std::uint64_t blank_frames = 0;   // frames with every pixel alike (DetectStatus::kBlankFrame)
  std::uint64_t truncated_frames = 0;  // frames whose lower rows were never written (kTruncatedFrame):
                                       // the blobs above the cut are used, the frame is counted bad
  std::uint64_t saturated_frames = 0;  // frames with a saturated region (BlobList::blind_cells)
  std::uint64_t stale_frames = 0;   // frames stamped no later than the last frame set while another
                                    // camera's was later: dropped for the frame set (DropStaleFrames)
};

struct LoopCounters {
  std::uint64_t frame_sets = 0;
  std::uint64_t fixes = 0, degraded = 0, lost = 0;
  std::uint64_t deadline_slips = 0;
  std::uint64_t worst_frame_set_ns = 0;
  std::uint64_t detect_errors = 0;
  std::uint64_t trigger_errors = 0;
  std::uint64_t clock_faults = 0;  // frame sets stamped no later than the previous one
  std::uint64_t clock_offsets = 0;  // clocks found whole periods behind after a fault (CheckClock)
  // Frame sets stamped more than kStampJumpPeriods periods later than the frame sets since the
  // last good stamp explain, with no frame counted lost meanwhile (drops, missing files,
  // timeouts): the driver clock stepped forward, or the loop stood still that long. The time is
  // kept (it may be real); the health message counts these among its clock_faults.
  std::uint64_t stamp_jumps = 0;
  std::uint64_t windowed_frames = 0;     // frames detected in windows (NavLoopConfig::windowed_detection)
  std::uint64_t windowed_fallbacks = 0;  // tracking, but more beacons predicted than windows: full frame
  std::array<std::uint64_t, static_cast<std::size_t>(NavReason::kCount)> by_reason{};
  // Per stage (index Stage), ns on the monotonic clock: the sum over every frame set, and the
  // largest of one frame set. Acquire counts the wait for a frame as well as its reading.
  std::array<std::uint64_t, kNumStages> stage_total_ns{};
  std::array<std::uint64_t, kNumStages> stage_worst_ns{};
};

// Fills r's blobs from a frame set's observations and the beacon of each (beacon_of_blob[i],
// -1: none): the matched ones first, then the others, each group in list order, as many as the
// message carries; sets r->truncated and r->num_blobs (the header fields are the caller's).
// NavLoop's blobs datagram, and mfns-view's playback (host/view/frame_blobs.h), build it so.
void FillBlobs(const BlobObs* obs, int num_obs, const std::int16_t* beacon_of_blob, BlobsRecord* r);
// One page of beacon health: beacons first .. first + kBeaconHealthPerMessage - 1 (fewer at the
// map's end); the sequence, frame_sets and t_ns are the caller's.
void FillBeaconHealth(const BeaconHealth& health, int first, BeaconHealthRecord* r);

class NavLoop {
 public:
  // rig must outlive the loop. source is driven by the loop; trigger, outputs (every --output:
  // MFNS datagrams, MAVLink) and log may be null.
  NavLoop(const Rig& rig, FrameSource* source, GpioTrigger* trigger, Outputs* outputs, PoseLog* log);

  // Checks the configuration and sizes everything; *why names a problem.
  bool Configure(const NavLoopConfig& config, const char** why);
  // Switches to a new rig (parameter reload) between frame sets; the track is reset, seeded
  // with the last pose (reload_sigma_*) when the last frame set had one.
  bool Reload(const Rig& rig, std::uint64_t generation, const char** why);

  // One frame set. *out (optional) receives the published pose record.
  StepStatus Step(PoseRecord* out = nullptr);

  const LoopCounters& counters() const { return counters_; }
  const CameraSupervision& supervision(int k) const { return supervision_[static_cast<std::size_t>(k)]; }
  const Navigator& navigator() const { return navigator_; }
  // The last frame set's observations (the blobs given to the navigator: its matches index
  // them) and the navigator's outcome (kLost when no camera delivered): for host tools that
  // need the identities with their centroids (mfns-calib survey).
  const BlobObs* observations() const { return obs_.data(); }
  int num_observations() const { return num_obs_; }
  const NavOutput& last_output() const { return nav_; }
  // Camera k's blob list of the last frame set (count 0 when it delivered no usable frame).
  const BlobList& blobs(int k) const { return lists_[static_cast<std::size_t>(k)]; }
  HealthRecord Health() const;

 private:
  bool AcquireAll(std::uint64_t* t_capture_ns, bool* all_ended, std::uint32_t* delivered);
  // The windows of camera k for a frame of width x height at `pose` (windowed_detection): the
  // stripe of this frame set and a window about each beacon projected into the frame; 0 when
  // they do not fit in limits::kMaxDetectWindows (detect the full frame).
  void KeepPoseForWindows(bool any, std::uint64_t t_capture_ns);
  bool WindowPose(BodyPose* pose) const;
  int PlanWindows(int k, int width, int height, const BodyPose& pose);
  std::uint64_t DropStaleFrames(std::uint32_t* delivered_set);
  bool CheckClock(std::uint64_t* t_capture_ns);
  void CarryMissingPeriods(std::uint64_t driver_t_ns);
  void CheckJump(std::uint64_t driver_t_ns);
  std::uint64_t FramesLost() const;
  void Publish(const NavOutput& nav, std::uint64_t t_capture_ns, PoseRecord* out);
  void PublishBlobs(const NavOutput& nav, int num_obs, std::uint64_t t_capture_ns);
  void PublishBeaconHealth();
  const char* FlaggedBeacons();

  const Rig* rig_;
  FrameSource* source_;
  GpioTrigger* trigger_;
  Outputs* outputs_;
  PoseLog* log_;
  NavLoopConfig config_;
  std::array<BlobDetector, limits::kMaxCameras> detectors_;
  std::array<BlobList, limits::kMaxCameras> lists_{};
  std::array<PixelWindow, limits::kMaxDetectWindows> windows_{};  // one camera's, this frame set
  int window_poses_ = 0;  // posed frame sets in a row kept (0..2) for WindowPose
  BodyPose window_last_, window_prev_;
  std::uint64_t window_last_t_ns_ = 0, window_prev_t_ns_ = 0;
  std::array<BlobObs, limits::kMaxObservations> obs_{};
  std::array<std::uint64_t, kNumStages> stage_ns_{};  // this frame set's, per stage (Step folds them in)
  std::array<std::uint64_t, limits::kMaxCameras> stamps_{};  // this frame set's, per camera (0: none)
  int num_obs_ = 0;
  Navigator navigator_;
  NavOutput nav_;
  std::array<CameraSupervision, limits::kMaxCameras> supervision_{};
  LoopCounters counters_;
  std::uint64_t last_t_capture_ns_ = 0;  // stamp given to the last frame set with a frame
  std::uint64_t last_driver_t_ns_ = 0;   // the last good driver stamp (0: none yet)
  int consecutive_clock_faults_ = 0;
  std::uint64_t good_stamp_frame_set_ = 0;   // frame set index of the last good driver stamp
  bool fault_since_good_stamp_ = false;
  std::uint64_t lost_at_good_stamp_ = 0;     // FramesLost() at the last good driver stamp
  std::uint64_t clock_offset_ns_ = 0;        // added to driver stamps: periods the clock lost
  std::uint32_t pose_sequence_ = 0, health_sequence_ = 0, blobs_sequence_ = 0;
  BlobsRecord blobs_record_;                                         // PublishBlobs' message
  std::array<std::int16_t, limits::kMaxObservations> beacon_of_blob_{};  // PublishBlobs' scratch
  BeaconHealthRecord beacon_health_record_;  // PublishBeaconHealth's message
  std::uint32_t beacon_health_sequence_ = 0;
  int beacon_health_first_ = 0;              // the next page's first beacon
  // The log's flagged_beacons cell: "b:state" per flagged beacon, space-separated.
  std::array<char, limits::kMaxBeacons * 20 + 1> flagged_text_{};
};


}  // namespace mfns::fw
