#include "firmware/modules/identify/lost_in_space.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "common/rotation/rotation.h"

namespace mfns::fw {
namespace {

constexpr int PairIndex(int i, int j) { return j * (j - 1) / 2 + i; }  // i < j

// The same identities.
template <int kA, int kB>
bool SameSet(const MatchList<kA>& a, const MatchList<kB>& b) {
  int shared = 0;
  return a.num_matches == b.num_matches && Compatible(a, b, &shared) && shared == a.num_matches;
}

}  // namespace

const char* ToString(LisStatus s) {
  switch (s) {
    case LisStatus::kFix: return "fix";
    case LisStatus::kAmbiguous: return "ambiguous: distinct poses explain the blobs equally well";
    case LisStatus::kNoHypothesis: return "no pose explains enough beacons";
    case LisStatus::kBudgetExhausted: return "hypothesis budget exhausted before a confirmed pose";
    case LisStatus::kTooFewBlobs: return "fewer than 3 blobs";
    case LisStatus::kBadInput: return "bad options, rig or blobs";
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
  else if (max_blobs < 3 || max_blobs > limits::kMaxLisBlobs) bad = "max_blobs";
  else if (!hypothesis_match.IsValid()) bad = "hypothesis_match";
  else if (!refine_match.IsValid()) bad = "refine_match";
  else if (!(miss_weight >= 0.0) || !std::isfinite(miss_weight)) bad = "miss_weight";
  else if (!(min_score_margin > 0.0) || !std::isfinite(min_score_margin)) bad = "min_score_margin";
  else if (max_missing < 0) bad = "max_missing";
  else if (min_beacons < 3 || min_beacons > limits::kMaxBeacons) bad = "min_beacons";
  else if (confirm_beacons != 0 && confirm_beacons < min_beacons + 1) bad = "confirm_beacons";
  else if (!(max_rms_px > 0.0)) bad = "max_rms_px";
  else if (!(pair_tolerance_m >= 0.0) || !std::isfinite(pair_tolerance_m)) bad = "pair_tolerance_m";
  else if (!(workspace_margin_m >= 0.0) || !std::isfinite(workspace_margin_m)) bad = "workspace_margin_m";
  else if (!workspace_auto && !(workspace_min_w.array() <= workspace_max_w.array()).all()) bad = "workspace";
  else if (!(same_pose_m > 0.0) || !(same_pose_rad > 0.0)) bad = "same_pose";
  else if (!solve.IsValid(&sub)) bad = sub;
  if (why != nullptr) *why = bad != nullptr ? bad : "ok";
  return bad == nullptr;
}

bool LostInSpace::Reset(const Rig& rig) {
  rig_ = nullptr;
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
      dist_[static_cast<std::size_t>(a)][static_cast<std::size_t>(b)] = d;
      map_diameter_m_ = std::max(map_diameter_m_, d);
    }
  }
  return true;
}

bool LostInSpace::InWorkspace(const Eigen::Vector3d& r, const LisOptions& o) const {
  const Eigen::Vector3d lo = o.workspace_auto ? (map_min_w_.array() - o.workspace_margin_m).matrix() : o.workspace_min_w;
  const Eigen::Vector3d hi = o.workspace_auto ? (map_max_w_.array() + o.workspace_margin_m).matrix() : o.workspace_max_w;
  return (r.array() >= lo.array()).all() && (r.array() <= hi.array()).all();
}

bool LostInSpace::SamePose(const Candidate& a, const Candidate& b, const LisOptions& o) const {
  int shared = 0;
  if (!Compatible(a.set, b.set, &shared)) return false;
  // Four shared identities determine the pose; three leave the P3P's discrete ambiguity (up to
  // four poses through the same three identities), so then the poses must be close too.
  if (shared >= 4) return true;
  return (a.pose.r_w_wb - b.pose.r_w_wb).norm() <= o.same_pose_m &&
         LogSO3(a.pose.C_w_b.transpose() * b.pose.C_w_b).norm() <= o.same_pose_rad;
}

void LostInSpace::Insert(const Candidate& c, const LisOptions& o) {
  for (int i = 0; i < num_cand_; ++i) {
    Candidate& k = cand_[static_cast<std::size_t>(i)];
    if (!SamePose(k, c, o)) continue;
    if (c.score > k.score || (c.refined && !k.refined && c.score >= k.score)) k = c;
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
  // A P3P pose fits its three blobs exactly: when those are all it matches, it is already the
  // least-squares solution; only the tight re-match remains.
  if (c->set.num_matches == 3 && c->set.sum_sq_px < 1e-12) {
    matcher_.MatchPose(c->pose, o.refine_match, &match_scratch_);
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
    matcher_.MatchPose(c->pose, o.refine_match, &match_scratch_);
    const bool stable = SameSet(match_scratch_, c->set);
    c->set.CopyFrom(match_scratch_);
    if (stable) break;
  }
  c->score = c->set.Score(o.miss_weight);
  return c->set.num_beacons >= o.min_beacons && c->rms_px <= o.max_rms_px;
}

void LostInSpace::Score(const BodyPose& pose, const LisOptions& o, LisResult* result) {
  ++result->poses_scored;
  matcher_.MatchPose(pose, o.hypothesis_match, &match_scratch_);
  // Too few beacons, or refuted even allowing for the raw pose's error at the margins.
  if (match_scratch_.num_beacons < o.min_beacons || match_scratch_.num_missing > o.max_missing + 1) return;
  scratch_.pose = pose;
  scratch_.refined = false;
  scratch_.set.CopyFrom(match_scratch_);
  scratch_.score = scratch_.set.Score(o.miss_weight);
  if (o.confirm_beacons > 0 && scratch_.set.num_beacons >= o.confirm_beacons && scratch_.set.num_missing == 0) {
    if (!Refine(&scratch_, o)) return;
    if (scratch_.set.num_beacons >= o.confirm_beacons && scratch_.set.num_missing == 0) result->confirmed = true;
  }
  Insert(scratch_, o);
}

void LostInSpace::SelectBlobs(const LisOptions& o) {
  // Brightest first within each camera, cameras in turn.
  std::array<std::array<short, limits::kMaxBlobsPerFrame>, limits::kMaxCameras> order{};
  for (int k = 0; k < rig_->num_cameras; ++k) {
    auto& ok = order[static_cast<std::size_t>(k)];
    const int n = matcher_.BlobsInCamera(k);
    for (int j = 0; j < n; ++j) ok[static_cast<std::size_t>(j)] = static_cast<short>(matcher_.BlobOfCamera(k, j));
    // (std::sort with the index as tie-break: deterministic like a stable sort, and no heap.)
    std::sort(ok.begin(), ok.begin() + n,
              [&](short a, short b) { return blobs_[a].flux > blobs_[b].flux || (blobs_[a].flux == blobs_[b].flux && a < b); });
  }
  num_sel_ = 0;
  for (int rank = 0; rank < limits::kMaxBlobsPerFrame && num_sel_ < o.max_blobs; ++rank)
    for (int k = 0; k < rig_->num_cameras && num_sel_ < o.max_blobs; ++k)
      if (rank < matcher_.BlobsInCamera(k))
        sel_[static_cast<std::size_t>(num_sel_++)] = order[static_cast<std::size_t>(k)][static_cast<std::size_t>(rank)];
  for (int i = 0; i < num_sel_; ++i)
    rays_[static_cast<std::size_t>(i)] = RayOfBlob(*rig_, blobs_[sel_[static_cast<std::size_t>(i)]]);
}

// With a prior, blob i can only be a beacon that some prior pose sees near blob i's ray: the
// angle between the ray and the beacon's direction is within the prior's attitude bound, plus
// what its position bound (and the raw slack) subtends at the beacon's distance.
BeaconSet LostInSpace::PriorBeacons(int i) const {
  const int nb = rig_->num_beacons;
  const BeaconSet all = BeaconSet::FirstN(nb);
  if (prior_ == nullptr || prior_->num_poses <= 0) return all;
  const BodyRay& ray = rays_[static_cast<std::size_t>(i)];
  const double max_rad = prior_->max_rad + prior_->raw_slack_rad;
  const double max_m = prior_->max_m + prior_->raw_slack_m + ray.o_b.norm() * max_rad;  // lever arm too
  BeaconSet set;
  for (int p = 0; p < prior_->num_poses && set != all; ++p) {
    const BodyPose& q = prior_->poses[p];
    const Eigen::Vector3d o_w = q.C_w_b * ray.o_b + q.r_w_wb;
    const Eigen::Vector3d d_w = q.C_w_b * ray.d_b;
    for (int a = 0; a < nb; ++a) {
      const Eigen::Vector3d u = rig_->beacons_w[static_cast<std::size_t>(a)] - o_w;
      const double dist = u.norm();
      if (dist <= max_m) {
        set.Set(a);
        continue;
      }
      const double angle = std::atan2(u.cross(d_w).norm(), u.dot(d_w));
      if (angle <= max_rad + std::asin(max_m / dist)) set.Set(a);
    }
  }
  return set;
}

void LostInSpace::PairFeasibility(const P3pOptions& p3p, const LisOptions& o) {
  // The beacons' distance within the rays' segment distance range; with a prior, only the
  // beacons it allows for each blob.
  const int nb = rig_->num_beacons;
  std::array<BeaconSet, limits::kMaxLisBlobs> allowed{};
  for (int i = 0; i < num_sel_; ++i) allowed[static_cast<std::size_t>(i)] = PriorBeacons(i);
  for (int j = 1; j < num_sel_; ++j) {
    for (int i = 0; i < j; ++i) {
      double lo = 0.0, hi = 0.0;
      SegmentDistanceRange(rays_[static_cast<std::size_t>(i)], rays_[static_cast<std::size_t>(j)], p3p.min_depth_m,
                           p3p.max_depth_m, &lo, &hi);
      lo -= o.pair_tolerance_m;
      hi += o.pair_tolerance_m;
      auto& f = feasible_[static_cast<std::size_t>(PairIndex(i, j))];
      for (int a = 0; a < nb; ++a) {
        BeaconSet bits;
        if (allowed[static_cast<std::size_t>(i)].Has(a)) {
          const auto& da = dist_[static_cast<std::size_t>(a)];
          for (int b = 0; b < nb; ++b)
            if (b != a && da[static_cast<std::size_t>(b)] >= lo && da[static_cast<std::size_t>(b)] <= hi)
              bits.Set(b);
          bits &= allowed[static_cast<std::size_t>(j)];
        }
        f[static_cast<std::size_t>(a)] = bits;
      }
    }
  }
}

bool LostInSpace::Search(const P3pOptions& p3p, const LisOptions& o, LisResult* res) {
  // Triples, brightest first: (i, j, k) with k the faintest of the three.
  const int nb = rig_->num_beacons;
  for (int k = 2; k < num_sel_; ++k) {
    for (int j = 1; j < k; ++j) {
      for (int i = 0; i < j; ++i) {
        ++res->blob_triples;
        triple_.Set({rays_[static_cast<std::size_t>(i)], rays_[static_cast<std::size_t>(j)],
                     rays_[static_cast<std::size_t>(k)]},
                    p3p);
        const auto& fij = feasible_[static_cast<std::size_t>(PairIndex(i, j))];
        const auto& fik = feasible_[static_cast<std::size_t>(PairIndex(i, k))];
        const auto& fjk = feasible_[static_cast<std::size_t>(PairIndex(j, k))];
        for (int a = 0; a < nb; ++a) {
          const BeaconSet& bs = fij[static_cast<std::size_t>(a)];
          for (int b = bs.First(); b >= 0; b = bs.Next(b + 1)) {
            BeaconSet cs = fik[static_cast<std::size_t>(a)] & fjk[static_cast<std::size_t>(b)];
            cs.Clear(a);
            cs.Clear(b);
            for (int c = cs.First(); c >= 0; c = cs.Next(c + 1)) {
              if (res->hypotheses >= o.max_hypotheses) return false;
              ++res->hypotheses;
              const int n = triple_.Solve({rig_->beacons_w[static_cast<std::size_t>(a)],
                                           rig_->beacons_w[static_cast<std::size_t>(b)],
                                           rig_->beacons_w[static_cast<std::size_t>(c)]},
                                          &solutions_);
              for (int s = 0; s < n; ++s) {
                const BodyPose& pose = solutions_[static_cast<std::size_t>(s)];
                if (InWorkspace(pose.r_w_wb, o) &&
                    (prior_ == nullptr || NearPrior(pose, prior_->raw_slack_m, prior_->raw_slack_rad)))
                  Score(pose, o, res);
              }
              if (res->confirmed) return true;
            }
          }
        }
      }
    }
  }
  return true;
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

LisStatus LostInSpace::Identify(const BlobObs* blobs, int num_blobs, const LisOptions& o, LisResult* result,
                                const LisPrior* prior, std::uint32_t cameras) {
  prior_ = prior;
  LisResult& res = *result;
  res.status = LisStatus::kBadInput;
  res.pose = BodyPose{};
  res.matches.num_matches = 0;
  res.matches.num_beacons = 0;
  res.best_score = 0.0;
  res.second_score = -std::numeric_limits<double>::infinity();
  res.hypotheses = res.poses_scored = res.blob_triples = 0;
  res.search_complete = res.confirmed = false;
  res.complete = false;
  res.num_consistent = 0;
  num_cand_ = 0;
  overflow_ = false;
  if (rig_ == nullptr || !o.IsValid() || num_blobs < 0 || num_blobs > limits::kMaxObservations ||
      (num_blobs > 0 && blobs == nullptr))
    return res.status;
  for (int i = 0; i < num_blobs; ++i)
    if (blobs[i].camera < 0 || blobs[i].camera >= rig_->num_cameras || !blobs[i].x_n.allFinite() ||
        !blobs[i].uv_px.allFinite())
      return res.status;
  if (num_blobs < 3 || rig_->num_beacons < 3) return res.status = LisStatus::kTooFewBlobs;
  blobs_ = blobs;
  num_blobs_ = num_blobs;
  matcher_.SetBlobs(blobs, num_blobs, cameras);
  SelectBlobs(o);
  P3pOptions p3p = o.p3p;
  if (p3p.max_depth_m <= 0.0) p3p.max_depth_m = map_diameter_m_ + o.workspace_margin_m;
  if (!p3p.IsValid()) return res.status;
  PairFeasibility(p3p, o);
  const bool budget_out = !Search(p3p, o, &res);
  return Decide(budget_out, o, &res);
}

LisStatus LostInSpace::Decide(bool budget_out, const LisOptions& o, LisResult* result) {
  LisResult& res = *result;
  res.search_complete = !budget_out && !res.confirmed;
  // Refine every kept pose; those that predict a beacon well inside an image where no blob is
  // (missing) are refuted, the others are consistent with the blobs. Merge the ones that
  // turned out the same, rank by score.
  int kept = 0;
  for (int i = 0; i < num_cand_; ++i) {
    Candidate& c = cand_[static_cast<std::size_t>(i)];
    if (!c.refined && !Refine(&c, o)) continue;
    if (c.set.num_missing > o.max_missing || !NearPrior(c.pose, 0.0, 0.0)) continue;
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
  const LisStatus none = budget_out ? LisStatus::kBudgetExhausted : LisStatus::kNoHypothesis;
  if (num_cand_ == 0) return res.status = none;
  const Candidate& best = cand_[0];
  res.pose = best.pose;
  res.best_score = best.score;
  if (num_cand_ > 1) res.second_score = cand_[1].score;
  // The best pose's full identities (the kept list may be truncated).
  matcher_.MatchPose(best.pose, o.refine_match, &res.matches);
  if (best.set.num_beacons < o.min_beacons) return res.status = none;
  if (res.best_score - res.second_score < o.min_score_margin) return res.status = LisStatus::kAmbiguous;
  if (budget_out && !res.confirmed) return res.status = LisStatus::kBudgetExhausted;
  // The fix: a last solve over the final identities gives covariance and residuals.
  const SolveStatus s = SolvePose(*rig_, blobs_, num_blobs_, res.matches.matches.data(), res.matches.num_matches,
                                  best.pose, o.solve, &res.solve);
  if (s != SolveStatus::kOk || res.solve.rms_px > o.max_rms_px) return res.status = LisStatus::kNoHypothesis;
  res.pose = res.solve.pose;
  // Keep only the identities the solver kept as inliers.
  int n = 0;
  for (int i = 0; i < res.matches.num_matches; ++i)
    if (res.solve.inlier[static_cast<std::size_t>(i)])
      res.matches.matches[static_cast<std::size_t>(n++)] = res.matches.matches[static_cast<std::size_t>(i)];
  res.matches.num_matches = n;
  res.matches.beacons.Reset();
  for (int i = 0; i < n; ++i) res.matches.beacons.Set(res.matches.matches[static_cast<std::size_t>(i)].beacon);
  res.matches.num_beacons = res.matches.beacons.Count();
  if (res.matches.num_beacons < o.min_beacons) return res.status = LisStatus::kNoHypothesis;
  return res.status = LisStatus::kFix;
}

}  // namespace mfns::fw
