#include "host/sim/navmatrix/navmatrix.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "common/rotation/rotation.h"
#include "firmware/lib/monotonic_clock.h"
#include "host/sim/observe/observe.h"

namespace mfns::host {

fw::NavigatorOptions NavdNavigatorOptions() {
  fw::NavigatorOptions o;
  o.track.solve.sigma_px = 0.15;
  o.track.lis.solve.sigma_px = 0.15;
  return o;
}

bool WrongPose(double position_error_m, double attitude_error_rad, double position_sigma_m, const NavMatrixOptions& o) {
  const double allowed_m = std::max(o.wrong_position_floor_m, o.wrong_position_sigmas * position_sigma_m);
  // A NaN error is wrong too: a published pose must be a number.
  return !(position_error_m <= allowed_m) || !(attitude_error_rad <= o.wrong_attitude_rad);
}

namespace {

// Whether a first fix at first_fix (-1: none in a run of `frames`) came more than max_lag frame
// sets after `from` (-1: nothing to time it from, never late).
bool LateFrom(int from, int first_fix, int frames, int max_lag) {
  if (from < 0) return false;
  if (first_fix >= 0) return first_fix - from > max_lag;
  return frames - 1 - from > max_lag;  // the run went on long enough to fix
}

}  // namespace

bool RunResult::LagExceeds(int max_lag) const { return LateFrom(first_in_view, first_fix, frames, max_lag); }

bool RunResult::HeldLagExceeds(int max_lag) const { return LateFrom(first_held_view, first_fix, frames, max_lag); }

double RunResult::PosedShare() const {
  return eligible_after_fix == 0 ? 1.0 : static_cast<double>(posed_after_fix) / eligible_after_fix;
}

namespace {

void CountPose(const FrameRecord& f, const NavMatrixOptions& o, RunResult* r) {
  const bool wrong = WrongPose(f.position_error_m, f.attitude_error_rad, f.position_sigma_m, o);
  if (f.status == fw::NavStatus::kFix) {
    ++r->fixes;
    r->wrong_fixes += wrong;
    r->worst_fix_position_m = std::max(r->worst_fix_position_m, f.position_error_m);
    r->worst_fix_attitude_rad = std::max(r->worst_fix_attitude_rad, f.attitude_error_rad);
  } else {
    ++r->degraded;
    r->wrong_degraded += wrong;
  }
}

void CountTime(const FrameRecord& f, double frame_period_s, const NavMatrixOptions& o, RunResult* r) {
  r->total_step_s += f.step_s;
  r->worst_step_s = std::max(r->worst_step_s, f.step_s);
  r->slips += f.step_s > frame_period_s;
  r->slow += f.step_s > o.slow_frame_s;
}

}  // namespace

RunResult ScoreRun(const std::vector<FrameRecord>& frames, double frame_period_s, const NavMatrixOptions& o) {
  RunResult r;
  r.frames = static_cast<int>(frames.size());
  long in_view_sum = 0;
  int held = 0;  // frame sets in a row with >= first_fix_in_view in view, up to this one
  for (int i = 0; i < r.frames; ++i) {
    const FrameRecord& f = frames[static_cast<std::size_t>(i)];
    in_view_sum += f.in_view;
    if (r.first_in_view < 0 && f.in_view >= o.first_fix_in_view) r.first_in_view = i;
    held = f.in_view >= o.first_fix_in_view ? held + 1 : 0;
    if (r.first_held_view < 0 && held > 0 && held >= o.held_view_frames) r.first_held_view = i + 1 - held;
    if (r.first_fix < 0 && f.status == fw::NavStatus::kFix) r.first_fix = i;
    const bool posed = f.status != fw::NavStatus::kLost;
    if (r.first_fix >= 0 && f.in_view >= o.posed_in_view) {
      ++r.eligible_after_fix;
      r.posed_after_fix += posed;
    }
    if (posed) CountPose(f, o, &r);
    CountTime(f, frame_period_s, o, &r);
  }
  r.mean_in_view = r.frames == 0 ? 0.0 : static_cast<double>(in_view_sum) / r.frames;
  return r;
}

FrameRecord RecordFrame(int in_view, const fw::NavOutput& out, const BodyPose& truth, double step_s) {
  FrameRecord f;
  f.in_view = in_view;
  f.status = out.status;
  f.reason = out.reason;
  f.source = out.source;
  f.num_beacons = out.num_beacons;
  f.rms_px = out.rms_px;
  f.step_s = step_s;
  if (out.status == fw::NavStatus::kLost) return f;
  f.position_error_m = (out.pose.r_w_wb - truth.r_w_wb).norm();
  f.attitude_error_rad = LogSO3(truth.C_w_b.transpose() * out.pose.C_w_b).norm();
  const auto& P = out.covariance;
  f.position_sigma_m = std::sqrt(std::max({P(0, 0), P(1, 1), P(2, 2), 0.0}));
  return f;
}

namespace {

// Everything a run keeps alive: the navigator holds a reference to the rig, and is too big
// (the tracker's workspaces, ~MB) for a thread's stack, as is NavOutput's match list.
struct NavRun {
  Rig rig;
  fw::Navigator navigator;
  fw::NavOutput out;
};

std::uint32_t DeliveredMask(const BlobFrameSet& b, int num_cameras) {
  std::uint32_t mask = 0;
  for (int k = 0; k < num_cameras; ++k)
    if (b.delivered[static_cast<std::size_t>(k)]) mask |= 1u << k;
  return mask;
}

}  // namespace

RunResult RunNavigation(const Scenario& s, const NavMatrixOptions& o, std::vector<FrameRecord>* frames_out) {
  auto run = std::make_unique<NavRun>();
  run->rig = BelievedRig(s);
  const char* why = nullptr;
  if (!run->navigator.Init(run->rig, o.navigator, &why))
    throw UserError(s.name + ": the navigator refuses the believed rig: " + (why != nullptr ? why : "?"));
  std::vector<FrameRecord> frames;
  frames.reserve(static_cast<std::size_t>(s.frames));
  for (const FrameTruth& f : SimulateTrajectory(s)) {
    const BlobFrameSet b = SimulateBlobs(s, f);
    const std::uint32_t delivered = DeliveredMask(b, run->rig.num_cameras);
    // CPU time: the worst step is compared with a one-core budget, and matrix runs share the
    // machine with other jobs (wall time doubled under a parallel build).
    const std::uint64_t start_ns = fw::ThreadCpuNs();
    run->navigator.Step(b.blobs.data(), static_cast<int>(b.blobs.size()), static_cast<std::uint64_t>(f.t_ns), delivered,
                        /*cameras_down=*/false, &run->out);
    frames.push_back(RecordFrame(b.NumVisible(), run->out, f.pose, 1e-9 * static_cast<double>(fw::ThreadCpuNs() - start_ns)));
    frames.back().num_blobs = static_cast<int>(b.blobs.size());
    for (int k = 0; k < run->rig.num_cameras && k < limits::kMaxCameras; ++k)
      frames.back().in_view_per_camera[static_cast<std::size_t>(k)] =
          static_cast<int>(b.visible[static_cast<std::size_t>(k)].size());
    const fw::TrackResult& tr = run->navigator.last_track();
    frames.back().lis_run = tr.lis_run;
    frames.back().lis_status = tr.lis_status;
    frames.back().acquisition_poses = tr.acquisition_poses;
    if (run->out.status != fw::NavStatus::kLost)
      for (int i = 0; i < run->out.num_matches; ++i) {
        const fw::Match& m = run->out.matches[static_cast<std::size_t>(i)];
        frames.back().wrong_ids += m.blob < 0 || m.blob >= static_cast<int>(b.beacon.size()) ||
                                   b.beacon[static_cast<std::size_t>(m.blob)] != m.beacon;
      }
  }
  RunResult r = ScoreRun(frames, 1.0 / s.frame_rate_hz, o);
  r.counters = run->navigator.counters();
  if (frames_out != nullptr) *frames_out = std::move(frames);
  return r;
}

}  // namespace mfns::host
