#include "firmware/app/navd/nav_loop.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "common/rotation/rotation.h"

namespace mfns::fw {

namespace {
std::uint32_t Saturate32(std::uint64_t n) { return static_cast<std::uint32_t>(std::min<std::uint64_t>(n, 0xFFFFFFFFu)); }

constexpr std::array<const char*, kNumStages> kStageNames = {"acquire", "detect", "navigate", "publish"};
static_assert(kStageNames.size() == static_cast<std::size_t>(Stage::kCount), "one name per stage");
}  // namespace

const char* ToString(Stage s) {
  const auto i = static_cast<std::size_t>(s);
  return i < kStageNames.size() ? kStageNames[i] : "?";
}

NavLoop::NavLoop(const Rig& rig, FrameSource* source, GpioTrigger* trigger, Outputs* outputs, PoseLog* log)
    : rig_(&rig), source_(source), trigger_(trigger), outputs_(outputs), log_(log) {}

bool NavLoop::Configure(const NavLoopConfig& config, const char** why) {
  const char* reason = nullptr;
  if (!config.detect.IsValid(&reason)) {
  } else if (config.timeout_ms < 1 || !(config.deadline_ms > 0) || !(config.sigma_px > 0) ||
             config.camera_timeouts_to_set_aside < 1 || config.camera_retry_every < 1 || config.health_every < 1) {
    reason = "timeout, deadline, sigma and counts must be positive";
  } else if (source_ == nullptr || source_->num_cameras() != rig_->num_cameras) {
    reason = "the frame source's cameras do not match the rig's";
  } else if (!(config.initial_sigma_m >= 0) || !(config.initial_sigma_rad >= 0) || !(config.reload_sigma_m >= 0) ||
             !(config.reload_sigma_rad >= 0) || !config.initial_pose.r_w_wb.allFinite() ||
             !config.initial_pose.C_w_b.allFinite()) {
    reason = "the initial pose and the pose sigmas must be finite, sigmas >= 0";
  } else if (config.window_half_px < 1 || config.max_window_half_px < config.window_half_px ||
             !(config.window_sigmas >= 0) || config.detection_stripes < 1 || config.stripe_margin_px < 0) {
    reason =
        "window_half_px and detection_stripes must be positive, max_window_half_px >= window_half_px, "
        "window_sigmas and stripe_margin_px >= 0";
  }
  if (reason != nullptr) {
    if (why != nullptr) *why = reason;
    return false;
  }
  config_ = config;
  config_.navigator.track.solve.sigma_px = config.sigma_px;
  config_.navigator.track.lis.solve.sigma_px = config.sigma_px;
  for (BlobDetector& d : detectors_) d = BlobDetector(config_.detect);
  if (!navigator_.Init(*rig_, config_.navigator, why)) return false;
  if (config_.has_initial_pose)
    navigator_.SetInitialPose(config_.initial_pose, config_.initial_sigma_m, config_.initial_sigma_rad);
  return true;
}

bool NavLoop::Reload(const Rig& rig, std::uint64_t generation, const char** why) {
  if (rig.num_cameras != rig_->num_cameras) {
    if (why != nullptr) *why = "the new parameters have a different number of cameras";
    return false;
  }
  BodyPose last;
  const bool had_pose = navigator_.LastPose(&last);
  const bool verified = navigator_.LastVerified();
  const Rig* old = rig_;
  rig_ = &rig;
  const bool ok = navigator_.Init(rig, config_.navigator, why);
  if (!ok) {
    rig_ = old;
    navigator_.Init(*old, config_.navigator, nullptr);
  }
  // Either way the track goes on from the last pose.
  if (had_pose) navigator_.SetInitialPose(last, config_.reload_sigma_m, config_.reload_sigma_rad, verified);
  if (ok) config_.param_generation = generation;
  return ok;
}

int NavLoop::PlanWindows(int k, int width, int height, const BodyPose& pose) {
  const RigCamera& cam = rig_->cameras[static_cast<std::size_t>(k)];
  // The window grows by window_sigmas image sigmas of the beacon under the last pose's
  // covariance (J_uv_pose C J_uv_pose^T), up to max_window_half_px in all.
  const SolveResult& solve = navigator_.last_track().solve;
  const bool has_cov = solve.has_covariance && solve.covariance.allFinite();
  int n = 0;
  const auto stripe = static_cast<int>(counters_.frame_sets % static_cast<std::uint64_t>(config_.detection_stripes));
  windows_[0] = DetectionStripe(width, height, stripe, config_.detection_stripes, config_.stripe_margin_px);
  ++n;
  for (int m = 0; m < rig_->num_beacons; ++m) {
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 6> J;
    if (ProjectBeacon(cam, pose, rig_->beacons_w[static_cast<std::size_t>(m)], &uv, has_cov ? &J : nullptr) !=
        ProjectStatus::kOk)
      continue;
    double grow = 0.0;
    if (has_cov) {
      const Eigen::Matrix2d S = J * solve.covariance * J.transpose();
      grow = config_.window_sigmas * std::sqrt(std::max({S(0, 0), S(1, 1), 0.0}));
    }
    const int half = static_cast<int>(
        std::min(config_.window_half_px + std::ceil(grow), static_cast<double>(config_.max_window_half_px)));
    if (uv.x() < -half || uv.y() < -half || uv.x() > width + half || uv.y() > height + half) continue;
    if (n == limits::kMaxDetectWindows) return 0;
    const int u = static_cast<int>(std::lround(uv.x())), v = static_cast<int>(std::lround(uv.y()));
    windows_[static_cast<std::size_t>(n++)] = PixelWindow{u - half, v - half, u + half + 1, v + half + 1};
  }
  return n;
}

// The last two posed frame sets (windowed detection's prediction); any frame set without a pose
// forgets them.
void NavLoop::KeepPoseForWindows(bool any, std::uint64_t t_capture_ns) {
  if (!any || nav_.status == NavStatus::kLost) {
    window_poses_ = 0;
    return;
  }
  window_prev_ = window_last_;
  window_prev_t_ns_ = window_last_t_ns_;
  window_last_ = nav_.pose;
  window_last_t_ns_ = t_capture_ns;
  window_poses_ = std::min(window_poses_ + 1, 2);
}

// Where the windows go this frame set: the last pose carried one frame set on at the velocity of
// the last two (consecutive frame sets, so the same period). At 1 rad/s a beacon moves ~86 px
// a frame set in a 1600 px camera: beyond window_half_px, which only covers the change of
// velocity, the pose's noise and the spot. Without that velocity (the first pose after a gap
// or an acquisition): false, full frames (seen: a track lost at the first frame set after its
// fix, the beacons 84 px from windows about the last pose).
bool NavLoop::WindowPose(BodyPose* pose) const {
  if (!navigator_.LastPose(pose)) return false;
  const double period_ns = config_.deadline_ms * 1e6;
  if (window_poses_ < 2 || window_last_t_ns_ <= window_prev_t_ns_ ||
      static_cast<double>(window_last_t_ns_ - window_prev_t_ns_) > 1.5 * period_ns)
    return false;
  pose->r_w_wb = window_last_.r_w_wb + (window_last_.r_w_wb - window_prev_.r_w_wb);
  pose->C_w_b = window_last_.C_w_b * (window_prev_.C_w_b.transpose() * window_last_.C_w_b);
  return true;
}

bool NavLoop::AcquireAll(std::uint64_t* t_capture_ns, bool* all_ended, std::uint32_t* delivered_set) {
  num_obs_ = 0;
  BodyPose pose;
  const bool windowed = config_.windowed_detection && WindowPose(&pose);
  *t_capture_ns = 0;
  *delivered_set = 0;
  int ended = 0, delivered = 0;
  for (int k = 0; k < rig_->num_cameras; ++k) {
    const auto ks = static_cast<std::size_t>(k);
    CameraSupervision& sup = supervision_[ks];
    lists_[ks].count = 0;
    stamps_[ks] = 0;
    if (sup.set_aside) {
      // Retry a set-aside camera every camera_retry_every frame sets; the others go on.
      if ((counters_.frame_sets - sup.set_aside_at) % static_cast<std::uint64_t>(config_.camera_retry_every) != 0) continue;
      ++sup.resets;
      if (source_->Reset(k) != SourceStatus::kOk) {
        ++sup.reset_failures;
        continue;
      }
      sup.set_aside = false;
      sup.consecutive_failures = 0;
    }
    FrameView view;
    const std::uint64_t t_acquire = MonotonicNs();
    const SourceStatus s = source_->Acquire(k, config_.timeout_ms, &view);
    stage_ns_[static_cast<std::size_t>(Stage::kAcquire)] += MonotonicNs() - t_acquire;
    if (s == SourceStatus::kEndOfStream) {
      ++ended;
      continue;
    }
    if (s != SourceStatus::kOk) {
      if (++sup.consecutive_failures >= config_.camera_timeouts_to_set_aside && !sup.set_aside) {
        sup.set_aside = true;
        sup.set_aside_at = counters_.frame_sets;
        ++sup.set_asides;
      }
      continue;
    }
    sup.consecutive_failures = 0;
    ++delivered;
    stamps_[ks] = view.t_capture_ns;
    const int num_windows = windowed ? PlanWindows(k, view.width, view.height, pose) : 0;
    if (windowed && num_windows == 0) ++counters_.windowed_fallbacks;
    counters_.windowed_frames += num_windows > 0 ? 1 : 0;
    const CameraIntrinsics* intrinsics = &rig_->cameras[ks].intrinsics;
    const std::uint64_t t_detect = MonotonicNs();
    const DetectStatus d = num_windows > 0
                               ? detectors_[ks].Detect(view, intrinsics, windows_.data(), num_windows, &lists_[ks])
                               : detectors_[ks].Detect(view, intrinsics, &lists_[ks]);
    stage_ns_[static_cast<std::size_t>(Stage::kDetect)] += MonotonicNs() - t_detect;
    source_->Release(k);
    if (d == DetectStatus::kBlankFrame) {
      ++sup.blank_frames;  // no information (a stuck sensor): as if the camera had not delivered
      continue;
    }
    if (d == DetectStatus::kTruncatedFrame) ++sup.truncated_frames;  // its blobs above the cut are sound
    if (d != DetectStatus::kOk && d != DetectStatus::kBlobLimit && d != DetectStatus::kTruncatedFrame) {
      ++counters_.detect_errors;  // no usable blob list: as if the camera had not delivered
      ++sup.detect_errors;
      continue;
    }
    const BlobList& list = lists_[ks];
    sup.saturated_frames += list.counters.saturated_frames;
    // Delivered, with the cells where it could not have seen a beacon (saturated, unwritten):
    // the beacons predicted there are not missing (match.h).
    *delivered_set |= (std::uint32_t{1} << k) | BlindCellBits(k, list.blind_cells);
    sup.blobs_last = static_cast<std::uint16_t>(list.count);
    for (int i = 0; i < list.count && num_obs_ < limits::kMaxObservations; ++i) {
      const Blob& b = list.blobs[static_cast<std::size_t>(i)];
      if (!b.normalised_ok) continue;
      BlobObs& o = obs_[static_cast<std::size_t>(num_obs_++)];
      o.camera = k;
      o.uv_px = b.uv_px;
      o.x_n = b.x_n;
      o.flux = static_cast<float>(b.flux_dn);
    }
  }
  *all_ended = ended > 0 && delivered == 0;
  *t_capture_ns = DropStaleFrames(delivered_set);
  return delivered > 0;
}

void NavLoop::Publish(const NavOutput& nav, std::uint64_t t_capture_ns, PoseRecord* out) {
  PoseRecord r;
  r.sequence = pose_sequence_++;
  r.frame_set = static_cast<std::uint32_t>(counters_.frame_sets);
  r.t_capture_ns = t_capture_ns;
  r.param_generation = config_.param_generation;
  r.status = nav.status;
  r.reason = nav.reason;
  r.num_cameras = static_cast<std::uint8_t>(rig_->num_cameras);
  r.num_beacons = static_cast<std::uint8_t>(std::min(nav.num_beacons, 255));
  for (int k = 0; k < rig_->num_cameras; ++k)
    r.beacons_per_camera[static_cast<std::size_t>(k)] =
        static_cast<std::uint8_t>(std::min(nav.beacons_per_camera[static_cast<std::size_t>(k)], 255));
  if (nav.status == NavStatus::kLost) {
    // No pose this frame set: NaN (MAVLink's "unknown"), never the last pose's numbers, so a
    // reader that ignores the status cannot mistake a lost row for a fix.
    constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
    r.r_w_wb.setConstant(kNan);
    r.q_w_b.coeffs().setConstant(kNan);
    r.euler_deg.setConstant(std::numeric_limits<float>::quiet_NaN());
    r.residual_rms_px = 0.0f;
    r.covariance.setConstant(kNan);
  } else {
    r.r_w_wb = nav.pose.r_w_wb;
    r.q_w_b = Eigen::Quaterniond(nav.pose.C_w_b).normalized();
    const EulerAngles e = MatrixToEuler(nav.pose.C_w_b.transpose());
    r.euler_deg = Eigen::Vector3f(static_cast<float>(RadToDeg(e.phi)), static_cast<float>(RadToDeg(e.theta)),
                                  static_cast<float>(RadToDeg(e.psi)));
    r.residual_rms_px = static_cast<float>(nav.rms_px);
    r.covariance = nav.covariance;
  }
  r.t_publish_ns = MonotonicNs();
  if (outputs_ != nullptr) outputs_->Pose(r);
  if (log_ != nullptr && log_->is_open()) log_->Write(r, FlaggedBeacons());
  if (out != nullptr) *out = r;
}

// The frame set's blobs with the beacons the published pose matched them to (viewers: the
// BlobsMessage): matched blobs first, then the others, as many as the message carries.
void NavLoop::PublishBlobs(const NavOutput& nav, int num_obs, std::uint64_t t_capture_ns) {
  BlobsRecord& r = blobs_record_;
  r.sequence = blobs_sequence_++;
  r.frame_set = static_cast<std::uint32_t>(counters_.frame_sets);
  r.t_capture_ns = t_capture_ns;
  r.num_cameras = static_cast<std::uint8_t>(rig_->num_cameras);
  const int n = std::clamp(num_obs, 0, limits::kMaxObservations);
  std::fill(beacon_of_blob_.begin(), beacon_of_blob_.begin() + n, std::int16_t{-1});
  const int num_matches = nav.status == NavStatus::kLost ? 0 : std::min(nav.num_matches, limits::kMaxMatches);
  for (int m = 0; m < num_matches; ++m) {
    const Match& match = nav.matches[static_cast<std::size_t>(m)];
    if (match.blob >= 0 && match.blob < n) beacon_of_blob_[static_cast<std::size_t>(match.blob)] = static_cast<std::int16_t>(match.beacon);
  }
  FillBlobs(obs_.data(), n, beacon_of_blob_.data(), &r);
  outputs_->Blobs(r);
}

void FillBlobs(const BlobObs* obs, int num_obs, const std::int16_t* beacon_of_blob, BlobsRecord* r) {
  r->num_blobs = 0;
  for (const bool matched : {true, false})
    for (int i = 0; i < num_obs && r->num_blobs < limits::kMaxBlobsInMessage; ++i) {
      if ((beacon_of_blob[i] >= 0) != matched) continue;
      const BlobObs& o = obs[i];
      r->blobs[static_cast<std::size_t>(r->num_blobs++)] = BlobEntry{
          static_cast<std::uint8_t>(o.camera), beacon_of_blob[i], static_cast<float>(o.uv_px.x()), static_cast<float>(o.uv_px.y())};
    }
  r->truncated = r->num_blobs < num_obs;
}

void FillBeaconHealth(const BeaconHealth& health, int first, BeaconHealthRecord* r) {
  r->map_beacons = static_cast<std::uint16_t>(health.num_beacons());
  r->flagged = static_cast<std::uint16_t>(health.NumFlagged());
  r->first = static_cast<std::uint16_t>(std::clamp(first, 0, health.num_beacons()));
  r->num_entries = std::min(limits::kBeaconHealthPerMessage, health.num_beacons() - r->first);
  for (int i = 0; i < r->num_entries; ++i) {
    const int b = r->first + i;
    const BeaconStats& s = health.stats(b);
    BeaconHealthEntry& e = r->entries[static_cast<std::size_t>(i)];
    e.beacon = static_cast<std::uint16_t>(b);
    e.state = static_cast<std::uint8_t>(s.state);
    e.judged = s.judged;
    e.in_view = s.in_view;
    e.seen = s.seen;
    e.used = s.used;
    e.rejected = s.rejected;
    e.mean_residual_px = static_cast<float>(s.MeanResidualPx());
    e.rms_residual_px = static_cast<float>(s.RmsResidualPx());
    e.suggested_sigma_mm = static_cast<float>(1e3 * health.SuggestedSigmaM(b));
  }
}

// The next page of the beacons' health, after each health message: every beacon within
// ceil(beacons / kBeaconHealthPerMessage) health periods.
void NavLoop::PublishBeaconHealth() {
  const BeaconHealth& health = navigator_.beacon_health();
  if (health.num_beacons() == 0) return;
  BeaconHealthRecord& r = beacon_health_record_;
  r.sequence = beacon_health_sequence_++;
  r.frame_sets = Saturate32(counters_.frame_sets);
  r.t_ns = MonotonicNs();
  FillBeaconHealth(health, beacon_health_first_, &r);
  outputs_->BeaconHealth(r);
  beacon_health_first_ += limits::kBeaconHealthPerMessage;
  if (beacon_health_first_ >= health.num_beacons()) beacon_health_first_ = 0;
}

// "b:state b:state ..." of the flagged beacons ("" when none), for the log.
const char* NavLoop::FlaggedBeacons() {
  const BeaconHealth& health = navigator_.beacon_health();
  std::size_t at = 0;
  flagged_text_[0] = '\0';
  const int beacons = health.NumFlagged() > 0 ? health.num_beacons() : 0;
  for (int b = 0; b < beacons; ++b) {
    const BeaconState state = health.stats(b).state;
    if (state == BeaconState::kOk) continue;
    const int n = std::snprintf(flagged_text_.data() + at, flagged_text_.size() - at, "%s%d:%s", at > 0 ? " " : "", b,
                                ToString(state));
    if (n < 0 || static_cast<std::size_t>(n) >= flagged_text_.size() - at) break;  // cannot happen: sized for all
    at += static_cast<std::size_t>(n);
  }
  return flagged_text_.data();
}

HealthRecord NavLoop::Health() const {
  HealthRecord h;
  h.sequence = health_sequence_;
  h.frame_sets = Saturate32(counters_.frame_sets);
  h.t_ns = MonotonicNs();
  h.param_generation = config_.param_generation;
  h.fixes = Saturate32(counters_.fixes);
  h.degraded = Saturate32(counters_.degraded);
  h.lost = Saturate32(counters_.lost);
  h.deadline_slips = Saturate32(counters_.deadline_slips);
  h.worst_frame_set_us = Saturate32(counters_.worst_frame_set_ns / 1000);
  h.num_cameras = static_cast<std::uint8_t>(rig_->num_cameras);
  for (int k = 0; k < rig_->num_cameras; ++k) {
    const auto ks = static_cast<std::size_t>(k);
    const SourceCounters& c = source_->counters(k);
    CameraHealth& ch = h.cameras[ks];
    ch.state = supervision_[ks].set_aside ? 1 : 0;
    ch.frames = Saturate32(c.frames);
    ch.drops = Saturate32(c.drops + c.missing_files);
    ch.timeouts = Saturate32(c.timeouts);
    ch.errors = Saturate32(c.driver_errors);
    ch.bad_frames = Saturate32(c.error_buffers + c.short_buffers + c.unknown_clock + c.bad_files +
                               supervision_[ks].blank_frames + supervision_[ks].stale_frames +
                               supervision_[ks].truncated_frames);
    ch.detect_errors = Saturate32(supervision_[ks].detect_errors);
    ch.blobs_last = supervision_[ks].blobs_last;
  }
  h.clock_faults = Saturate32(counters_.clock_faults + counters_.stamp_jumps);
  h.log_errors = log_ != nullptr ? Saturate32(log_->counters().log_errors) : 0;
  h.trigger_errors = Saturate32(counters_.trigger_errors);
  return h;
}

// The frame set's stamp: the earliest of its cameras'. A camera whose stamp is no later than
// the last good one while another camera's is later delivered an old frame (a buffer left in
// its queue, a driver that restamped): its blobs are of another pose, so its frame is dropped
// for this frame set (the camera counts as silent, stale_frames) and the others go on. When
// every camera is stale the clock itself went back: CheckClock's clock fault.
std::uint64_t NavLoop::DropStaleFrames(std::uint32_t* delivered_set) {
  const auto stale = [&](std::size_t k) { return last_driver_t_ns_ != 0 && stamps_[k] <= last_driver_t_ns_; };
  std::uint64_t earliest = 0, earliest_fresh = 0;
  for (std::size_t k = 0; k < static_cast<std::size_t>(rig_->num_cameras); ++k) {
    if (stamps_[k] == 0) continue;
    earliest = earliest == 0 ? stamps_[k] : std::min(earliest, stamps_[k]);
    if (!stale(k)) earliest_fresh = earliest_fresh == 0 ? stamps_[k] : std::min(earliest_fresh, stamps_[k]);
  }
  if (earliest_fresh == 0 || earliest_fresh == earliest) return earliest;
  int kept = 0;
  for (int i = 0; i < num_obs_; ++i) {
    const BlobObs& o = obs_[static_cast<std::size_t>(i)];
    if (!stale(static_cast<std::size_t>(o.camera))) obs_[static_cast<std::size_t>(kept++)] = o;
  }
  num_obs_ = kept;
  for (std::size_t k = 0; k < static_cast<std::size_t>(rig_->num_cameras); ++k) {
    const std::uint32_t bit = std::uint32_t{1} << k;
    if (stamps_[k] == 0 || !stale(k) || (*delivered_set & bit) == 0) continue;  // (blank: counted)
    *delivered_set &= ~bit;
    ++supervision_[k].stale_frames;
  }
  return earliest_fresh;
}

// A frame set stamped no later than the previous one (a repeated or backward driver clock)
// cannot be placed in time: its motion since the last pose would read as none, and tracking
// would refute the true pose (seen: a repeated timestamp lost the track for 23 frame sets).
// It is counted and stamped one nominal frame period (deadline_ms) after the previous frame
// set; the next good stamp is compared with the last good one, not with that estimate (which
// may run ahead of it by the difference of the periods), and kept after the estimate.
// After kClockRebaseFaults such frame sets in a row the clock itself went back (a driver
// restart): its time is taken as it is, and the track is seeded again from the last pose.
bool NavLoop::CheckClock(std::uint64_t* t_capture_ns) {
  constexpr int kClockRebaseFaults = 3;
  const std::uint64_t driver_t = *t_capture_ns;
  const bool fault = last_driver_t_ns_ != 0 && driver_t <= last_driver_t_ns_;
  consecutive_clock_faults_ = fault ? consecutive_clock_faults_ + 1 : 0;
  if (fault) ++counters_.clock_faults;
  if (fault && consecutive_clock_faults_ >= kClockRebaseFaults) {
    consecutive_clock_faults_ = 0;
    BodyPose last;
    if (navigator_.LastPose(&last)) navigator_.SetInitialPose(last, config_.reload_sigma_m, config_.reload_sigma_rad);
    last_driver_t_ns_ = driver_t;
    good_stamp_frame_set_ = counters_.frame_sets;
    fault_since_good_stamp_ = false;
    clock_offset_ns_ = 0;  // a new clock: nothing owed to the old one
  } else if (fault) {
    *t_capture_ns = last_t_capture_ns_ + static_cast<std::uint64_t>(config_.deadline_ms * 1e6);
    fault_since_good_stamp_ = true;
  } else {
    if (fault_since_good_stamp_) CarryMissingPeriods(driver_t);
    else CheckJump(driver_t);
    last_driver_t_ns_ = driver_t;
    lost_at_good_stamp_ = FramesLost();
    good_stamp_frame_set_ = counters_.frame_sets;
    fault_since_good_stamp_ = false;
    *t_capture_ns = driver_t + clock_offset_ns_;
    if (*t_capture_ns <= last_t_capture_ns_) *t_capture_ns = last_t_capture_ns_ + 1;
  }
  last_t_capture_ns_ = *t_capture_ns;
  return fault;
}

// The first good stamp after clock faults: a clock that repeated a stamp and stays behind
// (every later stamp whole periods early) shows as less time since the last good stamp than
// the frame sets since. Kept as it is, the frame set after the fault would be stamped right
// after the fault's estimate, no motion across it, and the track lost (found by the soak). The
// missing whole periods are carried from now on as a clock offset. Frame sets are counted by
// index, so one in which no camera delivered still counts (its time passed). More time than
// frame sets (frames dropped meanwhile) is real time and changes nothing.
void NavLoop::CarryMissingPeriods(std::uint64_t driver_t_ns) {
  const double period_ns = config_.deadline_ms * 1e6;
  const double expected_ns = static_cast<double>(counters_.frame_sets - good_stamp_frame_set_) * period_ns;
  const double elapsed_ns = static_cast<double>(driver_t_ns - last_driver_t_ns_);
  const long missing = std::lround((expected_ns - elapsed_ns) / period_ns);  // <= frame sets since
  if (missing < 1) return;
  clock_offset_ns_ += static_cast<std::uint64_t>(missing) * static_cast<std::uint64_t>(period_ns);
  ++counters_.clock_offsets;
}

// A good stamp far later than the frame sets since the last one explain, while no camera
// counted a frame lost: nothing the loop saw accounts for the time (a clock stepped forward, or
// the loop itself stood still). Counted, not corrected: the time may be real, and a gap only
// widens the tracker's motion bounds, it never bends a pose. kStampJumpPeriods leaves room for
// a late frame (jitter of a period or two).
void NavLoop::CheckJump(std::uint64_t driver_t_ns) {
  constexpr double kStampJumpPeriods = 3.0;
  if (last_driver_t_ns_ == 0 || FramesLost() != lost_at_good_stamp_) return;
  const double period_ns = config_.deadline_ms * 1e6;
  const double expected_ns = static_cast<double>(counters_.frame_sets - good_stamp_frame_set_) * period_ns;
  if (static_cast<double>(driver_t_ns - last_driver_t_ns_) > expected_ns + kStampJumpPeriods * period_ns)
    ++counters_.stamp_jumps;
}

// Frames the cameras are known to have lost so far (sequence gaps, missing replay files,
// timeouts): time that passed without a frame set for it.
std::uint64_t NavLoop::FramesLost() const {
  std::uint64_t n = 0;
  for (int k = 0; k < rig_->num_cameras; ++k) {
    const SourceCounters& c = source_->counters(k);
    n += c.drops + c.missing_files + c.timeouts;
  }
  return n;
}

StepStatus NavLoop::Step(PoseRecord* out) {
  if (trigger_ != nullptr && trigger_->enabled()) {
    const TriggerStatus t = trigger_->Fire();
    if (t != TriggerStatus::kOk) ++counters_.trigger_errors;
  }
  std::uint64_t t_capture_ns = 0;
  bool all_ended = false;
  std::uint32_t delivered = 0;
  stage_ns_.fill(0);
  const bool any = AcquireAll(&t_capture_ns, &all_ended, &delivered);
  if (all_ended) return StepStatus::kEndOfStream;
  const std::uint64_t t_start = MonotonicNs();
  // A fix from fewer cameras than the rig's (one set aside, or silent in this frame set, e.g.
  // while a set-aside camera is retried) is degraded.
  const std::uint32_t all = (std::uint32_t{1} << rig_->num_cameras) - 1U;
  bool cameras_down = (delivered & all) != all;
  for (int k = 0; k < rig_->num_cameras; ++k) cameras_down = cameras_down || supervision_[static_cast<std::size_t>(k)].set_aside;
  if (any) {
    const bool clock_fault = CheckClock(&t_capture_ns);
    navigator_.Step(obs_.data(), num_obs_, t_capture_ns, delivered, cameras_down, &nav_);
    // The pose is sound but its time an estimate: not a fix.
    if (clock_fault && nav_.status == NavStatus::kFix) {
      nav_.status = NavStatus::kDegraded;
      nav_.reason = NavReason::kClockFault;
    }
  } else {
    nav_.status = NavStatus::kLost;
    nav_.reason = NavReason::kNoFrames;
    nav_.num_beacons = 0;
    nav_.beacons_per_camera.fill(0);
  }
  KeepPoseForWindows(any, t_capture_ns);
  const std::uint64_t t_publish = MonotonicNs();
  stage_ns_[static_cast<std::size_t>(Stage::kNavigate)] = t_publish - t_start;
  Publish(nav_, t_capture_ns, out);
  if (outputs_ != nullptr && outputs_->wants_health()) PublishBlobs(nav_, any ? num_obs_ : 0, t_capture_ns);
  switch (nav_.status) {
    case NavStatus::kFix: ++counters_.fixes; break;
    case NavStatus::kDegraded: ++counters_.degraded; break;
    case NavStatus::kLost: ++counters_.lost; break;
  }
  ++counters_.by_reason[static_cast<std::size_t>(nav_.reason)];
  const std::uint64_t elapsed = MonotonicNs() - t_start;
  counters_.worst_frame_set_ns = std::max(counters_.worst_frame_set_ns, elapsed);
  if (static_cast<double>(elapsed) > config_.deadline_ms * 1e6) ++counters_.deadline_slips;
  ++counters_.frame_sets;
  if (counters_.frame_sets % static_cast<std::uint64_t>(config_.health_every) == 0 && outputs_ != nullptr &&
      outputs_->wants_health()) {
    outputs_->Health(Health());
    ++health_sequence_;
    PublishBeaconHealth();
  }
  stage_ns_[static_cast<std::size_t>(Stage::kPublish)] = MonotonicNs() - t_publish;
  for (std::size_t i = 0; i < stage_ns_.size(); ++i) {
    counters_.stage_total_ns[i] += stage_ns_[i];
    counters_.stage_worst_ns[i] = std::max(counters_.stage_worst_ns[i], stage_ns_[i]);
  }
  return StepStatus::kOk;
}

}  // namespace mfns::fw
