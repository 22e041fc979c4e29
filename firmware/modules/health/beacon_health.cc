#include "firmware/modules/health/beacon_health.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>

#include "common/rotation/rotation.h"

namespace mfns::fw {
namespace {

// Predictions farther than this from a camera's optic axis are not judged: the lens model is
// not used beyond it (as the simulator's visibility).
constexpr double kMaxOffAxisRad = 60.0 * 3.14159265358979323846 / 180.0;

std::uint32_t Saturating(std::uint32_t n) { return n == std::numeric_limits<std::uint32_t>::max() ? n : n + 1; }

}  // namespace

const char* ToString(BeaconState s) {
  switch (s) {
    case BeaconState::kOk: return "ok";
    case BeaconState::kInconsistent: return "inconsistent";
    case BeaconState::kMissing: return "missing";
    case BeaconState::kCount: break;
  }
  return "?";
}

bool BeaconHealthOptions::IsValid(const char** why) const {
  const char* bad = nullptr;
  if (!(search_px > 0.0) || !std::isfinite(search_px)) bad = "search_px";
  else if (!(sigma_px > 0.0) || !std::isfinite(sigma_px)) bad = "sigma_px";
  else if (min_observations < 2 || min_observations > limits::kBeaconHealthWindow) bad = "min_observations";
  else if (!(flag_mean_z2 > 2.0) || !std::isfinite(flag_mean_z2)) bad = "flag_mean_z2";
  else if (!(clear_mean_z2 > 0.0) || !(clear_mean_z2 < flag_mean_z2)) bad = "clear_mean_z2";
  else if (!(missing_fraction > 0.0) || !(missing_fraction <= 1.0)) bad = "missing_fraction";
  else if (!(edge_margin_px >= 0.0) || !std::isfinite(edge_margin_px)) bad = "edge_margin_px";
  if (why != nullptr) *why = bad != nullptr ? bad : "ok";
  return bad == nullptr;
}

void BeaconHealth::Window::Push(float z2_value, float residual_m_value) {
  z2[static_cast<std::size_t>(next)] = z2_value;
  residual_m[static_cast<std::size_t>(next)] = residual_m_value;
  next = (next + 1) % limits::kBeaconHealthWindow;
  count = std::min(count + 1, limits::kBeaconHealthWindow);
}

bool BeaconHealth::Reset(const Rig& rig, const BeaconHealthOptions& options) {
  num_beacons_ = 0;
  if (!options.IsValid() || rig.num_beacons <= 0 || rig.num_beacons > limits::kMaxBeacons) return false;
  options_ = options;
  num_beacons_ = rig.num_beacons;
  stats_.fill(BeaconStats{});
  windows_.fill(Window{});
  updates_ = 0;
  flagged_at_.fill(0);
  for (int b = 0; b < num_beacons_; ++b)
    sigma_m_[static_cast<std::size_t>(b)] =
        rig.has_beacon_sigmas ? rig.beacon_sigmas[static_cast<std::size_t>(b)] : rig.beacon_sigma;
  return true;
}

int BeaconHealth::Update(const Rig& rig, const BodyPose& pose, const Eigen::Matrix<double, 6, 6>& covariance,
                         const BlobObs* blobs, int num_blobs, const Match* used, int num_used,
                         std::uint32_t delivered) {
  if (num_beacons_ == 0 || num_blobs < 0 || num_blobs > limits::kMaxObservations || num_used < 0 ||
      num_used > limits::kMaxMatches || !covariance.allFinite())
    return 0;
  // The blob each (camera, beacon) used, and the blobs taken by a used match.
  std::array<bool, limits::kMaxObservations> taken{};
  std::array<std::array<std::int16_t, limits::kMaxBeacons>, limits::kMaxCameras> used_blob;
  for (auto& row : used_blob) row.fill(-1);
  for (int i = 0; i < num_used; ++i) {
    const Match& m = used[i];
    if (m.blob < 0 || m.blob >= num_blobs || m.camera < 0 || m.camera >= rig.num_cameras || m.beacon < 0 ||
        m.beacon >= num_beacons_)
      continue;
    used_blob[static_cast<std::size_t>(m.camera)][static_cast<std::size_t>(m.beacon)] = static_cast<std::int16_t>(m.blob);
    taken[static_cast<std::size_t>(m.blob)] = true;
  }
  int changed = 0;
  for (int k = 0; k < rig.num_cameras; ++k) {
    if ((delivered & (1U << static_cast<unsigned>(k))) == 0) continue;
    for (int b = 0; b < num_beacons_; ++b) {
      Observe(rig, b, k, pose, covariance, blobs, num_blobs, used_blob[static_cast<std::size_t>(k)][static_cast<std::size_t>(b)], taken);
    }
  }
  // At most one beacon turns inconsistent per fix: the one whose residuals are worst. A moved
  // beacon, used by the fixes until it is flagged, bends them, and its neighbours' residuals
  // grow with it (seen: cylinder 128, beacon 84 moved 5 mm; 56 and 79 flagged with it, 0.8-1.0 px,
  // for the rest of the run). So the others' windows, judged against those fixes, start over.
  int flagged = -1;
  double flagged_z2 = 0.0;
  for (int b = 0; b < num_beacons_; ++b) {
    double mean_z2 = 0.0;
    const BeaconState next = Judge(b, &mean_z2);
    if (next == BeaconState::kInconsistent && stats_[static_cast<std::size_t>(b)].state != next) {
      if (flagged < 0 || mean_z2 > flagged_z2) flagged = b, flagged_z2 = mean_z2;
      continue;
    }
    changed += Apply(b, next) ? 1 : 0;
  }
  ++updates_;
  if (flagged < 0) return changed;
  changed += Apply(flagged, BeaconState::kInconsistent) ? 1 : 0;
  flagged_at_[static_cast<std::size_t>(flagged)] = updates_;
  for (int b = 0; b < num_beacons_; ++b) {
    const auto sb = static_cast<std::size_t>(b);
    if (b == flagged) continue;
    // A beacon flagged within the last window may have been judged against fixes this one bent
    // (seen: box 64, beacon 9 flagged 0.7 px off before the moved beacon 14): it starts over too.
    // Once only (its first flag): two beacons both moved would otherwise revoke each other.
    const bool recent = stats_[sb].state == BeaconState::kInconsistent && stats_[sb].flags <= 1 &&
                        updates_ - flagged_at_[sb] < static_cast<std::uint32_t>(limits::kBeaconHealthWindow);
    if (recent) changed += Apply(b, BeaconState::kOk) ? 1 : 0;
    if (stats_[sb].state == BeaconState::kOk) windows_[sb] = Window{};
  }
  return changed;
}

// One camera's view of one beacon: not in view (nothing recorded), seen with a residual, or not seen.
void BeaconHealth::Observe(const Rig& rig, int b, int k, const BodyPose& pose, const Eigen::Matrix<double, 6, 6>& cov,
                           const BlobObs* blobs, int num_blobs, int used_blob,
                           const std::array<bool, limits::kMaxObservations>& taken) {
  const RigCamera& cam = rig.cameras[static_cast<std::size_t>(k)];
  const Eigen::Vector3d& P_w = rig.beacons_w[static_cast<std::size_t>(b)];
  const Eigen::Vector3d p_k = WorldToCamera(cam, pose, P_w);
  if (!(p_k.z() > 0.0) || p_k.head<2>().norm() > std::tan(kMaxOffAxisRad) * p_k.z()) return;
  if (!BeaconFaces(rig, b, pose.C_w_b * cam.r_b_bk + pose.r_w_wb)) return;
  Eigen::Vector2d uv;
  Eigen::Matrix<double, 2, 6> J;
  if (ProjectBeacon(cam, pose, P_w, &uv, &J) != ProjectStatus::kOk || !InImage(cam.intrinsics, uv, options_.edge_margin_px))
    return;
  // Its image: the blob the fix used, else the nearest free blob of the camera within search_px.
  int best = used_blob;
  double best_d = used_blob >= 0 ? (blobs[used_blob].uv_px - uv).norm() : options_.search_px;
  for (int i = 0; used_blob < 0 && i < num_blobs; ++i) {
    if (blobs[i].camera != k || taken[static_cast<std::size_t>(i)]) continue;
    const double d = (blobs[i].uv_px - uv).norm();
    if (d < best_d) best = i, best_d = d;
  }
  BeaconStats& s = stats_[static_cast<std::size_t>(b)];
  s.in_view = Saturating(s.in_view);
  const double px_per_m = cam.intrinsics.alpha_x / p_k.norm();
  Window& w = windows_[static_cast<std::size_t>(b)];
  if (best < 0) {
    w.Push(-1.0F, 0.0F);
    return;
  }
  s.seen = Saturating(s.seen);
  (used_blob >= 0 ? s.used : s.rejected) = Saturating(used_blob >= 0 ? s.used : s.rejected);
  s.sum_residual_px += best_d;
  s.sum_residual2_px2 += best_d * best_d;
  // What the residual should be: centroid noise, the beacon's map error at its range, the pose.
  const double map_px = px_per_m * sigma_m_[static_cast<std::size_t>(b)];
  const Eigen::Matrix2d S = (options_.sigma_px * options_.sigma_px + map_px * map_px) * Eigen::Matrix2d::Identity() +
                            J * cov * J.transpose();
  const Eigen::Vector2d r = blobs[best].uv_px - uv;
  w.Push(static_cast<float>(r.dot(S.ldlt().solve(r))), static_cast<float>(best_d / px_per_m));
}

BeaconState BeaconHealth::Judge(int b, double* mean_z2_out) {
  const Window& w = windows_[static_cast<std::size_t>(b)];
  BeaconStats& s = stats_[static_cast<std::size_t>(b)];
  *mean_z2_out = 0.0;
  if (w.count < options_.min_observations) return s.state;
  s.judged = true;
  int seen = 0;
  double sum_z2 = 0.0;
  for (int i = 0; i < w.count; ++i) {
    const float z2 = w.z2[static_cast<std::size_t>(i)];
    if (z2 < 0.0F) continue;
    ++seen;
    sum_z2 += static_cast<double>(z2);
  }
  const int unseen = w.count - seen;
  const double mean_z2 = seen > 0 ? sum_z2 / seen : 0.0;
  BeaconState next = s.state;
  if (unseen >= options_.missing_fraction * w.count) {
    next = BeaconState::kMissing;
  } else if (seen >= options_.min_observations / 2 && mean_z2 > options_.flag_mean_z2) {
    next = BeaconState::kInconsistent;
  } else if (s.state == BeaconState::kMissing ? unseen * 2 < w.count
                                               : seen >= options_.min_observations / 2 && mean_z2 < options_.clear_mean_z2) {
    next = BeaconState::kOk;
  }
  *mean_z2_out = mean_z2;
  return next;
}

bool BeaconHealth::Apply(int b, BeaconState next) {
  BeaconStats& s = stats_[static_cast<std::size_t>(b)];
  if (next == s.state) return false;
  if (next != BeaconState::kOk) s.flags = Saturating(s.flags);
  s.state = next;
  return true;
}

int BeaconHealth::NumFlagged() const {
  int n = 0;
  for (int b = 0; b < num_beacons_; ++b) n += stats_[static_cast<std::size_t>(b)].state != BeaconState::kOk ? 1 : 0;
  return n;
}

double BeaconHealth::SuggestedSigmaM(int b) const {
  if (b < 0 || b >= num_beacons_ || stats_[static_cast<std::size_t>(b)].state != BeaconState::kInconsistent) return 0.0;
  const Window& w = windows_[static_cast<std::size_t>(b)];
  double sum2 = 0.0;
  int n = 0;
  for (int i = 0; i < w.count; ++i) {
    if (w.z2[static_cast<std::size_t>(i)] < 0.0F) continue;
    const auto r = static_cast<double>(w.residual_m[static_cast<std::size_t>(i)]);
    sum2 += r * r;
    ++n;
  }
  return n > 0 ? std::sqrt(sum2 / n) : 0.0;
}

}  // namespace mfns::fw
