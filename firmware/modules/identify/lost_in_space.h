// Lost-in-space beacon identification: blobs -> beacon identities and a pose, with no prior
// (issue 4 item 5; the paper matched beacons by hand).
//
// 1. Up to max_blobs blobs are taken, brightest first, cameras in turn; each is a ray in the
//    body frame.
// 2. Every blob pair gets, per beacon pair, a feasibility bit: the beacons' distance must lie
//    within the range of distances between the two rays' segments [min_depth, max_depth]
//    (this prunes a same-camera pair by its ray angle and a cross-camera pair by the lever arm).
// 3. Blob triples are visited brightest first; for each, every ordered beacon triple whose
//    three pairs are feasible goes through the generalized three-point solver (p3p.h), at
//    most max_hypotheses times per frame set.
// 4. Solution poses outside the workspace box are refused; the others are scored by
//    reprojecting the whole beacon map with visibility (match.h): matched blobs minus
//    miss_weight per beacon predicted well inside an image with no blob there. The best
//    distinct poses (up to limits::kMaxLisCandidates) are kept.
// 5. Each kept pose is refined with the joint solver (solve.h) and re-matched, until its
//    identities settle. A refined pose with a missing beacon is refuted; the rest are the
//    poses consistent with the blobs.
// 6. The best consistent pose is a fix only when it has >= min_beacons beacons, a small
//    residual, and beats every other consistent pose by min_score_margin matches. The default
//    margin, 2, keeps a wrong pose that happens to land one beacon on a spurious blob (likely
//    among thousands of hypotheses) from beating a true pose; a tie is kAmbiguous, never a
//    guess. A pose with confirm_beacons beacons and none missing ends the search early.
//
// With three or four beacons in view and narrow fields of view, several poses usually explain
// the blobs equally well (nothing else is in view to refute them): the result is then
// kAmbiguous with every consistent pose listed; when the list is complete the tracker
// (tracker.h) follows them all until the motion refutes all but one.
//
// Two poses are the same when their identities agree on every shared blob and beacon and
// either they share four identities or they lie within same_pose_m / same_pose_rad of each
// other (three identities alone leave the P3P's discrete ambiguity).
//
// Memory: one object (about 270 kB) holds every buffer; construct it at start (static or
// reserved), Reset() it with the rig, then Identify() never allocates.
#pragma once

#include <array>
#include <cstdint>

#include "common/limits.h"
#include "common/rig/rig.h"
#include "firmware/modules/identify/match.h"
#include "firmware/modules/identify/p3p.h"
#include "firmware/modules/solve/observation.h"
#include "firmware/modules/solve/solve.h"

namespace mfns::fw {

enum class LisStatus : unsigned char {
  kFix = 0,          // unambiguous identities and a refined pose
  kAmbiguous,        // several consistent poses explain the blobs about equally well
  kNoHypothesis,     // no consistent pose explains >= min_beacons beacons
  kBudgetExhausted,  // the hypothesis budget ran out before a confirmed pose was found
  kTooFewBlobs,      // fewer than 3 blobs
  kBadInput,         // invalid options, rig not set, blob camera out of range
};
inline constexpr int kNumLisStatus = 6;
const char* ToString(LisStatus s);

struct LisOptions {
  P3pOptions p3p{0.1, 0.0, 128};  // depth range of the ray search; max_depth_m <= 0: automatic
                                  // (the beacon map's diameter + workspace_margin_m)
  int max_hypotheses = limits::kMaxLisHypotheses;  // P3P solves per frame set, 1..limit
  int max_blobs = limits::kMaxLisBlobs;            // blobs used for triples, 3..limit
  MatchOptions hypothesis_match{15.0, 15.0, false};  // scoring raw P3P poses
  MatchOptions refine_match{4.0, 15.0, false};       // re-matching refined poses
  double miss_weight = 1.0;       // score penalty per missing beacon
  double min_score_margin = 2.0;  // best - second-best consistent score needed for a fix
  int max_missing = 0;            // a refined pose with more missing beacons is refuted
  int min_beacons = 3;            // distinct beacons of a fix (>= 3)
  int confirm_beacons = 6;        // a pose with this many beacons and none missing ends the
                                  // search (0: always search the whole budget)
  double max_rms_px = 2.0;        // refined residual RMS of a consistent pose
  double pair_tolerance_m = 0.01;  // slack of the pair distance test
  // Workspace: body positions outside [min, max] (world, m) are refused. Automatic (when
  // workspace_auto) from the beacon map's bounding box grown by workspace_margin_m.
  bool workspace_auto = true;
  double workspace_margin_m = 0.1;
  Eigen::Vector3d workspace_min_w = Eigen::Vector3d::Constant(-1e3);
  Eigen::Vector3d workspace_max_w = Eigen::Vector3d::Constant(1e3);
  double same_pose_m = 0.05;
  double same_pose_rad = 0.05;
  SolveOptions solve;             // refinement

  bool IsValid(const char** why = nullptr) const;
};

struct LisResult {
  LisStatus status = LisStatus::kBadInput;
  BodyPose pose;                  // of the fix (kFix); the best consistent pose otherwise
  MatchSet matches;               // identities of the fix (kFix), of the best pose otherwise
  SolveResult solve;              // final solve of the fix: covariance, residuals, per camera
  double best_score = 0.0;        // matches - miss_weight * missing of the best consistent pose
  double second_score = 0.0;      // of the next consistent pose (-inf if none)
  int hypotheses = 0;             // P3P solves spent
  int poses_scored = 0;           // P3P solutions scored
  int blob_triples = 0;           // blob triples visited
  bool search_complete = false;   // every feasible triple was tried
  bool confirmed = false;         // ended early on a confirmed pose
  // Every distinct pose consistent with the blobs, best first. Complete when the search was
  // neither cut nor overflowed, so that the true pose is among them (barring a missed P3P
  // root, about 1e-4 of triples).
  int num_consistent = 0;
  std::array<BodyPose, limits::kMaxLisCandidates> consistent_poses{};
  std::array<double, limits::kMaxLisCandidates> consistent_scores{};
  bool complete = false;
};

// Optional prior for Identify: only poses within max_m / max_rad of one of `poses` are
// considered (the tracker passes the poses it still follows). Raw P3P poses get raw_slack_m /
// raw_slack_rad more, for their noise.
struct LisPrior {
  const BodyPose* poses = nullptr;
  int num_poses = 0;
  double max_m = 0.0;
  double max_rad = 0.0;
  double raw_slack_m = 0.05;
  double raw_slack_rad = 0.05;
};

class LostInSpace {
 public:
  // Precomputes beacon distances and the automatic depth range / workspace. The rig must stay
  // alive and unchanged until the next Reset. Returns false when the rig is unusable.
  bool Reset(const Rig& rig);

  // Identifies blobs[0..num_blobs) (num_blobs <= limits::kMaxObservations). Never allocates.
  // With a prior, only poses near it are sought and listed (complete then means: every
  // consistent pose near the prior).
  // cameras: those that delivered a frame (BeaconMatcher::SetBlobs); the others refute nothing.
  LisStatus Identify(const BlobObs* blobs, int num_blobs, const LisOptions& options, LisResult* result,
                     const LisPrior* prior = nullptr, std::uint32_t cameras = kAllCameras);

 private:
  struct Candidate {
    BodyPose pose;
    MatchList<limits::kMaxLisCandidateMatches> set;
    double score = 0.0;
    double rms_px = 0.0;
    bool refined = false;
  };
  void SelectBlobs(const LisOptions& o);
  BeaconSet PriorBeacons(int i) const;
  void PairFeasibility(const P3pOptions& p3p, const LisOptions& o);
  bool Search(const P3pOptions& p3p, const LisOptions& o, LisResult* result);  // false: budget out
  void Score(const BodyPose& pose, const LisOptions& o, LisResult* result);
  bool Refine(Candidate* c, const LisOptions& o);
  bool SamePose(const Candidate& a, const Candidate& b, const LisOptions& o) const;
  void Insert(const Candidate& c, const LisOptions& o);
  bool InWorkspace(const Eigen::Vector3d& r_w_wb, const LisOptions& o) const;
  bool NearPrior(const BodyPose& pose, double slack_m, double slack_rad) const;
  LisStatus Decide(bool budget_out, const LisOptions& o, LisResult* result);

  const Rig* rig_ = nullptr;
  double map_diameter_m_ = 0.0;
  Eigen::Vector3d map_min_w_ = Eigen::Vector3d::Zero(), map_max_w_ = Eigen::Vector3d::Zero();
  std::array<std::array<double, limits::kMaxBeacons>, limits::kMaxBeacons> dist_{};
  const BlobObs* blobs_ = nullptr;
  int num_blobs_ = 0;
  const LisPrior* prior_ = nullptr;
  BeaconMatcher matcher_;
  int num_sel_ = 0;
  std::array<int, limits::kMaxLisBlobs> sel_{};  // selected blob indices
  std::array<BodyRay, limits::kMaxLisBlobs> rays_{};
  // feasible_[pair(i, j)][a]: bit b set when beacons (a, b) may be seen along rays (i, j).
  static constexpr int kMaxPairs = limits::kMaxLisBlobs * (limits::kMaxLisBlobs - 1) / 2;
  std::array<std::array<BeaconSet, limits::kMaxBeacons>, kMaxPairs> feasible_{};
  P3pRayTriple triple_;
  std::array<BodyPose, limits::kMaxP3pSolutions> solutions_{};
  int num_cand_ = 0;
  bool overflow_ = false;
  std::array<Candidate, limits::kMaxLisCandidates> cand_{};
  Candidate scratch_{};
  SolveResult solve_{};
  MatchSet match_scratch_{};
};

}  // namespace mfns::fw
