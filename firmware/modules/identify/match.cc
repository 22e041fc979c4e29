#include "firmware/modules/identify/match.h"

#include <algorithm>
#include <cmath>

#include "common/camera/camera.h"
#include "common/rotation/rotation.h"

namespace mfns::fw {

bool MatchOptions::IsValid(const char** why) const {
  const char* bad = nullptr;
  if (!(gate_px > 0.0) || !std::isfinite(gate_px)) bad = "gate_px";
  else if (!(miss_margin_px >= 0.0) || !std::isfinite(miss_margin_px)) bad = "miss_margin_px";
  else if (!(facing_margin_rad >= 0.0) || !std::isfinite(facing_margin_rad)) bad = "facing_margin_rad";
  else if (!(near_miss_px >= 0.0) || !std::isfinite(near_miss_px)) bad = "near_miss_px";
  if (why != nullptr) *why = bad != nullptr ? bad : "ok";
  return bad == nullptr;
}

void BeaconMatcher::CacheFacing(double margin_rad) const {
  if (margin_rad == facing_margin_ || rig_ == nullptr) return;
  for (int m = 0; m < rig_->num_beacons; ++m) {
    cos_wide_[static_cast<std::size_t>(m)] = FacingCosine(*rig_, m, margin_rad);
    // A beam of pi (facing unknown, InferFacing) may light any direction, or none: such a
    // beacon is predicted from everywhere and its absence refutes nothing.
    const bool unknown = rig_->beacon_half_angle[static_cast<std::size_t>(m)] >= kPi;
    cos_narrow_[static_cast<std::size_t>(m)] = unknown ? 2.0 : FacingCosine(*rig_, m, -margin_rad);
  }
  facing_margin_ = margin_rad;
}

void BeaconMatcher::Reset(const Rig& rig) {
  rig_ = &rig;
  facing_margin_ = -1.0;
  blobs_ = nullptr;
  excluded_.Reset();
  count_.fill(0);
  for (int k = 0; k < rig.num_cameras && k < limits::kMaxCameras; ++k) {
    const CameraIntrinsics& in = rig.cameras[static_cast<std::size_t>(k)].intrinsics;
    double r2 = 0.0;
    const double us[2] = {-0.5, in.width - 0.5}, vs[2] = {-0.5, in.height - 0.5};
    for (double u : us) {
      for (double v : vs) {
        Eigen::Vector2d x_n;
        if (Unproject(in, Eigen::Vector2d(u, v), &x_n) != UnprojectStatus::kOk)
          x_n = Eigen::Vector2d((u - in.u0) / in.alpha_x, (v - in.v0) / in.alpha_y);  // pinhole
        r2 = std::max(r2, x_n.squaredNorm());
      }
    }
    max_tan_sq_[static_cast<std::size_t>(k)] = 1.21 * r2;  // 10% beyond the corners
  }
}

bool BeaconMatcher::Blind(int k, const Eigen::Vector2d& uv) const {
  const CameraIntrinsics& in = rig_->cameras[static_cast<std::size_t>(k)].intrinsics;
  return (cameras_ >> BlindCellBit(k, BlindCellOf(uv.x(), uv.y(), in.width, in.height)) & 1U) != 0;
}

int BeaconMatcher::SetBlobs(const BlobObs* blobs, int num_blobs, std::uint32_t cameras) {
  blobs_ = blobs;
  cameras_ = cameras;
  count_.fill(0);
  int indexed = 0;
  for (int i = 0; i < num_blobs && rig_ != nullptr; ++i) {
    const int k = blobs[i].camera;
    if (k < 0 || k >= rig_->num_cameras || k >= limits::kMaxCameras || (cameras >> k & 1U) == 0) continue;
    auto& c = count_[static_cast<std::size_t>(k)];
    if (c >= limits::kMaxBlobsPerFrame) continue;
    index_[static_cast<std::size_t>(k)][static_cast<std::size_t>(c++)] = static_cast<short>(i);
    ++indexed;
  }
  return indexed;
}

bool BeaconMatcher::Predict(int k, const BodyPose& pose, const Eigen::Vector3d& P_w, double grow_px,
                            double margin_px, Eigen::Vector2d* uv_px, bool* inner) const {
  return PredictInCamera(k, WorldToCamera(rig_->cameras[static_cast<std::size_t>(k)], pose, P_w), grow_px, margin_px,
                         uv_px, inner);
}

bool BeaconMatcher::PredictInCamera(int k, const Eigen::Vector3d& p_k, double grow_px, double margin_px,
                                    Eigen::Vector2d* uv_px, bool* inner) const {
  const RigCamera& cam = rig_->cameras[static_cast<std::size_t>(k)];
  if (!(p_k.z() > 0.0) ||
      p_k.head<2>().squaredNorm() > max_tan_sq_[static_cast<std::size_t>(k)] * p_k.z() * p_k.z())
    return false;
  if (Project(cam.intrinsics, p_k, uv_px) != ProjectStatus::kOk) return false;
  if (!InImage(cam.intrinsics, *uv_px, -grow_px)) return false;
  *inner = InImage(cam.intrinsics, *uv_px, margin_px);
  return true;
}

void BeaconMatcher::MatchPose(const BodyPose& pose, const MatchOptions& o, MatchSet* out,
                              AmbiguityList* ambiguous) const {
  if (ambiguous != nullptr) ambiguous->num = 0;
  out->num_matches = 0;
  out->beacons.Reset();
  out->num_beacons = 0;
  out->num_predicted = 0;
  out->num_missing = 0;
  out->num_near_missing = 0;
  out->sum_sq_px = 0.0;
  if (rig_ == nullptr || blobs_ == nullptr) return;
  if (rig_->has_facing) CacheFacing(o.facing_margin_rad);
  struct Candidate {
    double d;
    int beacon;
    int slot;  // blob slot within the camera
  };
  const double gate_sq = o.gate_px * o.gate_px;
  for (int k = 0; k < rig_->num_cameras; ++k) {
    if ((cameras_ >> k & 1U) == 0) continue;  // no frame from this camera: nothing to predict
    const auto sk = static_cast<std::size_t>(k);
    std::array<Candidate, 2 * limits::kMaxBeacons> cand;
    int n_cand = 0;
    BeaconSet inner_set;
    std::array<Eigen::Vector2d, limits::kMaxBeacons> inner_uv;
    std::array<int, limits::kMaxBeacons> inner_beacon{};
    int n_inner = 0;
    const Eigen::Vector3d centre_w = pose.C_w_b * rig_->cameras[sk].r_b_bk + pose.r_w_wb;
    // World to camera k in one product per beacon (WorldToCamera's two, and its call, were
    // a tenth of a 256-beacon cold search).
    const Eigen::Matrix3d C_k_w = rig_->cameras[sk].C_k_b * pose.C_w_b.transpose();
    for (int m = 0; m < rig_->num_beacons; ++m) {
      Eigen::Vector2d uv;
      bool inner = false;
      const auto sm = static_cast<std::size_t>(m);
      if (excluded_.Has(m)) continue;
      // The camera's cone first: it leaves out most of a large map at the cost of a rotation,
      // where the facing test takes a square root (a tenth of a 256-beacon cold search).
      if (!PredictInCamera(k, C_k_w * (rig_->beacons_w[sm] - centre_w), o.gate_px, o.miss_margin_px, &uv, &inner))
        continue;
      if (rig_->has_facing && !BeaconFacesCos(*rig_, m, centre_w, cos_wide_[sm])) continue;
      if (inner && rig_->has_facing && !BeaconFacesCos(*rig_, m, centre_w, cos_narrow_[sm])) inner = false;
      if (inner && o.skip_blind_cells && Blind(k, uv)) inner = false;  // glare or unwritten rows hide it
      if (InImage(rig_->cameras[sk].intrinsics, uv)) ++out->num_predicted;
      if (inner) inner_set.Set(m);
      if (inner && o.near_miss_px > 0.0) {  // (only tight re-matches count near misses, not hypotheses)
        inner_uv[static_cast<std::size_t>(n_inner)] = uv;
        inner_beacon[static_cast<std::size_t>(n_inner++)] = m;
      }
      // Nearest and second-nearest blob of this camera.
      double d1 = gate_sq * 4.0 + 1.0, d2 = d1;
      int j1 = -1, j2 = -1;
      for (int j = 0; j < count_[sk]; ++j) {
        const double d = (blobs_[index_[sk][static_cast<std::size_t>(j)]].uv_px - uv).squaredNorm();
        if (d < d1) {
          d2 = d1;
          j2 = j1;
          d1 = d;
          j1 = j;
        } else if (d < d2) {
          d2 = d;
          j2 = j;
        }
      }
      if (j1 < 0 || d1 > gate_sq) continue;
      if (o.reject_ambiguous && j2 >= 0 && d2 <= gate_sq) {
        if (ambiguous != nullptr && ambiguous->num < limits::kMaxAmbiguousMatches)
          ambiguous->items[static_cast<std::size_t>(ambiguous->num++)] =
              AmbiguousMatch{k, m, index_[sk][static_cast<std::size_t>(j1)], index_[sk][static_cast<std::size_t>(j2)]};
        continue;
      }
      cand[static_cast<std::size_t>(n_cand++)] = Candidate{d1, m, j1};
      if (j2 >= 0 && d2 <= gate_sq) cand[static_cast<std::size_t>(n_cand++)] = Candidate{d2, m, j2};
    }
    std::sort(cand.begin(), cand.begin() + n_cand, [](const Candidate& a, const Candidate& b) {
      return a.d < b.d || (a.d == b.d && (a.beacon < b.beacon || (a.beacon == b.beacon && a.slot < b.slot)));
    });
    std::array<bool, limits::kMaxBlobsPerFrame> used{};
    BeaconSet matched;
    for (int c = 0; c < n_cand; ++c) {
      const Candidate& cd = cand[static_cast<std::size_t>(c)];
      if (matched.Has(cd.beacon) || used[static_cast<std::size_t>(cd.slot)] || out->num_matches >= limits::kMaxMatches)
        continue;
      matched.Set(cd.beacon);
      used[static_cast<std::size_t>(cd.slot)] = true;
      out->matches[static_cast<std::size_t>(out->num_matches++)] =
          Match{index_[sk][static_cast<std::size_t>(cd.slot)], cd.beacon, k};
      out->sum_sq_px += cd.d;
    }
    out->beacons |= matched;
    out->num_missing += inner_set.Minus(matched).Count();
    if (o.near_miss_px > 0.0)
      out->num_near_missing +=
          NearMissing(k, inner_uv.data(), inner_beacon.data(), n_inner, matched, &used, o.near_miss_px);
  }
  out->num_beacons = out->beacons.Count();
}

int BeaconMatcher::NearMissing(int k, const Eigen::Vector2d* inner_uv, const int* inner_beacon, int num_inner,
                               const BeaconSet& matched, std::array<bool, limits::kMaxBlobsPerFrame>* used,
                               double radius_px) const {
  const auto sk = static_cast<std::size_t>(k);
  int near = 0;
  for (int i = 0; i < num_inner; ++i) {
    if (matched.Has(inner_beacon[i])) continue;
    double best = radius_px * radius_px;
    int slot = -1;
    for (int j = 0; j < count_[sk]; ++j) {
      if ((*used)[static_cast<std::size_t>(j)]) continue;
      const double d = (blobs_[index_[sk][static_cast<std::size_t>(j)]].uv_px - inner_uv[i]).squaredNorm();
      if (d <= best) {
        best = d;
        slot = j;
      }
    }
    if (slot < 0) continue;
    (*used)[static_cast<std::size_t>(slot)] = true;
    ++near;
  }
  return near;
}

}  // namespace mfns::fw
