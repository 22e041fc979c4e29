#include "firmware/modules/identify/lost_in_space.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "common/rotation/rotation.h"
#include "firmware/modules/identify/map_repeats.h"

namespace mfns::fw {
namespace {

// LisResult::cost, in units of one same-camera P3P hypothesis (0.62 us on the host). A least-
// squares fit of whole frame sets' CPU time over the acquisition matrix's 1878 searching frame
// sets (docs/acquisition.md, session 17: 0.74 us per 1000 beacons x blobs of a fourth-blob
// test, 7.0 us per 100 beacons of a full reprojection, 8.6 us per refinement; rms 0.63 ms).
constexpr double kCostFourthPerBeaconBlob = 1.2e-3;
constexpr double kCostReprojectionPerBeacon = 0.113;
constexpr double kCostRefine = 14.0;
constexpr double kCostRepeatPerBeaconPair = 2e-3;  // RepeatedElsewhere's scan (not fitted: an estimate)
// PriorBeacons: per prior pose, each camera's offsets to the beacons and each selected blob's
// test of them (estimates: ~10 ns and ~3 ns per beacon).
constexpr double kCostPriorPerCameraBeacon = 0.016;
constexpr double kCostPriorPerBlobBeacon = 0.005;
// MayComplete's count, per beacon pair of a blob triple (an estimate: ~3 ns).
constexpr double kCostCountPerBeaconPair = 0.005;

constexpr int PairIndex(int i, int j) { return j * (j - 1) / 2 + i; }  // i < j

// The same identities.
template <int kA, int kB>
bool SameSet(const MatchList<kA>& a, const MatchList<kB>& b) {
  int shared = 0;
  return a.num_matches == b.num_matches && Compatible(a, b, &shared) && shared == a.num_matches;
}

}  // namespace

double FalseAlarms(int matched, int predicted, double blobs_per_image, double gate_px, double image_area_px2,
                   double tests) {
  const int k = matched - 3, n = predicted - 3;
  if (k <= 0) return tests;
  if (n < k || !(image_area_px2 > 0.0)) return 0.0;  // cannot happen for a consistent set
  const double p = std::min(1.0, blobs_per_image * kPi * gate_px * gate_px / image_area_px2);
  if (p >= 1.0) return tests;
  if (!(p > 0.0)) return 0.0;
  // Binomial tail P(X >= k), X ~ Bin(n, p): the first term from logs, the rest by ratios.
  double term = std::exp(std::lgamma(n + 1.0) - std::lgamma(k + 1.0) - std::lgamma(n - k + 1.0) + k * std::log(p) +
                         (n - k) * std::log1p(-p));
  double tail = 0.0;
  for (int x = k; x <= n && x <= limits::kMaxMatches; ++x) {
    tail += term;
    term *= (n - x) / (x + 1.0) * p / (1.0 - p);
  }
  return tests * std::min(1.0, tail);
}

const char* ToString(LisStatus s) {
  switch (s) {
    case LisStatus::kFix: return "fix";
    case LisStatus::kAmbiguous: return "ambiguous: distinct poses explain the blobs equally well";
    case LisStatus::kNoHypothesis: return "no pose explains enough beacons";
    case LisStatus::kBudgetExhausted: return "hypothesis budget exhausted before a confirmed pose";
    case LisStatus::kTooFewBlobs: return "fewer than 3 blobs";
    case LisStatus::kBadInput: return "bad options, rig or blobs";
    case LisStatus::kSearching: return "searching: continues in the next call";
    case LisStatus::kCount: break;
  }
  return "unknown lost-in-space status";
}

bool LisOptions::IsValid(const char** why) const {
  const char* bad = nullptr;
  P3pOptions p = p3p;
  if (p.max_depth_m <= 0.0) p.max_depth_m = p.min_depth_m * 2.0;  // automatic: checked at use
  const char* sub = nullptr;
  if (!p.IsValid(&sub)) bad = sub;
  else if (max_hypotheses < 1 || max_hypotheses > limits::kMaxLisHypotheses) bad = "max_hypotheses";
  else if (!(max_cost > 0.0)) bad = "max_cost";
  else if (cross_camera_work < 1 || cross_camera_work > 8) bad = "cross_camera_work";
  else if (max_blobs < 3 || max_blobs > limits::kMaxLisBlobs) bad = "max_blobs";
  else if (!hypothesis_match.IsValid()) bad = "hypothesis_match";
  else if (!refine_match.IsValid()) bad = "refine_match";
  else if (!(miss_weight >= 0.0) || !std::isfinite(miss_weight)) bad = "miss_weight";
  else if (!(min_score_margin > 0.0) || !std::isfinite(min_score_margin)) bad = "min_score_margin";
  else if (max_missing < 0) bad = "max_missing";
  else if (near_miss_min_beacons < 0) bad = "near_miss_min_beacons";
  else if (!(near_miss_px > 0.0) || !std::isfinite(near_miss_px)) bad = "near_miss_px";
  else if (raw_matches_per_miss < 0) bad = "raw_matches_per_miss";
  else if (near_bands < 1 || near_bands > kMaxNearBands) bad = "near_bands";
  else if (min_beacons < 3 || min_beacons > limits::kMaxBeacons) bad = "min_beacons";
  else if (confirm_beacons != 0 && confirm_beacons < min_beacons + 1) bad = "confirm_beacons";
  else if (!(max_rms_px > 0.0)) bad = "max_rms_px";
  else if (!(pair_tolerance_m >= 0.0) || !std::isfinite(pair_tolerance_m)) bad = "pair_tolerance_m";
  else if (!(repeat_tolerance_m >= 0.0) || !std::isfinite(repeat_tolerance_m)) bad = "repeat_tolerance_m";
  else if (!(pair_angle_tolerance_rad >= 0.0) || !std::isfinite(pair_angle_tolerance_rad)) bad = "pair_angle_tolerance_rad";
  else if (!(max_false_alarms >= 0.0) || !std::isfinite(max_false_alarms)) bad = "max_false_alarms";
  else if (!(fourth_blob_max_rad > 0.0) || !std::isfinite(fourth_blob_max_rad)) bad = "fourth_blob_max_rad";
  else if (!(weak_fourth_blob_max_rad >= fourth_blob_max_rad) || !(weak_fourth_blob_max_rad < 1.5))
    bad = "weak_fourth_blob_max_rad";
  else if (!(workspace_margin_m >= 0.0) || !std::isfinite(workspace_margin_m)) bad = "workspace_margin_m";
  else if (!workspace_auto && !(workspace_min_w.array() <= workspace_max_w.array()).all()) bad = "workspace";
  else if (!(same_pose_m > 0.0) || !(same_pose_rad > 0.0)) bad = "same_pose";
  else if (!solve.IsValid(&sub)) bad = sub;
  if (why != nullptr) *why = bad != nullptr ? bad : "ok";
  return bad == nullptr;
}

bool LostInSpace::Reset(const Rig& rig) {
  rig_ = nullptr;
  searching_ = false;
  if (ValidateRig(rig) != RigStatus::kOk) return false;
  rig_ = &rig;
  matcher_.Reset(rig);
  map_diameter_m_ = 0.0;
  map_min_w_ = map_max_w_ = rig.num_beacons > 0 ? rig.beacons_w[0] : Eigen::Vector3d::Zero();
  for (int a = 0; a < rig.num_beacons; ++a) {
    const Eigen::Vector3d& Pa = rig.beacons_w[static_cast<std::size_t>(a)];
    map_min_w_ = map_min_w_.cwiseMin(Pa);
    map_max_w_ = map_max_w_.cwiseMax(Pa);
    for (int b = 0; b < rig.num_beacons; ++b) {
      const double d = (Pa - rig.beacons_w[static_cast<std::size_t>(b)]).norm();
      dist_[static_cast<std::size_t>(a)][static_cast<std::size_t>(b)] = static_cast<float>(d);
      map_diameter_m_ = std::max(map_diameter_m_, d);
    }
  }
  for (int a = 0; a < rig.num_beacons; ++a) {
    const auto sa = static_cast<std::size_t>(a);
    beacon_x_[sa] = static_cast<float>(rig.beacons_w[sa].x());
    beacon_y_[sa] = static_cast<float>(rig.beacons_w[sa].y());
    beacon_z_[sa] = static_cast<float>(rig.beacons_w[sa].z());
  }
  image_area_px2_ = 0.0;
  for (int k = 0; k < rig.num_cameras; ++k) {
    const CameraIntrinsics& in = rig.cameras[static_cast<std::size_t>(k)].intrinsics;
    image_area_px2_ = std::max(image_area_px2_, static_cast<double>(in.width) * in.height);
  }
  CoVisibilityTable();
  return true;
}

// Samples camera centres over the workspace (the map's bounding box grown by the cameras'
// lever arm; with facing data, only points in front of every beacon, the inside of a convex
// module, unless that leaves too few) and records, per beacon pair, the extreme angles under
// which both are seen (facing the point, at least kMinDepthM away). The true camera lies
// between samples, so the ranges get pair_angle_tolerance_rad at use: the sampled minimum
// sits where the angle changes slowly (the far end of the module), so a coarse grid loses
// little (checked: no true pair lost over 60 random views of 64- and 256-beacon cylinders).
void LostInSpace::CoVisibilityTable() {
  constexpr int kMaxSamples = 2048;
  constexpr double kMinDepthM = 0.2;
  const Rig& rig = *rig_;
  const int nb = rig.num_beacons;
  for (int a = 0; a < nb; ++a) {
    cos_min_angle_[static_cast<std::size_t>(a)].fill(2.0F);
    cos_max_angle_[static_cast<std::size_t>(a)].fill(2.0F);
  }
  double lever = 0.0;
  for (int k = 0; k < rig.num_cameras; ++k) lever = std::max(lever, rig.cameras[static_cast<std::size_t>(k)].r_b_bk.norm());
  const Eigen::Vector3d lo = map_min_w_.array() - lever, hi = map_max_w_.array() + lever;
  const Eigen::Vector3d size = (hi - lo).cwiseMax(1e-3);
  const double step = std::cbrt(size.prod() / kMaxSamples);
  std::array<int, 3> n{};
  for (int d = 0; d < 3; ++d) n[static_cast<std::size_t>(d)] = std::max(1, static_cast<int>(size[d] / step));
  const auto point = [&](int i) {
    const int ix = i / (n[1] * n[2]), iy = i / n[2] % n[1], iz = i % n[2];
    return Eigen::Vector3d(lo + Eigen::Vector3d((ix + 0.5) * size.x() / n[0], (iy + 0.5) * size.y() / n[1],
                                                (iz + 0.5) * size.z() / n[2]));
  };
  // (A beacon whose beam covers every direction, e.g. one whose facing InferFacing could not
  // tell, carries no wall normal: it bounds nothing. Seen: such beacons on a box's end walls,
  // with the placeholder normal +z, cut the sampled region at their height, and true beacon
  // pairs seen from below it were refused by the table.)
  std::array<bool, limits::kMaxBeacons> bounds{};
  for (int m = 0; m < nb; ++m) bounds[static_cast<std::size_t>(m)] = FacingCosine(rig, m, 0.0) > -1.0;
  const auto inside = [&](const Eigen::Vector3d& p) {
    for (int m = 0; m < nb; ++m)
      if (bounds[static_cast<std::size_t>(m)] &&
          rig.beacon_normal_w[static_cast<std::size_t>(m)].dot(p - rig.beacons_w[static_cast<std::size_t>(m)]) <= 0.0)
        return false;
    return true;
  };
  const int total = n[0] * n[1] * n[2];
  // With facing data, only points in front of every beacon (the inside of a convex module);
  // a layout where that leaves under a tenth of the box is not convex: the whole box.
  bool inside_only = rig.has_facing;
  if (inside_only) {
    int kept = 0;
    for (int i = 0; i < total; ++i) kept += inside(point(i)) ? 1 : 0;
    inside_only = kept * 10 >= total;
  }
  for (int i = 0; i < total; ++i) {
    const Eigen::Vector3d p = point(i);
    if (!inside_only || inside(p)) SampleCoVisibility(p, kMinDepthM);
  }
}

void LostInSpace::SampleCoVisibility(const Eigen::Vector3d& p, double min_depth_m) {
  const Rig& rig = *rig_;
  const int nb = rig.num_beacons;
  std::array<Eigen::Vector3f, limits::kMaxBeacons> dir;
  std::array<short, limits::kMaxBeacons> seen;
  int ns = 0;
  for (int m = 0; m < nb; ++m) {
    const Eigen::Vector3d u = rig.beacons_w[static_cast<std::size_t>(m)] - p;
    const double len = u.norm();
    if (!(len >= min_depth_m) || !BeaconFaces(rig, m, p)) continue;
    dir[static_cast<std::size_t>(m)] = (u / len).cast<float>();
    seen[static_cast<std::size_t>(ns++)] = static_cast<short>(m);
  }
  for (int x = 0; x < ns; ++x) {
    const auto a = static_cast<std::size_t>(seen[static_cast<std::size_t>(x)]);
    auto& cmin = cos_min_angle_[a];
    auto& cmax = cos_max_angle_[a];
    for (int y = x + 1; y < ns; ++y) {
      const auto b = static_cast<std::size_t>(seen[static_cast<std::size_t>(y)]);
      const float c = dir[a].dot(dir[b]);
      // cos of the smallest angle: the largest cosine; of the largest angle: the smallest.
      if (cmin[b] > 1.5F || c > cmin[b]) cmin[b] = c;
      if (cmax[b] > 1.5F || c < cmax[b]) cmax[b] = c;
    }
  }
}

bool LostInSpace::InWorkspace(const Eigen::Vector3d& r, const LisOptions& o) const {
  const Eigen::Vector3d lo = o.workspace_auto ? (map_min_w_.array() - o.workspace_margin_m).matrix() : o.workspace_min_w;
  const Eigen::Vector3d hi = o.workspace_auto ? (map_max_w_.array() + o.workspace_margin_m).matrix() : o.workspace_max_w;
  return (r.array() >= lo.array()).all() && (r.array() <= hi.array()).all();
}

bool LostInSpace::SamePose(const Candidate& a, const Candidate& b, const LisOptions& o) const {
  // Four shared identities determine the pose; three leave the P3P's discrete ambiguity (up to
  // four poses through the same three identities), so then the poses must be close too.
  // A side with fewer than four identities cannot share four: its positions are compared
  // first, the cheaper test (Insert compares each new pose with every kept one: with 256 kept,
  // the identity comparisons were a quarter of a small cluttered map's search time).
  const bool near = (a.pose.r_w_wb - b.pose.r_w_wb).squaredNorm() <= o.same_pose_m * o.same_pose_m;
  if (!near && (a.set.num_matches < 4 || b.set.num_matches < 4)) return false;
  int shared = 0;
  if (!Compatible(a.set, b.set, &shared)) return false;
  if (shared >= 4) return true;
  return near && LogSO3(a.pose.C_w_b.transpose() * b.pose.C_w_b).norm() <= o.same_pose_rad;
}

void LostInSpace::Insert(const Candidate& c, const LisOptions& o) {
  for (int i = 0; i < num_cand_; ++i) {
    Candidate& k = cand_[static_cast<std::size_t>(i)];
    if (!SamePose(k, c, o)) continue;
    // (At an equal score a refined pose beats a raw one, and one whose miss is excused - a
    // near miss, LisOptions::near_miss_min_beacons - one whose is not.)
    const bool excused = c.refined && k.refined && c.score == k.score &&
                         UnexcusedMissing(c.set, o) < UnexcusedMissing(k.set, o);
    if (c.score > k.score || (c.refined && !k.refined && c.score >= k.score) || excused) k = c;
    return;
  }
  if (num_cand_ < limits::kMaxLisCandidates) {
    cand_[static_cast<std::size_t>(num_cand_++)] = c;
    return;
  }
  // Full: the lowest score goes. Dropping a pose that may still be consistent means the list
  // no longer holds every plausible pose.
  int worst = 0;
  for (int i = 1; i < num_cand_; ++i)
    if (cand_[static_cast<std::size_t>(i)].score < cand_[static_cast<std::size_t>(worst)].score) worst = i;
  Candidate& w = cand_[static_cast<std::size_t>(worst)];
  const Candidate& dropped = c.score > w.score ? w : c;
  if (dropped.set.num_missing <= o.max_missing) overflow_ = true;
  if (c.score > w.score) w = c;
}

// Solve, re-match with the tight gate, until the identities stop changing (bounded).
bool LostInSpace::Refine(Candidate* c, const LisOptions& o) {
  c->refined = true;
  const MatchOptions tight = WithNearMisses(o.refine_match, o);
  // (ScoreMatched's fourth: the solve below then pulls the raw pose onto it.)
  if (c->fourth.blob >= 0) c->set.Add(c->fourth);
  // A P3P pose fits its three blobs exactly: when those are all it matches, it is already the
  // least-squares solution; only the tight re-match remains.
  if (c->set.num_matches == 3 && c->set.sum_sq_px < 1e-12) {
    matcher_.MatchPose(c->pose, tight, &match_scratch_);
    if (SameSet(match_scratch_, c->set)) {
      c->set.CopyFrom(match_scratch_);
      c->rms_px = 0.0;
      c->score = c->set.Score(o.miss_weight);
      return c->set.num_beacons >= o.min_beacons;
    }
  }
  for (int round = 0; round < 3; ++round) {
    const SolveStatus s = SolvePose(*rig_, blobs_, num_blobs_, c->set.matches.data(), c->set.num_matches, c->pose,
                                    o.solve, &solve_);
    if (s != SolveStatus::kOk && s != SolveStatus::kNotConverged) return false;
    c->pose = solve_.pose;
    c->rms_px = solve_.rms_px;
    matcher_.MatchPose(c->pose, tight, &match_scratch_);
    const bool stable = SameSet(match_scratch_, c->set);
    c->set.CopyFrom(match_scratch_);
    if (stable) break;
  }
  c->score = c->set.Score(o.miss_weight);
  return c->set.num_beacons >= o.min_beacons && c->rms_px <= o.max_rms_px;
}

// Whether some selected blob other than the hypothesis' three (t_i, t_j, t_k) sees a beacon
// within max_rad of its ray at `pose`: a cheap necessary condition for a fourth match. With
// steady_only only a steady blob makes it kFound, and kUnsteadyOnly says an unsteady one would
// have (one scan: each camera's offsets computed once).
LostInSpace::Fourth LostInSpace::ExplainsAFourth(const BodyPose& pose, int t_i, int t_j, int t_k, float cos_sq,
                                                 bool steady_only, int* found) {
  const int nb = rig_->num_beacons;
  // The blobs of one camera share its centre: its offsets to the beacons (and their squared
  // lengths times cos_sq) are computed once per pose, at its first blob (in 256-beacon maps
  // this test was a quarter of a cold search's time).
  std::uint32_t offsets_of = 0;  // bit k: off_*_[k] hold camera k's offsets for this pose
  bool unsteady_hit = false;
  for (int s = 0; s < num_sel_; ++s) {
    if (s == t_i || s == t_j || s == t_k) continue;
    const auto ss = static_cast<std::size_t>(s);
    const bool counts = !steady_only || sel_steady_[ss];
    if (!counts && unsteady_hit) continue;  // (only a steady blob can change the answer now)
    const auto k = static_cast<std::size_t>(blobs_[sel_[ss]].camera);
    CameraOffsets& c = offsets_[k];
    if ((offsets_of >> k & 1U) == 0) {
      offsets_of |= 1U << k;
      const Eigen::Vector3f o_w = (pose.C_w_b * rays_[ss].o_b + pose.r_w_wb).cast<float>();
      for (int m = 0; m < nb; ++m) {
        const auto sm = static_cast<std::size_t>(m);
        const float vx = beacon_x_[sm] - o_w.x(), vy = beacon_y_[sm] - o_w.y(), vz = beacon_z_[sm] - o_w.z();
        c.x[sm] = vx;
        c.y[sm] = vy;
        c.z[sm] = vz;
        c.cos_sq_len_sq[sm] = cos_sq * (vx * vx + vy * vy + vz * vz);
      }
    }
    const Eigen::Vector3f d_w = (pose.C_w_b * rays_[ss].d_b).cast<float>();
    const float dx = d_w.x(), dy = d_w.y(), dz = d_w.z();
    // Branch-free over the map so that the compiler can vectorise it: the hot loop of a search.
    int hits = 0;
    for (int m = 0; m < nb; ++m) {
      const auto sm = static_cast<std::size_t>(m);
      const float t = c.x[sm] * dx + c.y[sm] * dy + c.z[sm] * dz;
      hits += static_cast<int>((t > 0.0F) & (t * t >= c.cos_sq_len_sq[sm]));
    }
    if (hits > 0 && counts) {
      *found = s;
      return Fourth::kFound;
    }
    unsteady_hit = unsteady_hit || hits > 0;
  }
  return unsteady_hit ? Fourth::kUnsteadyOnly : Fourth::kNone;
}

// The beacon nearest in angle to selected blob s's ray at `pose`, in front of its camera (-1:
// none): ExplainsAFourth's offsets of that camera must hold this pose's (it found s).
int LostInSpace::BeaconAlong(const BodyPose& pose, int s) const {
  const auto ss = static_cast<std::size_t>(s);
  const CameraOffsets& c = offsets_[static_cast<std::size_t>(blobs_[sel_[ss]].camera)];
  const Eigen::Vector3f d_w = (pose.C_w_b * rays_[ss].d_b).cast<float>();
  int best = -1;
  float best_cos_sq = 0.0F;
  for (int m = 0; m < rig_->num_beacons; ++m) {
    const auto sm = static_cast<std::size_t>(m);
    const float t = c.x[sm] * d_w.x() + c.y[sm] * d_w.y() + c.z[sm] * d_w.z();
    const float len_sq = c.x[sm] * c.x[sm] + c.y[sm] * c.y[sm] + c.z[sm] * c.z[sm];
    if (!(t > 0.0F) || len_sq <= 0.0F || t * t <= best_cos_sq * len_sq) continue;
    best = m;
    best_cos_sq = t * t / len_sq;
  }
  return best;
}

void LostInSpace::Score(const BodyPose& pose, const LisOptions& o, LisResult* result, bool weak) {
  ++result->poses_scored;
  // In a large map a three-beacon pose is never a fix and its exact twins are too many to
  // follow: a pose that explains no fourth blob is not worth the full reprojection. Unless two
  // blobs of every triple are anchored (a cold search after a gap with two beacons tracked
  // through it): a triple then holds ~N beacon triples, and its three-beacon poses are few
  // enough to reproject and list (docs/acquisition.md, session 21).
  const double nb = rig_->num_beacons;
  if (cur_.item < num_steady_items_) {
    // A steady list's item: only a pose with a steady fourth may explain four steady blobs.
    result->cost += kCostFourthPerBeaconBlob * nb * num_sel_;
    int found = -1;
    Fourth f = ExplainsAFourth(pose, cur_i_, cur_j_, cur_k_, fourth_cos_sq_, /*steady_only=*/true, &found);
    if (f != Fourth::kFound && weak) {  // (LisOptions::weak_fourth_blob_max_rad)
      result->cost += kCostFourthPerBeaconBlob * nb * num_sel_;
      f = ExplainsAFourth(pose, cur_i_, cur_j_, cur_k_, weak_fourth_cos_sq_, /*steady_only=*/true, &found);
    }
    if (f == Fourth::kFound) ScoreMatched(pose, o, result, found, weak);
    return;
  }
  const bool pairs_anchored = anchors_per_triple_ >= 2;
  const bool fourth_test = !PosePrior() && !pairs_anchored && rig_->num_beacons >= o.fourth_blob_min_beacons;
  if (fourth_test) {
    // A triple of steady blobs asks for a steady fourth (LisOptions::steady_fourth); a pose with
    // only an unsteady one is deferred: scored after the last item (ScoreDeferred), so only a
    // search that ends early never pays for it.
    const bool steady_only = o.steady_fourth && num_sel_steady_ >= 4 && sel_steady_[static_cast<std::size_t>(cur_i_)] &&
                             sel_steady_[static_cast<std::size_t>(cur_j_)] && sel_steady_[static_cast<std::size_t>(cur_k_)];
    result->cost += kCostFourthPerBeaconBlob * nb * num_sel_;
    int found = -1;
    const Fourth fourth = ExplainsAFourth(pose, cur_i_, cur_j_, cur_k_, fourth_cos_sq_, steady_only, &found);
    if (fourth == Fourth::kUnsteadyOnly) {
      ++result->deferred;
      if (num_deferred_ < limits::kMaxLisDeferred)
        deferred_[static_cast<std::size_t>(num_deferred_++)] = pose;
      else
        deferred_lost_ = true;
    }
    if (fourth != Fourth::kFound) return;
    ScoreMatched(pose, o, result, found);
    return;
  }
  // Under a prior (or two anchors) no fourth-blob test filters the poses: their full
  // reprojection is work the budget counts (a frame set's time would otherwise grow with the
  // map; seen: 22 ms).
  ++result->work;
  ScoreMatched(pose, o, result);
}

// A raw pose's full reprojection: listed (Insert) if it explains enough, refined and perhaps
// confirmed if it explains many.
void LostInSpace::ScoreMatched(const BodyPose& pose, const LisOptions& o, LisResult* result, int fourth_sel, bool weak) {
  result->cost += kCostReprojectionPerBeacon * rig_->num_beacons;
  matcher_.MatchPose(pose, o.hypothesis_match, &match_scratch_);
  // Too few beacons, or refuted even allowing for the raw pose's error at the margins.
  const int beacons = match_scratch_.num_beacons, missing = match_scratch_.num_missing;
  if (beacons < o.min_beacons) return;
  // A raw pose that misses few beacons against many it explains is refined first and judged
  // as refined: in a dense view the raw truth misses far beacons (raw_matches_per_miss).
  const bool worth_refining =
      o.confirm_beacons > 0 && beacons >= o.confirm_beacons &&
      missing <= o.max_missing + (o.raw_matches_per_miss > 0 ? beacons / o.raw_matches_per_miss : 0);
  if (missing > o.max_missing + 1 && !worth_refining) return;
  scratch_.pose = pose;
  scratch_.refined = false;
  scratch_.set.CopyFrom(match_scratch_);
  // The fourth-blob test's angle is wider than the raw match's gate (0.015 rad is 24 px at
  // f = 1600 px): a raw pose from a triple of weak geometry may predict its fourth beacon
  // beside that blob but outside the gate, and it is then "missing" and refutes the truth
  // (seen: 3 of 119 exhaustive steady lists of clean four-beacon views held nothing for this
  // alone; docs/acquisition.md, session 44). The association is kept for Refine. A weak root
  // (WeakRoot) found its fourth by the wide test: its fourth beacon may lie off the image, not
  // "missing", so it is kept whatever the match says.
  scratch_.fourth = Match{};
  scratch_.weak = weak;
  if (fourth_sel >= 0 && (missing > 0 || weak)) {
    const int blob = sel_[static_cast<std::size_t>(fourth_sel)];
    const int beacon = scratch_.set.BeaconOfBlob(blob) < 0 ? BeaconAlong(pose, fourth_sel) : -1;
    if (beacon >= 0 && !scratch_.set.beacons.Has(beacon) && !matcher_.excluded().Has(beacon))
      scratch_.fourth = Match{blob, beacon, blobs_[blob].camera};
  }
  scratch_.score = scratch_.set.Score(o.miss_weight);
  if (worth_refining) {
    result->cost += kCostRefine;
    if (!Refine(&scratch_, o) || scratch_.set.num_missing > o.max_missing + 1) return;
    Confirm(&scratch_, o, result);
  }
  Insert(scratch_, o);
}

// A refined pose ends the search when chance would explain its matches in fewer than
// max_false_alarms of the hypotheses tried so far.
void LostInSpace::Confirm(Candidate* c, const LisOptions& o, LisResult* result) {
  if (c->set.num_beacons < o.confirm_beacons || UnexcusedMissing(c->set, o) != 0) return;
  int blobs_per_image = 0;
  for (int k = 0; k < rig_->num_cameras; ++k) blobs_per_image = std::max(blobs_per_image, matcher_.BlobsInCamera(k));
  const double fa = FalseAlarms(c->set.num_matches, c->set.num_predicted, blobs_per_image, o.refine_match.gate_px,
                                image_area_px2_, std::max(1, result->poses_scored));
  if (fa > o.max_false_alarms) return;
  if (RepeatedElsewhere(*c, o, result)) {
    ++result->repeats;
    return;
  }
  result->confirmed = true;
  confirmed_ = *c;
  result->false_alarms = fa;
}

// Whether the map holds another copy of c's beacons (a rigid motion taking each within
// repeat_tolerance_m of a beacon) from which the moved pose explains the blobs as c does:
// CopyExplainsTheBlobs. The copies: FindMapCopies (map_repeats.h). A beacon
// set found repeated is remembered for the rest of the search: in a regular grid many blob
// triples lead to the same set, and its scan would give the same answer each time.
bool LostInSpace::RepeatedElsewhere(const Candidate& c, const LisOptions& o, LisResult* result) {
  if (!(o.repeat_tolerance_m > 0.0)) return false;
  std::array<int, limits::kMaxLisCandidateMatches> v{};
  int n = 0;
  BeaconSet seen;
  for (int i = 0; i < c.set.num_matches; ++i) {
    const int m = c.set.matches[static_cast<std::size_t>(i)].beacon;
    if (seen.Has(m)) continue;
    seen.Set(m);
    v[static_cast<std::size_t>(n++)] = m;
  }
  if (n < 3) return false;
  for (int i = 0; i < std::min(num_repeated_, kRepeatMemo); ++i)
    if (repeated_[static_cast<std::size_t>(i)] == seen) return true;
  const auto D = [this](int x, int y) {
    return static_cast<double>(dist_[static_cast<std::size_t>(x)][static_cast<std::size_t>(y)]);
  };
  result->cost += kCostRepeatPerBeaconPair * rig_->num_beacons * rig_->num_beacons;
  const bool repeated = FindMapCopies(*rig_, v.data(), n, o.repeat_tolerance_m, D, [&](const MapCopy& copy) {
    return CopyExplainsTheBlobs(c, copy.C, copy.t, n, o);
  });
  if (repeated) repeated_[static_cast<std::size_t>(num_repeated_++ % kRepeatMemo)] = seen;  // oldest replaced
  return repeated;
}

// Whether c's pose moved by (R, t) (a copy of its beacons: FindMapCopies) matches as many
// beacons with none missing (the hypothesis gate: a copy off by a few millimetres is refused by
// no fainter test). Under a prior the copy must also be one the search could have listed: near
// the followed poses (with the raw poses' slack) and naming the anchored blobs as c must; the
// prior tells the others apart (a regular map re-identified after a short loss).
bool LostInSpace::CopyExplainsTheBlobs(const Candidate& c, const Eigen::Matrix3d& R, const Eigen::Vector3d& t, int n,
                                       const LisOptions& o) {
  BodyPose moved;
  moved.C_w_b = R * c.pose.C_w_b;
  moved.r_w_wb = R * c.pose.r_w_wb + t;
  if (prior_ != nullptr && !NearPrior(moved, prior_->raw_slack_m, prior_->raw_slack_rad)) return false;
  matcher_.MatchPose(moved, o.hypothesis_match, &match_scratch_);
  if (match_scratch_.num_beacons < n || match_scratch_.num_missing > o.max_missing) return false;
  int kept = 0;
  for (int b = 0; b < num_blobs_; ++b) {
    const int beacon = blob_anchor_[static_cast<std::size_t>(b)];
    kept += beacon >= 0 && match_scratch_.BeaconOfBlob(b) == beacon;
  }
  return kept >= anchors_per_triple_;
}

void LostInSpace::SelectBlobs(const LisOptions& o, const std::uint8_t* steady) {
  // Steady first, then brightest first within each camera; cameras in turn.
  // (An anchored blob counts as steady, and comes first: every searched triple holds it.)
  const auto anchored = [&](short b) { return blob_anchor_[static_cast<std::size_t>(b)] >= 0; };
  const auto is_steady = [&](short b) { return anchored(b) || (steady != nullptr && steady[b] != 0); };
  std::array<std::array<short, limits::kMaxBlobsPerFrame>, limits::kMaxCameras> order{};
  for (int k = 0; k < rig_->num_cameras; ++k) {
    auto& ok = order[static_cast<std::size_t>(k)];
    const int n = matcher_.BlobsInCamera(k);
    for (int j = 0; j < n; ++j) ok[static_cast<std::size_t>(j)] = static_cast<short>(matcher_.BlobOfCamera(k, j));
    // (std::sort with the index as tie-break: deterministic like a stable sort, and no heap.)
    std::sort(ok.begin(), ok.begin() + n, [&](short a, short b) {
      if (anchored(a) != anchored(b)) return anchored(a);
      if (is_steady(a) != is_steady(b)) return is_steady(a);
      return blobs_[a].flux > blobs_[b].flux || (blobs_[a].flux == blobs_[b].flux && a < b);
    });
  }
  // Two rounds over the cameras: the steady blobs, then the others.
  num_sel_ = 0;
  for (const bool want_steady : {true, false})
    for (int rank = 0; rank < limits::kMaxBlobsPerFrame && num_sel_ < o.max_blobs; ++rank)
      for (int k = 0; k < rig_->num_cameras && num_sel_ < o.max_blobs; ++k) {
        if (rank >= matcher_.BlobsInCamera(k)) continue;
        const short b = order[static_cast<std::size_t>(k)][static_cast<std::size_t>(rank)];
        if (is_steady(b) == want_steady) sel_[static_cast<std::size_t>(num_sel_++)] = b;
      }
  num_sel_steady_ = 0;
  for (int i = 0; i < num_sel_; ++i) {
    const auto si = static_cast<std::size_t>(i);
    rays_[si] = RayOfBlob(*rig_, blobs_[sel_[si]]);
    sel_steady_[si] = is_steady(static_cast<short>(sel_[si]));
    num_sel_steady_ += sel_steady_[si] ? 1 : 0;
    sel_anchored_[si] = anchored(static_cast<short>(sel_[si]));
  }
}

// With a prior, blob i can only be a beacon that some prior pose sees near blob i's ray: the
// angle theta between the ray and the beacon's direction within the prior's attitude bound
// alpha (plus the raw slack), plus beta, what its position bound (plus the raw slack and the
// lever arm) subtends at the beacon's distance d: sin(beta) = m / d. Without trigonometry per
// blob: theta <= alpha + beta <=> u.d_w >= cos(alpha) sqrt(d^2 - m^2) - sin(alpha) m, u the
// beacon's offset from the camera (any beacon within m passes). Sets each pose's sets
// (pose_allowed_, pose_blobs_) and their union (allowed_), the anchors applied to both.
void LostInSpace::PriorBeacons(LisResult* res) {
  const int nb = rig_->num_beacons;
  num_pose_sets_ = 0;
  const double alpha = PosePrior() ? prior_->max_rad + prior_->raw_slack_rad : 0.0;
  if (!PosePrior() || alpha >= kPi / 2.0) {  // (a bound that wide allows every beacon)
    std::fill(allowed_.begin(), allowed_.begin() + num_sel_, BeaconSet::FirstN(nb));
    ApplyAnchors(allowed_.data());
    return;
  }
  std::fill(allowed_.begin(), allowed_.begin() + num_sel_, BeaconSet{});
  const auto cos_a = static_cast<float>(std::cos(alpha)), sin_a = static_cast<float>(std::sin(alpha));
  // More poses than there is room for (the tracker never passes them): their union alone.
  const bool per_pose = prior_->num_poses <= limits::kMaxLisCandidates;
  for (int p = 0; p < prior_->num_poses; ++p) {
    const BodyPose& q = prior_->poses[p];
    auto& sets = pose_allowed_[static_cast<std::size_t>(per_pose ? p : 0)];
    std::uint32_t cameras_done = 0;
    for (int i = 0; i < num_sel_; ++i) {
      const BodyRay& ray = rays_[static_cast<std::size_t>(i)];
      const auto k = static_cast<std::size_t>(blobs_[sel_[static_cast<std::size_t>(i)]].camera);
      // (ExplainsAFourth's scratch, free before the search: the offsets and the thresholds.)
      CameraOffsets& c = offsets_[k];
      if ((cameras_done >> k & 1U) == 0) {
        cameras_done |= 1U << k;
        res->cost += kCostPriorPerCameraBeacon * nb;
        const auto m = static_cast<float>(prior_->max_m + prior_->raw_slack_m + ray.o_b.norm() * alpha);
        const Eigen::Vector3f o_w = (q.C_w_b * ray.o_b + q.r_w_wb).cast<float>();
        for (int b = 0; b < nb; ++b) {
          const auto sb = static_cast<std::size_t>(b);
          c.x[sb] = beacon_x_[sb] - o_w.x();
          c.y[sb] = beacon_y_[sb] - o_w.y();
          c.z[sb] = beacon_z_[sb] - o_w.z();
          const float d2 = c.x[sb] * c.x[sb] + c.y[sb] * c.y[sb] + c.z[sb] * c.z[sb];
          c.cos_sq_len_sq[sb] = d2 <= m * m ? -std::numeric_limits<float>::infinity()
                                            : cos_a * std::sqrt(d2 - m * m) - sin_a * m;
        }
      }
      res->cost += kCostPriorPerBlobBeacon * nb;
      const Eigen::Vector3f d_w = (q.C_w_b * ray.d_b).cast<float>();
      BeaconSet& set = sets[static_cast<std::size_t>(i)];
      set.Reset();
      for (int b = 0; b < nb; ++b) {
        const auto sb = static_cast<std::size_t>(b);
        if (c.x[sb] * d_w.x() + c.y[sb] * d_w.y() + c.z[sb] * d_w.z() >= c.cos_sq_len_sq[sb]) set.Set(b);
      }
    }
    ApplyAnchors(sets.data());
    std::uint16_t blobs = 0;
    for (int i = 0; i < num_sel_; ++i) {
      const BeaconSet& set = sets[static_cast<std::size_t>(i)];
      allowed_[static_cast<std::size_t>(i)] |= set;
      if (!set.Empty()) blobs = static_cast<std::uint16_t>(blobs | 1U << i);
    }
    pose_blobs_[static_cast<std::size_t>(per_pose ? p : 0)] = blobs;
  }
  num_pose_sets_ = per_pose ? prior_->num_poses : 0;
}

// An anchored blob is its beacon, and no other blob of its camera is: applied to one set per
// selected blob.
void LostInSpace::ApplyAnchors(BeaconSet* allowed) const {
  for (int i = 0; i < num_sel_; ++i) {
    const int beacon = blob_anchor_[static_cast<std::size_t>(sel_[static_cast<std::size_t>(i)])];
    if (beacon < 0) continue;
    const int camera = blobs_[sel_[static_cast<std::size_t>(i)]].camera;
    for (int j = 0; j < num_sel_; ++j) {
      if (j == i) {
        const bool had = allowed[j].Has(beacon);
        allowed[j] = BeaconSet{};
        if (had) allowed[j].Set(beacon);
      } else if (blobs_[sel_[static_cast<std::size_t>(j)]].camera == camera) {
        allowed[j].Clear(beacon);
      }
    }
  }
}

// Feasibility bits of selected blobs (i, j), i < j: bit b of row a when beacons (a, b) may
// be seen along rays (i, j): their distance within the rays' segment distance range and, for
// rays of one camera, their angle within the co-visibility table's range; with a prior, only
// the beacons it allows for each blob. Computed on first use in an Identify.
const std::array<BeaconSet, limits::kMaxBeacons>& LostInSpace::Feasible(int i, int j) {
  const auto pi = static_cast<std::size_t>(PairIndex(i, j));
  const auto range = static_cast<std::size_t>(band_);
  auto& f = feasible_[range][pi];
  if (feasible_done_[range][pi]) return f;
  feasible_done_[range][pi] = true;
  const int nb = rig_->num_beacons;
  const BodyRay& ri = rays_[static_cast<std::size_t>(i)];
  const BodyRay& rj = rays_[static_cast<std::size_t>(j)];
  double lo = 0.0, hi = 0.0;
  SegmentDistanceRange(ri, rj, p3p_min_m_, p3p_max_m_, &lo, &hi);
  const auto flo = static_cast<float>(lo - pair_tol_m_), fhi = static_cast<float>(hi + pair_tol_m_);
  const bool same_camera = blobs_[sel_[static_cast<std::size_t>(i)]].camera == blobs_[sel_[static_cast<std::size_t>(j)]].camera;
  const double angle = std::acos(std::clamp(ri.d_b.dot(rj.d_b), -1.0, 1.0));
  // The ray angle within [min - tol, max + tol]: cos(angle + tol) <= cos_min, cos(angle - tol) >= cos_max.
  const auto c_lo = static_cast<float>(std::cos(std::min(kPi, angle + pair_tol_rad_)));
  const auto c_hi = static_cast<float>(std::cos(std::max(0.0, angle - pair_tol_rad_)));
  const BeaconSet& allowed_j = allowed_[static_cast<std::size_t>(j)];
  for (int a = 0; a < nb; ++a) {
    BeaconSet bits;
    const auto sa = static_cast<std::size_t>(a);
    if (allowed_[static_cast<std::size_t>(i)].Has(a)) {
      const auto& da = dist_[sa];
      for (int b = 0; b < nb; ++b) {
        const auto sb = static_cast<std::size_t>(b);
        if (b == a || da[sb] < flo || da[sb] > fhi) continue;
        if (same_camera) {
          const std::size_t x = std::min(sa, sb), y = std::max(sa, sb);
          const float cmin = cos_min_angle_[x][y], cmax = cos_max_angle_[x][y];
          if (cmin > 1.5F || c_lo > cmin || c_hi < cmax) continue;
        }
        bits.Set(b);
      }
      bits &= allowed_j;
    }
    f[sa] = bits;
  }
  return f;
}

// The search's work list: every blob triple over each of the num_bands nested depth ranges
// (band_max_m_: the near ones below the full one, then the full one). Same-camera triples
// first, the nearest range, the next, ..., then the full one, then the cross-camera ones
// likewise: a same-camera triple's ray angles prune its beacon triples (the
// co-visibility table) and its solve is closed-form, while a cross-camera pair is pruned by its
// distance only and its solve scans (checked on 150 sampled views of station maps: ordering
// the items by their exact number of beacon triples instead reaches the true one 1.4-5x later
// in five of six map rows, docs/acquisition.md; against session 6's order, where the near
// range of every triple came first, the matrix's first-fix lag fell). Within a group, a
// same-camera triple by its largest ray angle (fewer beacon pairs are seen under a small
// angle), a cross-camera one in the order of selection (brightest first; of steady blobs, those
// over two cameras before those over three: session 36). With at least three
// steady blobs selected, the triples of three steady blobs come first (same-camera, then
// cross-camera, each triple's ranges in a row): most other triples hold a spurious blob.
void LostInSpace::OrderItems(int num_bands) {
  const bool steady_first = num_sel_steady_ >= 3;
  num_items_ = 0;
  int t = 0;
  const auto& d = [&](int x) { return rays_[static_cast<std::size_t>(x)].d_b; };
  for (int k = 2; k < num_sel_; ++k)
    for (int j = 1; j < k; ++j)
      for (int i = 0; i < j; ++i, ++t) {
        if (sel_anchored_[static_cast<std::size_t>(i)] + sel_anchored_[static_cast<std::size_t>(j)] +
                sel_anchored_[static_cast<std::size_t>(k)] < anchors_per_triple_)
          continue;
        triples_[static_cast<std::size_t>(t)] =
            Triple{static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(j), static_cast<std::uint8_t>(k)};
        const int ci = blobs_[sel_[static_cast<std::size_t>(i)]].camera;
        const int cj = blobs_[sel_[static_cast<std::size_t>(j)]].camera;
        const int ck = blobs_[sel_[static_cast<std::size_t>(k)]].camera;
        const bool same = ci == cj && ci == ck;
        const bool three_cameras = ci != cj && ci != ck && cj != ck;
        const double widest = std::max({std::acos(std::clamp(d(i).dot(d(j)), -1.0, 1.0)),
                                        std::acos(std::clamp(d(i).dot(d(k)), -1.0, 1.0)),
                                        std::acos(std::clamp(d(j).dot(d(k)), -1.0, 1.0))});
        for (int band = 0; band < num_bands; ++band) {
          // A steady triple's wider ranges follow its nearest one at once: its blobs are most
          // likely beacons, at any depth, and a near pass over every steady triple first
          // spent whole searches short of the truth (a 128-beacon cylinder with 20 beacons in
          // view: 20 000 hypotheses over 240 near items).
          const bool all_steady = steady_first && sel_steady_[static_cast<std::size_t>(i)] &&
                                  sel_steady_[static_cast<std::size_t>(j)] && sel_steady_[static_cast<std::size_t>(k)];
          const int cls = all_steady ? (same ? 0 : 1) : (steady_first ? 2 : 0) + (same ? 0 : 1);
          const int group = cls * kMaxBands + (all_steady ? 0 : band);
          // Among the cross-camera triples of steady blobs, those with two blobs in one camera
          // first: that pair's angle prunes its beacon pairs (the co-visibility table) where
          // three cameras leave only distances, thousands of beacon triples more in a large map
          // (seen: a 64-beacon cylinder's first fix 140 frame sets after four beacons were in
          // view, 59 with this order; NavMatrix.SteadyTriplesOverTwoCamerasAreSearchedFirst).
          const float key = same ? static_cast<float>(widest)
                                 : static_cast<float>(t + (all_steady && three_cameras ? kMaxTriples : 0));
          items_[static_cast<std::size_t>(num_items_++)] = Item{static_cast<std::uint16_t>(t), static_cast<std::uint8_t>(band),
                                                                same, group, key};
        }
      }
  // (std::sort with the index as tie-break: deterministic, and no heap.)
  std::sort(items_.begin(), items_.begin() + num_items_, [](const Item& a, const Item& b) {
    if (a.group != b.group) return a.group < b.group;
    if (a.key != b.key) return a.key < b.key;
    return a.t < b.t || (a.t == b.t && a.band < b.band);  // a triple's nearer item first
  });
  for (auto& done : band_done_) done.fill(false);
}

// LisOptions::steady_list: moves to the front the items of the steady triples that cover every
// four steady selected blobs - of each four, the triple with the fewest beacon triples over the
// full range (counted exactly, CountTriples; the count's cost charged) - keeping their order,
// when their work fits max_hypotheses (else nothing changes).
void LostInSpace::SteadyItemsFirst(LisResult* result) {
  std::array<int, limits::kMaxLisBlobs> st{};
  int ns = 0;
  for (int i = 0; i < num_sel_; ++i)
    if (sel_steady_[static_cast<std::size_t>(i)]) st[static_cast<std::size_t>(ns++)] = i;
  const auto index = [](int i, int j, int k) { return k * (k - 1) * (k - 2) / 6 + j * (j - 1) / 2 + i; };  // OrderItems' t
  const int full = num_bands_ - 1, keep = band_;
  SetRange(full);
  std::array<bool, kMaxTriples> cover{};
  triple_count_.fill(-1);
  // A triple's work as the search counts it: its beacon triples, cross_camera_work each when its
  // blobs are not all in one camera.
  const auto work_of = [&](int i, int j, int k) {
    const int t = index(i, j, k);
    auto& n = triple_count_[static_cast<std::size_t>(t)];
    if (n < 0) {
      result->cost += kCostCountPerBeaconPair * rig_->num_beacons * rig_->num_beacons;
      n = CountTriples(triples_[static_cast<std::size_t>(t)], options_.max_hypotheses);
    }
    const int camera = blobs_[sel_[static_cast<std::size_t>(i)]].camera;
    const bool same = blobs_[sel_[static_cast<std::size_t>(j)]].camera == camera &&
                      blobs_[sel_[static_cast<std::size_t>(k)]].camera == camera;
    return n * (same ? 1 : options_.cross_camera_work);
  };
  long work = 0;  // the cover's
  for (int d = 3; d < ns; ++d)
    for (int c = 2; c < d; ++c)
      for (int b = 1; b < c; ++b)
        for (int a = 0; a < b; ++a) {
          const std::array<int, 4> q{st[static_cast<std::size_t>(a)], st[static_cast<std::size_t>(b)],
                                     st[static_cast<std::size_t>(c)], st[static_cast<std::size_t>(d)]};
          int best = -1;
          long fewest = std::numeric_limits<long>::max();
          for (int skip = 3; skip >= 0; --skip) {  // the four triples of q (increasing indices)
            std::array<int, 3> t{};
            for (int m = 0, n = 0; m < 4; ++m)
              if (m != skip) t[static_cast<std::size_t>(n++)] = q[static_cast<std::size_t>(m)];
            const long n = work_of(t[0], t[1], t[2]);
            if (n < fewest) {
              fewest = n;
              best = index(t[0], t[1], t[2]);
            }
          }
          if (!cover[static_cast<std::size_t>(best)]) work += fewest;
          cover[static_cast<std::size_t>(best)] = true;
          // A list that the search's work units cannot reach is no list (the search goes on as
          // without the option; counted no further).
          if (work > options_.max_hypotheses) {
            SetRange(keep);
            return;
          }
        }
  SetRange(keep);
  // (std::stable_partition may allocate: the chosen items, then the others, through a copy.)
  std::copy(items_.begin(), items_.begin() + num_items_, items_scratch_.begin());
  int n = 0;
  for (const bool chosen : {true, false}) {
    for (int x = 0; x < num_items_; ++x)
      if (cover[items_scratch_[static_cast<std::size_t>(x)].t] == chosen)
        items_[static_cast<std::size_t>(n++)] = items_scratch_[static_cast<std::size_t>(x)];
    if (chosen) num_steady_items_ = n;
  }
}

// Visits blob triples and their feasible beacon triples from the cursor on; at most `budget`
// work units (LisResult::work) in this call, o.max_hypotheses in the whole search. The cursor names the
// next hypothesis, so that a paused search resumes exactly where it stopped.
LostInSpace::SearchEnd LostInSpace::Search(int budget, double cost_budget, LisResult* res) {
  const Spent since{res->work, res->cost, budget, cost_budget};
  const SearchEnd items_end = SearchItems(since, res);
  if (items_end != SearchEnd::kDone || res->confirmed || steady_end_) return items_end;
  return ScoreDeferred(since, res);
}

// The work items from the cursor on: kDone when the last is done (or a pose confirmed).
LostInSpace::SearchEnd LostInSpace::SearchItems(const Spent& since, LisResult* res) {
  for (; cur_.item < num_items_; ++cur_.item, cur_ = Cursor{cur_.item}) {
    const Item& item = items_[static_cast<std::size_t>(cur_.item)];
    const Triple& tr = triples_[item.t];
    cur_i_ = tr.i;
    cur_j_ = tr.j;
    cur_k_ = tr.k;
    SetRange(item.band);
    if (!cur_.ready) {
      ++res->blob_triples;
      triple_.Set({rays_[tr.i], rays_[tr.j], rays_[tr.k]}, p3p_);
      cur_.ready = true;
      if (++tried_stamp_ == 0) {  // (wrapped: no slot may look current)
        tried_.fill(TriedSlot{});
        tried_stamp_ = 1;
      }
    }
    SearchEnd end = SearchEnd::kDone;
    if (!SearchPoseSets(item, since, res, &end)) return end;
    band_done_[item.band][item.t] = true;
    if (cur_.item + 1 == num_steady_items_) {
      steady_end_ = true;
      res->steady_complete = !overflow_;
      return SearchEnd::kDone;
    }
  }
  return SearchEnd::kDone;
}

// The poses the steady-fourth rule deferred, scored as they would have been without it (each
// a full reprojection, within the budgets): a search that reaches its end lists every pose.
// kDone when the last is scored or one is confirmed.
LostInSpace::SearchEnd LostInSpace::ScoreDeferred(const Spent& since, LisResult* res) {
  SearchEnd end = SearchEnd::kDone;
  for (; next_deferred_ < num_deferred_ && !res->confirmed; ++next_deferred_) {
    if (!WithinBudget(since, *res, &end, /*work_cap=*/false)) return end;
    ScoreMatched(deferred_[static_cast<std::size_t>(next_deferred_)], options_, res);
  }
  return SearchEnd::kDone;
}

// Whether the search may go on: false when it has spent its budget (kBudgetOut: max_cost, and
// max_hypotheses if work_cap) or this call's (kPaused; it resumes where it stopped).
bool LostInSpace::WithinBudget(const Spent& since, const LisResult& res, SearchEnd* end, bool work_cap) const {
  if ((work_cap && res.work >= options_.max_hypotheses) || res.cost >= options_.max_cost) {
    *end = SearchEnd::kBudgetOut;
    return false;
  }
  if (res.work - since.work >= since.budget || res.cost - since.cost >= since.cost_budget) {
    *end = SearchEnd::kPaused;
    return false;
  }
  return true;
}

// The current item's beacon triples, from the cursor on: those one prior pose allows for all
// three blobs, pose by pose (without a pose prior, the one set of allowed_). False when the
// search stops within the item (*end says why).
bool LostInSpace::SearchPoseSets(const Item& item, const Spent& since, LisResult* res, SearchEnd* end) {
  const Triple& tr = triples_[item.t];
  const auto& fij = Feasible(tr.i, tr.j);
  const auto& fik = Feasible(tr.i, tr.k);
  const auto& fjk = Feasible(tr.j, tr.k);
  // The beacon triples the triple's item of the range before (nested in this one) tried are
  // skipped.
  const int prev = item.band - 1;
  const bool skip_tried = prev >= 0 && band_done_[static_cast<std::size_t>(prev)][item.t];
  const int unit = item.same_camera ? 1 : options_.cross_camera_work;
  // Beacons a without a third (none along ray k) and b without one are skipped unvisited (with
  // many spurious blobs most feasible pairs have none; visiting them cost 35 ms of one frame
  // set, uncounted by the budget: 64 spurious blobs per camera, session 34).
  // (Only the beacons the prior allows for the blob can have bits.)
  BeaconSet a_with_third, b_with_third;
  const BeaconSet& ai = allowed_[tr.i];
  const BeaconSet& bj = allowed_[tr.j];
  for (int a = ai.First(); a >= 0; a = ai.Next(a + 1))
    if (!fik[static_cast<std::size_t>(a)].Empty()) a_with_third.Set(a);
  for (int b = bj.First(); b >= 0; b = bj.Next(b + 1))
    if (!fjk[static_cast<std::size_t>(b)].Empty()) b_with_third.Set(b);
  const bool per_pose = num_pose_sets_ > 0;
  const int num_sets = per_pose ? num_pose_sets_ : 1;
  const auto need = static_cast<std::uint16_t>(1U << tr.i | 1U << tr.j | 1U << tr.k);
  for (; cur_.p < num_sets; ++cur_.p, cur_.a = 0, cur_.b = cur_.c = -1) {
    const auto sp = static_cast<std::size_t>(cur_.p);
    if (per_pose && (pose_blobs_[sp] & need) != need) continue;
    const BeaconSet* sets = per_pose ? pose_allowed_[sp].data() : allowed_.data();
    const BeaconSet as = sets[tr.i] & a_with_third;
    for (int a = as.Next(cur_.a); a >= 0; a = as.Next(a + 1), cur_.b = cur_.c = -1) {
      cur_.a = a;
      const BeaconSet bs = fij[static_cast<std::size_t>(a)] & b_with_third & sets[tr.j];
      for (int b = cur_.b < 0 ? bs.First() : cur_.b; b >= 0; b = bs.Next(b + 1), cur_.c = -1) {
        cur_.b = b;
        BeaconSet cs = fik[static_cast<std::size_t>(a)] & fjk[static_cast<std::size_t>(b)] & sets[tr.k];
        cs.Clear(a);
        cs.Clear(b);
        if (skip_tried && PairTriedIn(tr, prev, a, b)) cs = cs.Minus(ThirdsTriedIn(tr, prev, a, b));
        for (int c = cur_.c < 0 ? cs.First() : cur_.c; c >= 0; c = cs.Next(c + 1)) {
          cur_.c = c;
          if (!Hypothesis(a, b, c, unit, since, res, end)) return false;
        }
      }
    }
  }
  return true;
}

// One hypothesis within the budgets (of the search, then of this call): false when the search
// stops here (*end says why; a paused one resumes with this hypothesis).
bool LostInSpace::Hypothesis(int a, int b, int c, int unit, const Spent& since, LisResult* res, SearchEnd* end) {
  if (!WithinBudget(since, *res, end, /*work_cap=*/true)) return false;
  if (num_pose_sets_ > 1 && !FirstTry(a, b, c)) return true;  // another prior pose's already
  res->work += unit;
  hypothesis_work_ += unit;
  res->cost += unit;
  ++res->hypotheses;
  TryTriple(a, b, c, res);
  if (res->confirmed) {
    *end = SearchEnd::kDone;
    return false;
  }
  return true;
}

// Whether beacons (a, b, c) are new to the current item (and marks them tried).
bool LostInSpace::FirstTry(int a, int b, int c) {
  static_assert(limits::kMaxBeacons <= 256, "a beacon index is 8 bits of the key");
  static_assert((kTriedSlots & (kTriedSlots - 1)) == 0, "a power of two");
  const std::uint32_t key = (static_cast<std::uint32_t>(a) << 16 | static_cast<std::uint32_t>(b) << 8 |
                             static_cast<std::uint32_t>(c)) + 1U;
  std::uint32_t h = (key * 2654435761U) >> 20U;  // (Fibonacci hashing onto 12 bits)
  for (int n = 0; n < 8; ++n, h = (h + 1U) & static_cast<std::uint32_t>(kTriedSlots - 1)) {
    TriedSlot& s = tried_[h];
    if (s.stamp != tried_stamp_) {
      s = TriedSlot{key, tried_stamp_};
      return true;
    }
    if (s.key == key) return false;
  }
  return true;  // (no room nearby: tried again, which costs a solve and changes nothing)
}

// Whether the item of triple tr over range `band` had beacons (a, b) on its first pair, and the
// third beacons it tried with them (each range keeps its own pair bits).
bool LostInSpace::PairTriedIn(const Triple& tr, int band, int a, int b) const {
  const auto pi = static_cast<std::size_t>(PairIndex(tr.i, tr.j));
  const auto r = static_cast<std::size_t>(band);
  return feasible_done_[r][pi] && feasible_[r][pi][static_cast<std::size_t>(a)].Has(b);
}

BeaconSet LostInSpace::ThirdsTriedIn(const Triple& tr, int band, int a, int b) const {
  const auto r = static_cast<std::size_t>(band);
  return feasible_[r][static_cast<std::size_t>(PairIndex(tr.i, tr.k))][static_cast<std::size_t>(a)] &
         feasible_[r][static_cast<std::size_t>(PairIndex(tr.j, tr.k))][static_cast<std::size_t>(b)];
}

// A near range pairs beacons as if within band_max_m_[band] of the cameras (the nearest
// near_depth_m, each next twice the last, the last the full range): in a dense map many beacons
// are that near, and the short range prunes beacon pairs by their distance. (The solver's scan
// keeps the full range: a triple of near pairs may still have a beacon beyond it.) Each range
// keeps its own pair bits.
void LostInSpace::SetRange(int band) {
  band_ = band;
  p3p_min_m_ = p3p_.min_depth_m;
  p3p_max_m_ = band_max_m_[static_cast<std::size_t>(band)];
}

// One hypothesis: the P3P poses of beacons (a, b, c) along the current rays, scored when they
// lie in the workspace with the three beacons facing the body (0.15 rad for the lever arm).
void LostInSpace::TryTriple(int a, int b, int c, LisResult* res) {
  const std::array<Eigen::Vector3d, 3> P_w = {rig_->beacons_w[static_cast<std::size_t>(a)],
                                              rig_->beacons_w[static_cast<std::size_t>(b)],
                                              rig_->beacons_w[static_cast<std::size_t>(c)]};
  const int n = triple_.Solve(P_w, &solutions_, &depths_);
  for (int s = 0; s < n; ++s) {
    const BodyPose& pose = solutions_[static_cast<std::size_t>(s)];
    if (Plausible(pose, a, b, c)) Score(pose, options_, res, cur_.item < num_steady_items_ && WeakRoot(s, n));
  }
}

// Whether root s of the current triple's n (solutions_, depths_) has weak geometry, its pose
// ill-determined by the three rays (LisOptions::weak_fourth_blob_max_rad): a near twin (near
// the danger cylinder noise splits a double root into two, each centimetres off) or a nearly
// collinear triangle (the turn about its line is loose; with P3pOptions::near_double_residual
// also the real part of a complex pair). The thresholds are loose on purpose: a weak root only
// costs a wider fourth-blob test, and its listing still needs a refinement that explains four
// blobs. (A nearly singular depth Jacobian as a third sign found one more true pose, in a list
// of 79 000 units, beyond the tests' reach; not kept.)
bool LostInSpace::WeakRoot(int s, int n) const {
  constexpr double kTwinSpread = 0.25;    // relative depth difference (seen: 0.06-0.13)
  constexpr double kCollinear = 0.1;      // triangle height / longest side (seen: 0.02-0.07)
  const Eigen::Vector3d& l = depths_[static_cast<std::size_t>(s)];
  for (int t = 0; t < n; ++t) {
    const Eigen::Vector3d& m = depths_[static_cast<std::size_t>(t)];
    if (t != s && ((m - l).cwiseAbs().array() / l.array().min(m.array())).maxCoeff() <= kTwinSpread) return true;
  }
  const std::array<const BodyRay*, 3> r = {&rays_[static_cast<std::size_t>(cur_i_)], &rays_[static_cast<std::size_t>(cur_j_)],
                                           &rays_[static_cast<std::size_t>(cur_k_)]};
  std::array<Eigen::Vector3d, 3> q;
  for (std::size_t i = 0; i < 3; ++i) q[i] = r[i]->o_b + l(static_cast<Eigen::Index>(i)) * r[i]->d_b;
  const double L = std::max({(q[1] - q[0]).norm(), (q[2] - q[0]).norm(), (q[2] - q[1]).norm()});
  return (q[1] - q[0]).cross(q[2] - q[0]).norm() < kCollinear * L * L;
}

bool LostInSpace::Plausible(const BodyPose& pose, int a, int b, int c) const {
  return InWorkspace(pose.r_w_wb, options_) && BeaconFaces(*rig_, a, pose.r_w_wb, 0.15) &&
         BeaconFaces(*rig_, b, pose.r_w_wb, 0.15) && BeaconFaces(*rig_, c, pose.r_w_wb, 0.15) &&
         (prior_ == nullptr || NearPrior(pose, prior_->raw_slack_m, prior_->raw_slack_rad));
}

bool LostInSpace::NearPrior(const BodyPose& pose, double slack_m, double slack_rad) const {
  if (prior_ == nullptr || prior_->num_poses <= 0) return true;
  for (int i = 0; i < prior_->num_poses; ++i) {
    const BodyPose& q = prior_->poses[i];
    if ((pose.r_w_wb - q.r_w_wb).norm() <= prior_->max_m + slack_m &&
        LogSO3(q.C_w_b.transpose() * pose.C_w_b).norm() <= prior_->max_rad + slack_rad)
      return true;
  }
  return false;
}

// The prior's anchors over this search's blob list (blob_anchor_): each valid one once.
void LostInSpace::SetAnchors() {
  std::fill(blob_anchor_.begin(), blob_anchor_.begin() + num_blobs_, static_cast<short>(-1));
  num_anchors_ = 0;
  if (prior_ == nullptr || prior_->anchors == nullptr) return;
  for (int i = 0; i < prior_->num_anchors && i < limits::kMaxObservations; ++i) {
    const LisAnchor& a = prior_->anchors[i];
    if (a.blob < 0 || a.blob >= num_blobs_ || a.beacon < 0 || a.beacon >= rig_->num_beacons) continue;
    bool taken = blob_anchor_[static_cast<std::size_t>(a.blob)] >= 0;
    for (int b = 0; b < num_blobs_ && !taken; ++b)
      taken = blob_anchor_[static_cast<std::size_t>(b)] == a.beacon && blobs_[b].camera == blobs_[a.blob].camera;
    if (taken) continue;
    blob_anchor_[static_cast<std::size_t>(a.blob)] = static_cast<short>(a.beacon);
    ++num_anchors_;
  }
}

// Whether a candidate names at least min(anchors, 3) anchored blobs their beacons, the poses the
// anchored triples enumerate (matched afresh: its kept set holds at most
// limits::kMaxLisCandidateMatches of its matches).
bool LostInSpace::KeepsAnchors(const Candidate& c, const LisOptions& o) {
  if (num_anchors_ == 0) return true;
  matcher_.MatchPose(c.pose, o.refine_match, &match_scratch_);
  int kept = 0;
  for (int b = 0; b < num_blobs_; ++b) {
    const int beacon = blob_anchor_[static_cast<std::size_t>(b)];
    kept += beacon >= 0 && match_scratch_.BeaconOfBlob(b) == beacon;
  }
  return kept >= anchors_per_triple_;
}

LisStatus LostInSpace::Identify(const BlobObs* blobs, int num_blobs, const LisOptions& o, LisResult* result,
                                const LisPrior* prior, std::uint32_t cameras, const std::uint8_t* steady) {
  const LisStatus s = Begin(blobs, num_blobs, o, result, prior, cameras, steady);
  return s == LisStatus::kSearching ? Continue(o.max_hypotheses, result) : s;
}

LisStatus LostInSpace::Begin(const BlobObs* blobs, int num_blobs, const LisOptions& o, LisResult* result,
                             const LisPrior* prior, std::uint32_t cameras, const std::uint8_t* steady) {
  searching_ = false;
  prior_ = prior;
  LisResult& res = *result;
  res.status = LisStatus::kBadInput;
  res.pose = BodyPose{};
  res.matches.num_matches = 0;
  res.matches.num_beacons = 0;
  res.best_score = 0.0;
  res.second_score = -std::numeric_limits<double>::infinity();
  res.hypotheses = res.work = res.poses_scored = res.blob_triples = res.deferred = 0;
  res.cost = 0.0;
  res.false_alarms = 0.0;
  res.search_complete = res.confirmed = false;
  res.complete = false;
  res.steady_complete = false;
  res.num_consistent = 0;
  res.repeats = 0;
  num_steady_items_ = 0;
  steady_end_ = false;
  num_cand_ = 0;
  overflow_ = false;
  num_deferred_ = next_deferred_ = 0;
  deferred_lost_ = false;
  work_bound_ = -1;
  hypothesis_work_ = 0;
  num_repeated_ = 0;
  if (rig_ == nullptr || !o.IsValid() || num_blobs < 0 || num_blobs > limits::kMaxObservations ||
      (num_blobs > 0 && blobs == nullptr))
    return res.status;
  for (int i = 0; i < num_blobs; ++i)
    if (blobs[i].camera < 0 || blobs[i].camera >= rig_->num_cameras || !blobs[i].x_n.allFinite() ||
        !blobs[i].uv_px.allFinite())
      return res.status;
  if (num_blobs < 3 || rig_->num_beacons < 3) return res.status = LisStatus::kTooFewBlobs;
  options_ = o;
  p3p_ = o.p3p;
  if (p3p_.max_depth_m <= 0.0) p3p_.max_depth_m = map_diameter_m_ + o.workspace_margin_m;
  if (!p3p_.IsValid()) return res.status;
  // The search may outlive the caller's list (Continue in later frame sets): a copy.
  std::copy(blobs, blobs + num_blobs, own_blobs_.begin());
  blobs_ = own_blobs_.data();
  num_blobs_ = num_blobs;
  matcher_.SetBlobs(blobs_, num_blobs, cameras);
  SetAnchors();
  SelectBlobs(o, steady);
  // The nested depth ranges: near_depth_m, twice that, ... while below the full range, then it.
  num_bands_ = 0;
  for (double d = o.near_depth_m; num_bands_ < o.near_bands && d > p3p_.min_depth_m && d < p3p_.max_depth_m; d *= 2.0)
    band_max_m_[static_cast<std::size_t>(num_bands_++)] = d;
  band_max_m_[static_cast<std::size_t>(num_bands_++)] = p3p_.max_depth_m;
  pair_tol_m_ = o.pair_tolerance_m;
  pair_tol_rad_ = o.pair_angle_tolerance_rad;
  fourth_cos_sq_ = static_cast<float>(std::cos(o.fourth_blob_max_rad) * std::cos(o.fourth_blob_max_rad));
  weak_fourth_cos_sq_ = static_cast<float>(std::cos(o.weak_fourth_blob_max_rad) * std::cos(o.weak_fourth_blob_max_rad));
  PriorBeacons(&res);
  int anchored_sel = 0;
  for (int i = 0; i < num_sel_; ++i)
    anchored_sel += blob_anchor_[static_cast<std::size_t>(sel_[static_cast<std::size_t>(i)])] >= 0 ? 1 : 0;
  anchors_per_triple_ = std::min(anchored_sel, 3);
  for (auto& done : feasible_done_) done.fill(false);
  OrderItems(num_bands_);
  if (o.steady_list && num_sel_steady_ >= 4 && anchors_per_triple_ == 0) SteadyItemsFirst(&res);
  cur_ = Cursor{};
  searching_ = true;
  return res.status = LisStatus::kSearching;
}

LisStatus LostInSpace::Continue(int budget, LisResult* result, double cost_budget) {
  if (!searching_) return result->status;
  const SearchEnd end = Search(std::max(1, budget), cost_budget, result);
  if (end == SearchEnd::kPaused) return result->status = LisStatus::kSearching;
  searching_ = false;
  return Decide(end == SearchEnd::kBudgetOut, options_, result);
}

// The feasible beacon triples of blob triple tr over the current range; once above cap, some
// count above it (the rest is not counted: in a 256-beacon map a triple over three cameras
// holds up to 16 million, ~1 ms to count).
long LostInSpace::CountTriples(const Triple& tr, long cap) {
  const auto& fij = Feasible(tr.i, tr.j);
  const auto& fik = Feasible(tr.i, tr.k);
  const auto& fjk = Feasible(tr.j, tr.k);
  long n = 0;
  for (int a = 0; a < rig_->num_beacons && n <= cap; ++a) {
    const BeaconSet& ta = fik[static_cast<std::size_t>(a)];
    if (ta.Empty()) continue;
    const BeaconSet& bs = fij[static_cast<std::size_t>(a)];
    for (int b = bs.First(); b >= 0; b = bs.Next(b + 1)) {
      // The thirds SearchPoseSets tries: both pairs feasible, neither beacon of the pair itself.
      const BeaconSet thirds = ta & fjk[static_cast<std::size_t>(b)];
      n += thirds.Count() - (thirds.Has(a) ? 1 : 0) - (thirds.Has(b) ? 1 : 0);
    }
  }
  return n;
}

bool LostInSpace::MayComplete(LisResult* result) {
  if (overflow_) return false;
  if (num_pose_sets_ > 1) return true;  // (several poses may allow a triple: not counted)
  if (work_bound_ < 0) {
    // The hypotheses of every blob triple over the full range: its nested ranges together try
    // the same beacon triples once (SearchPoseSets skips those the range before tried).
    const int full = num_bands_ - 1, keep = band_;
    SetRange(full);
    long work = 0;
    const int nb = rig_->num_beacons;
    for (int t = 0; t < num_items_ && work <= options_.max_hypotheses; ++t) {
      const Item& item = items_[static_cast<std::size_t>(t)];
      if (item.band != full) continue;
      result->cost += kCostCountPerBeaconPair * nb * nb;
      const int unit = item.same_camera ? 1 : options_.cross_camera_work;
      work += CountTriples(triples_[item.t], (options_.max_hypotheses - work) / unit) * unit;
    }
    SetRange(keep);
    work_bound_ = static_cast<int>(std::min<long>(work, std::numeric_limits<int>::max()));
  }
  return static_cast<long>(result->work) + work_bound_ - hypothesis_work_ <= options_.max_hypotheses;
}

LisStatus LostInSpace::Stop(LisResult* result) {
  if (!searching_) return result->status;
  searching_ = false;
  return Decide(true, options_, result);
}

LisStatus LostInSpace::Decide(bool budget_out, const LisOptions& o, LisResult* result) {
  LisResult& res = *result;
  // A search that deferred more poses than it could keep (LisOptions::steady_fourth) has not
  // listed every pose: like one cut by its budget, it fixes only on a confirmed pose.
  const bool cut = budget_out || deferred_lost_;
  res.search_complete = !cut && !res.confirmed && !steady_end_;
  // Refine every kept pose; those that predict a beacon well inside an image where no blob is
  // (missing) are refuted, the others are consistent with the blobs. Merge the ones that
  // turned out the same, rank by score. A search cut by its budget before a confirmed pose
  // can neither fix nor give a complete list (which alone the tracker follows), so its raw
  // poses are not refined: that was up to 256 refinements after the budget had run out (seen:
  // +45 % on a 10-beacon map's cold searches with clutter, 13 ms frame sets).
  const bool refine_raw = !cut || res.confirmed || res.steady_complete;
  int kept = 0;
  for (int i = 0; i < num_cand_; ++i) {
    Candidate& c = cand_[static_cast<std::size_t>(i)];
    if (!c.refined && !refine_raw) continue;
    if (!c.refined) res.cost += kCostRefine;
    if (!c.refined && !Refine(&c, o)) continue;
    if (UnexcusedMissing(c.set, o) > o.max_missing || !NearPrior(c.pose, 0.0, 0.0) || !KeepsAnchors(c, o)) continue;
    if (c.weak && c.set.num_beacons < 4) continue;  // (its wide fourth did not hold: a three-beacon pose)
    bool merged = false;
    for (int j = 0; j < kept && !merged; ++j) {
      Candidate& k = cand_[static_cast<std::size_t>(j)];
      if (SamePose(k, c, o)) {
        if (c.score > k.score) k = c;
        merged = true;
      }
    }
    if (!merged) cand_[static_cast<std::size_t>(kept++)] = c;
  }
  num_cand_ = kept;
  std::sort(cand_.begin(), cand_.begin() + num_cand_, [](const Candidate& a, const Candidate& b) {
    return a.score > b.score || (a.score == b.score && a.set.sum_sq_px < b.set.sum_sq_px);
  });
  res.complete = res.search_complete && !overflow_;
  res.num_consistent = num_cand_;
  for (int i = 0; i < num_cand_; ++i) {
    res.consistent_poses[static_cast<std::size_t>(i)] = cand_[static_cast<std::size_t>(i)].pose;
    res.consistent_scores[static_cast<std::size_t>(i)] = cand_[static_cast<std::size_t>(i)].score;
  }
  // (A deferred pose may be a rival: ambiguous rather than nothing.)
  const LisStatus cut_status = budget_out ? LisStatus::kBudgetExhausted : LisStatus::kAmbiguous;
  const LisStatus none = cut ? cut_status : LisStatus::kNoHypothesis;
  if (num_cand_ == 0) return res.status = none;
  const Candidate& best = cand_[0];
  res.pose = best.pose;
  res.best_score = best.score;
  if (num_cand_ > 1) res.second_score = cand_[1].score;
  // The best pose's full identities (the kept list may be truncated).
  matcher_.MatchPose(best.pose, o.refine_match, &res.matches);
  if (best.set.num_beacons < o.min_beacons) return res.status = none;
  // A search cut short by a confirmed pose fixes on that pose or not at all: its list is
  // incomplete, so the best of the others is no elimination (seen when the confirmed pose was
  // merged into a twin whose near miss was not excused: a three-beacon pose 3.5 m off won).
  if (res.confirmed && !SamePose(best, confirmed_, o)) return res.status = LisStatus::kBudgetExhausted;
  if (steady_end_ && !res.confirmed) return res.status = LisStatus::kAmbiguous;  // (a list, never a fix)
  if (res.best_score - res.second_score < o.min_score_margin) return res.status = LisStatus::kAmbiguous;
  if (cut && !res.confirmed) return res.status = cut_status;
  // The fix: a last solve over the final identities gives covariance and residuals.
  const SolveStatus s = SolvePose(*rig_, blobs_, num_blobs_, res.matches.matches.data(), res.matches.num_matches,
                                  best.pose, o.solve, &res.solve);
  if (s != SolveStatus::kOk || res.solve.rms_px > o.max_rms_px) return res.status = LisStatus::kNoHypothesis;
  res.pose = res.solve.pose;
  // Keep only the identities the solver kept as inliers.
  res.matches.Retain([&](int i, const Match&) { return res.solve.inlier[static_cast<std::size_t>(i)]; });
  if (res.matches.num_beacons < o.min_beacons) return res.status = LisStatus::kNoHypothesis;
  return res.status = LisStatus::kFix;
}

}  // namespace mfns::fw
