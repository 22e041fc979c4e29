// Beacon map reprojection and gated one-to-one matching of predicted beacons to blobs, shared
// by lost-in-space (hypothesis scoring) and tracking.
//
// Visibility model: beacon m is predicted in camera k when it faces the camera (the rig's
// optional beacon facing, widened by facing_margin_rad), is in front of the camera,
// inside the camera's view cone (the cone through the image corners, so that the distortion
// polynomial is never used where it may fold back) and its image falls inside the image grown
// by the gate. It is predicted "well inside" when its image is at least miss_margin_px inside
// the image and faces the camera by facing_margin_rad inside its beam (an LED seen at the rim of
// its beam is dim and may go undetected); such a beacon with no blob matched counts as missing.
// A beacon whose beam is unknown (half-angle pi, common/rig/infer_facing.h) never counts as
// missing: an LED at an unknown angle may be out of its beam. Nor does one predicted in a blind
// cell of its camera (the camera set below; MatchOptions::skip_blind_cells): the detector could
// not have seen it there.
//
// Matching: each predicted beacon takes its nearest blob of that camera within gate_px;
// conflicts are resolved greedily by distance so that every blob and every (camera, beacon)
// is used at most once. With reject_ambiguous, a beacon with a second blob inside the gate is
// not matched at all.
//
// No heap; work bounded by beacons x blobs per camera.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "common/limits.h"
#include "common/rig/rig.h"
#include "firmware/lib/frame.h"
#include "firmware/modules/solve/observation.h"

namespace mfns::fw {

// A camera set, per frame set: bit k (k < limits::kMaxCameras) set when camera k delivered a
// frame; bit BlindCellBit(k, c) set when cell c (firmware/lib/frame.h BlindCellOf) of camera k's
// frame is blind, where its detector could not have seen a blob (BlobList::blind_cells: a
// saturated region, rows never written). One word, so that the blind cells travel with their
// frame set wherever the tracker and lost-in-space pass the set (unchanged) to the matcher.
inline constexpr std::uint32_t kAllCameras = (std::uint32_t{1} << limits::kMaxCameras) - 1U;  // none blind
inline constexpr int BlindCellBit(int camera, int cell) {
  return limits::kMaxCameras + camera * limits::kBlindCells + cell;
}
// The camera set's bits for camera k's blind cells (bit c: cell c, as BlobList::blind_cells).
inline constexpr std::uint32_t BlindCellBits(int camera, std::uint32_t cells) {
  return (cells & ((std::uint32_t{1} << limits::kBlindCells) - 1U)) << BlindCellBit(camera, 0);
}

struct MatchOptions {
  double gate_px = 10.0;          // largest blob-to-prediction distance of a match (> 0)
  double miss_margin_px = 15.0;   // "well inside the image" margin for missing beacons (>= 0)
  bool reject_ambiguous = false;  // drop beacons with two blobs inside the gate
  double facing_margin_rad = 0.1;  // beam rim: predicted within +margin, missing within -margin
  // A beacon predicted in a blind cell of the camera set (SetBlobs) is not missing. True where a
  // track is followed; mfns-navd's lost-in-space turns it off (Navigator::Init): with no track,
  // the missing beacons are what tells a pose from its twins.
  bool skip_blind_cells = true;
  // A missing beacon whose prediction has a free blob (one this pose matched to no beacon)
  // within this distance is also counted in MatchList::num_near_missing (0: not counted): a
  // beacon moved since the survey leaves its blob beyond the tight gate, a wrong pose mostly
  // leaves nothing there. Each free blob excuses one beacon.
  double near_miss_px = 0.0;

  bool IsValid(const char** why = nullptr) const;
};

// The matches of one pose hypothesis and how well it explains the blobs; kCapacity matches
// at most (MatchSet: every possible one; lost-in-space keeps many hypotheses in shorter lists).
template <int kCapacity>
struct MatchList {
  int num_matches = 0;
  std::array<Match, static_cast<std::size_t>(kCapacity)> matches{};
  BeaconSet beacons;          // beacons matched in some camera
  int num_beacons = 0;        // distinct matched beacons
  int num_predicted = 0;      // (camera, beacon) pairs predicted inside the image
  int num_missing = 0;        // predicted well inside with no blob matched
  int num_near_missing = 0;   // of those, with a free blob within MatchOptions::near_miss_px
  double sum_sq_px = 0.0;     // sum of squared match distances

  // Matched observations minus miss_weight per missing beacon.
  double Score(double miss_weight) const { return num_matches - miss_weight * num_missing; }
  // Beacon of blob i in this set, or -1.
  int BeaconOfBlob(int blob) const {
    for (int i = 0; i < num_matches; ++i)
      if (matches[static_cast<std::size_t>(i)].blob == blob) return matches[static_cast<std::size_t>(i)].beacon;
    return -1;
  }
  // Appends m and counts its beacon; false (nothing changed) when m's blob is already matched
  // or the list is full.
  bool Add(const Match& m) {
    if (num_matches >= kCapacity || BeaconOfBlob(m.blob) >= 0) return false;
    matches[static_cast<std::size_t>(num_matches++)] = m;
    beacons.Set(m.beacon);
    num_beacons = beacons.Count();
    return true;
  }
  // Keeps the matches for which keep(index, match) is true, in order, and recounts the
  // beacons (num_predicted, num_missing, num_near_missing and sum_sq_px stay as they were).
  template <class Keep>
  void Retain(Keep keep) {
    int n = 0;
    beacons.Reset();
    for (int i = 0; i < num_matches; ++i) {
      if (!keep(i, matches[static_cast<std::size_t>(i)])) continue;
      matches[static_cast<std::size_t>(n)] = matches[static_cast<std::size_t>(i)];
      beacons.Set(matches[static_cast<std::size_t>(n)].beacon);
      ++n;
    }
    num_matches = n;
    num_beacons = beacons.Count();
  }
  // Copies another list, truncated to this capacity (the statistics are kept as they were).
  template <int kOther>
  void CopyFrom(const MatchList<kOther>& o) {
    num_matches = o.num_matches < kCapacity ? o.num_matches : kCapacity;
    for (int i = 0; i < num_matches; ++i) matches[static_cast<std::size_t>(i)] = o.matches[static_cast<std::size_t>(i)];
    beacons = o.beacons;
    num_beacons = o.num_beacons;
    num_predicted = o.num_predicted;
    num_missing = o.num_missing;
    num_near_missing = o.num_near_missing;
    sum_sq_px = o.sum_sq_px;
  }
};
using MatchSet = MatchList<limits::kMaxMatches>;

// Identities of a and b never contradict: no blob named two beacons, no beacon of a camera
// named two blobs. *shared counts the identical identities.
template <int kA, int kB>
bool Compatible(const MatchList<kA>& a, const MatchList<kB>& b, int* shared) {
  *shared = 0;
  for (int i = 0; i < a.num_matches; ++i) {
    const Match& x = a.matches[static_cast<std::size_t>(i)];
    for (int j = 0; j < b.num_matches; ++j) {
      const Match& y = b.matches[static_cast<std::size_t>(j)];
      const bool same_blob = x.blob == y.blob;
      const bool same_beacon = x.beacon == y.beacon && x.camera == y.camera;
      if (same_blob && same_beacon) ++*shared;
      else if (same_blob || same_beacon) return false;
    }
  }
  return true;
}

// Beacons with a second blob inside the gate (up to limits::kMaxAmbiguousMatches; the rest are
// left out, unmatched): MatchPose with reject_ambiguous leaves them out and lists them here,
// so that the tracker can try either blob.
struct AmbiguousMatch {
  int camera = 0;
  int beacon = 0;
  int blob_near = 0;  // index into the frame set's blob list: the nearest blob
  int blob_far = 0;   // the second-nearest
};
struct AmbiguityList {
  int num = 0;
  std::array<AmbiguousMatch, limits::kMaxAmbiguousMatches> items{};
};

class BeaconMatcher {
 public:
  // Precomputes each camera's view cone. The rig must stay alive and unchanged while in use.
  void Reset(const Rig& rig);

  // Indexes a frame set's blobs by camera (blobs with a camera outside the rig, or beyond
  // limits::kMaxBlobsPerFrame in a camera, are ignored). The list must stay alive while
  // matching. cameras: the camera set (above): bit k set when camera k delivered a frame in
  // this frame set (the others predict nothing: no match, never missing), and its blind cells
  // (predicted there: matched if a blob is near, never missing). Returns the number of blobs indexed.
  int SetBlobs(const BlobObs* blobs, int num_blobs, std::uint32_t cameras = kAllCameras);

  // Predicts every beacon at `pose` and matches. out->matches come camera by camera.
  // ambiguous (nullptr: not wanted), with reject_ambiguous: the beacons left out for a second
  // blob in the gate.
  void MatchPose(const BodyPose& pose, const MatchOptions& options, MatchSet* out,
                 AmbiguityList* ambiguous = nullptr) const;

  // Whether beacon P_w is predicted in camera k at `pose`; *uv_px its image; *inner whether
  // it is margin_px inside the image.
  bool Predict(int k, const BodyPose& pose, const Eigen::Vector3d& P_w, double grow_px, double margin_px,
               Eigen::Vector2d* uv_px, bool* inner) const;
  // The same for the beacon's position in camera k's frame, p_k (m).
  bool PredictInCamera(int k, const Eigen::Vector3d& p_k, double grow_px, double margin_px, Eigen::Vector2d* uv_px,
                       bool* inner) const;

  // Beacons left out of every prediction until the next call (none at Reset): never matched,
  // never missing. Beacon health's inconsistent beacons (moved, or a reflection in their
  // place: their blob would be missed by the tight gates or bend the pose) and the tracker's
  // leave-one-out solves (Tracker::LeaveOneOut).
  void SetExcluded(const BeaconSet& beacons) { excluded_ = beacons; }
  const BeaconSet& excluded() const { return excluded_; }

  int BlobsInCamera(int k) const { return count_[static_cast<std::size_t>(k)]; }
  int BlobOfCamera(int k, int j) const { return index_[static_cast<std::size_t>(k)][static_cast<std::size_t>(j)]; }

 private:
  // FacingCosine of every beacon for +-margin (a cache: MatchPose is called per hypothesis).
  void CacheFacing(double margin_rad) const;
  // How many of camera k's missing beacons (predicted at inner_uv, beacons inner_beacon; those
  // in `matched` are not missing) have a blob not `used` within radius_px; each blob counts once.
  int NearMissing(int k, const Eigen::Vector2d* inner_uv, const int* inner_beacon, int num_inner,
                  const BeaconSet& matched, std::array<bool, limits::kMaxBlobsPerFrame>* used, double radius_px) const;
  // Whether image point uv of camera k lies in one of its blind cells (SetBlobs' camera set).
  bool Blind(int k, const Eigen::Vector2d& uv) const;

  const Rig* rig_ = nullptr;
  std::array<double, limits::kMaxCameras> max_tan_sq_{};  // view cone: (x^2 + y^2) / z^2 bound
  mutable double facing_margin_ = -1.0;  // of the cache; < 0: none
  mutable std::array<double, limits::kMaxBeacons> cos_wide_{}, cos_narrow_{};
  const BlobObs* blobs_ = nullptr;
  std::uint32_t cameras_ = kAllCameras;
  BeaconSet excluded_;
  std::array<int, limits::kMaxCameras> count_{};
  std::array<std::array<short, limits::kMaxBlobsPerFrame>, limits::kMaxCameras> index_{};
};

}  // namespace mfns::fw
