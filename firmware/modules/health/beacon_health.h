// Beacon health (issue 16 item 3): is every beacon of the map still where the map says, and lit?
//
// After each published fix, every beacon the pose says a delivered camera sees (in front,
// inside the image, facing the camera) is looked for among that camera's blobs: the nearest
// blob within `search_px` of its prediction is its image. Per beacon this counts, since start:
// in view, seen (a blob near it), used (in the fix's matches), rejected (seen but not used: an
// outlier, or left out by identification), and the residual (px) of every seen observation
// (mean and RMS). Its last limits::kBeaconHealthWindow in-view observations are judged:
//   - kInconsistent: the residuals, normalised by what they should be (centroid noise, the
//     beacon's own map sigma at its range, the pose's covariance projected into the image),
//     have a mean square above `flag_mean_z2` (a chi-square of 2 per observation is expected):
//     the beacon moved, or a reflection sits where it should be. It clears below `clear_mean_z2`.
//     The map sigma in that normalisation is the beacon's at Reset, so down-weighting a beacon
//     (which inflates its sigma in the navigator's rig) does not clear it.
//   - kMissing: no blob near it in at least `missing_fraction` of the window (dead, or occluded
//     for a while); it clears when it is seen again in most of the window.
// Both need `min_observations` in-view observations in the window. At most one beacon turns
// inconsistent per update, the worst; the windows of the beacons still ok then start over (they
// were judged against fixes the flagged beacon bent), and so do beacons flagged inconsistent
// within the last window of updates (back to ok: flagged on such fixes, before the bad one). The navigator down-weights an
// inconsistent beacon (its map sigma inflated to what its residuals show, SuggestedSigmaM) and
// reports every flagged one (health datagram, --log).
//
// Frames: pose is the body in the world (common/rig/rig.h); covariance of PoseDelta (m^2, rad^2)
// as published. Units: px, m. Fixed storage (about 100 bytes per beacon), no heap.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "common/limits.h"
#include "common/rig/rig.h"
#include "firmware/modules/solve/observation.h"

namespace mfns::fw {

enum class BeaconState : std::uint8_t {
  kOk = 0,         // consistent, or not judged yet (see BeaconStats::judged)
  kInconsistent,   // residuals larger than the noise and map allow: moved, or a reflection
  kMissing,        // in view but not seen: dead, or occluded for a while
  kCount
};
inline constexpr int kNumBeaconStates = static_cast<int>(BeaconState::kCount);
const char* ToString(BeaconState s);  // "ok", "inconsistent", "missing"

struct BeaconHealthOptions {
  double search_px = 12.0;       // a blob this near a beacon's prediction is its image (px)
  double sigma_px = 0.3;         // blob centroid noise, px 1-sigma per axis
  int min_observations = 8;      // in-view observations in the window before a beacon is judged
  double flag_mean_z2 = 16.0;    // mean normalised squared residual that flags (expected: 2)
  double clear_mean_z2 = 6.0;    // ... and below which a flagged beacon is clear again
  double missing_fraction = 0.8; // unseen share of the window that reports a beacon missing
  double edge_margin_px = 8.0;   // predictions nearer the image edge than this are not judged
  bool IsValid(const char** why = nullptr) const;
};

struct BeaconStats {
  std::uint32_t in_view = 0, seen = 0, used = 0, rejected = 0;  // since start (saturating)
  double sum_residual_px = 0.0, sum_residual2_px2 = 0.0;          // over the seen observations
  BeaconState state = BeaconState::kOk;
  bool judged = false;       // it had min_observations in its window at least once
  std::uint32_t flags = 0;   // times it turned inconsistent or missing
  double MeanResidualPx() const { return seen > 0 ? sum_residual_px / seen : 0.0; }
  double RmsResidualPx() const { return seen > 0 ? std::sqrt(sum_residual2_px2 / seen) : 0.0; }
};

class BeaconHealth {
 public:
  // Forgets everything; false (and unusable) on bad options or a rig without beacons.
  bool Reset(const Rig& rig, const BeaconHealthOptions& options);
  // One published fix of a frame set: its pose and covariance (PoseDelta, m^2/rad^2), the frame
  // set's blobs, the matches the fix used, and the delivered cameras (bit k: camera k delivered a
  // frame; the others are not judged). The rig must be Reset's (its positions and cameras;
  // the sigmas are Reset's copy). Blobs that a used match names are the image of that beacon
  // only. Returns how many beacons changed state.
  int Update(const Rig& rig, const BodyPose& pose, const Eigen::Matrix<double, 6, 6>& covariance,
             const BlobObs* blobs, int num_blobs, const Match* used, int num_used, std::uint32_t delivered);

  const BeaconStats& stats(int beacon) const { return stats_[static_cast<std::size_t>(beacon)]; }
  int num_beacons() const { return num_beacons_; }
  // Beacons whose state is not kOk now.
  int NumFlagged() const;
  // The map sigma (m per coordinate) that explains an inconsistent beacon's residuals: its RMS
  // residual over the window seen at its mean range (0 when not inconsistent).
  double SuggestedSigmaM(int beacon) const;

 private:
  // The last in-view observations of one beacon (a ring).
  struct Window {
    std::array<float, limits::kBeaconHealthWindow> z2{};          // normalised; < 0: not seen
    std::array<float, limits::kBeaconHealthWindow> residual_m{};  // residual over px per metre
    int next = 0, count = 0;
    void Push(float z2_value, float residual_m_value);
  };
  void Observe(const Rig& rig, int beacon, int camera, const BodyPose& pose, const Eigen::Matrix<double, 6, 6>& cov,
               const BlobObs* blobs, int num_blobs, int used_blob, const std::array<bool, limits::kMaxObservations>& taken);
  // The state its window says (*mean_z2: of its seen observations); Apply sets it (true: changed).
  BeaconState Judge(int beacon, double* mean_z2);
  bool Apply(int beacon, BeaconState next);

  BeaconHealthOptions options_;
  int num_beacons_ = 0;
  std::array<BeaconStats, limits::kMaxBeacons> stats_{};
  std::array<Window, limits::kMaxBeacons> windows_{};
  std::array<double, limits::kMaxBeacons> sigma_m_{};  // each beacon's map sigma at Reset
  std::uint32_t updates_ = 0;                              // Update calls since Reset
  std::array<std::uint32_t, limits::kMaxBeacons> flagged_at_{};  // updates_ when it turned inconsistent
};

}  // namespace mfns::fw
