// Lost-in-space beacon identification: blobs -> beacon identities and a pose, with no prior
// (issue 4 item 5; the paper matched beacons by hand).
//
// 1. Up to max_blobs blobs are taken, steady ones first (blob_tracks.h, when given), then
//    brightest first, cameras in turn; each is a ray in the body frame.
// 2. Every blob pair gets, per beacon pair, a feasibility bit: the beacons' distance must lie
//    within the range of distances between the two rays' segments [min_depth, max_depth]
//    (this prunes a cross-camera pair by the lever arm). A same-camera pair's ray angle must
//    also lie within the range of angles under which the two beacons are seen together from
//    the workspace (facing them both, when the rig has facing data): Reset samples the
//    workspace for it (the co-visibility table). With unknown depths the distance test alone
//    prunes nothing for a same-camera pair; the table is what makes large maps searchable.
//    The bits are computed for a blob pair when a triple first needs them, per depth range:
//    nested near ones (within near_depth_m, then twice that, ...: near_bands of them, which
//    prune beacon pairs by their distance) and the full one.
// 3. Work items, a blob triple over one range, are visited in groups (after those of the
//    triples of three steady blobs, when the caller marks steady blobs): same-camera triples
//    over the nearest range, then the next, ..., then the full one, then the cross-camera ones
//    likewise (a same-camera triple is cheap: its angles prune, its solve is closed-form);
//    same-camera triples by their largest ray angle (the smaller, the fewer beacon pairs are
//    seen under it). For each item, every ordered beacon triple whose three pairs are feasible
//    (and not already tried over the range before, which it contains) goes through the
//    generalized three-point solver (p3p.h), at most max_hypotheses times per search.
// 4. Solution poses outside the workspace box are refused; the others are scored by
//    reprojecting the whole beacon map with visibility (match.h): matched blobs minus
//    miss_weight per beacon predicted well inside an image with no blob there. The best
//    distinct poses (up to limits::kMaxLisCandidates) are kept. A raw pose with
//    confirm_beacons beacons that misses few against them (raw_matches_per_miss: far beacons
//    of a dense view fall outside the raw gate) is refined at once and judged as refined.
// 5. Each kept pose is refined with the joint solver (solve.h) and re-matched, until its
//    identities settle. A refined pose with a missing beacon is refuted; the rest are the
//    poses consistent with the blobs.
// 6. The best consistent pose is a fix only when it has >= min_beacons beacons, a small
//    residual, and beats every other consistent pose by min_score_margin matches. The default
//    margin, 2, keeps a wrong pose that happens to land one beacon on a spurious blob (likely
//    among thousands of hypotheses) from beating a true pose; a tie is kAmbiguous, never a
//    guess. A refined pose with confirm_beacons beacons, none missing and an expected number of
//    false alarms (FalseAlarms) below max_false_alarms ends the search early (confirmed).
//
// 7. A steady list (LisOptions::steady_list): with four or more steady blobs, the cheapest triple
//    of every four of them is searched first and the search ends there, its list holding
//    every pose that explains four steady blobs (LisResult::steady_complete) where a list of
//    every pose is out of reach.
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
// Memory: one object (about 4.8 MB at 256 beacons: pair bits of three depth ranges 2.8 MB,
// co-visibility table 0.5 MB,
// distances 0.25 MB, a copy of the blobs) holds every buffer; construct it at start (static or
// reserved), Reset() it with the rig, then Identify() never allocates.
#pragma once

#include <array>
#include <limits>
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
  kSearching,        // Begin/Continue: the search goes on in the next Continue
  kCount,
};
inline constexpr int kNumLisStatus = static_cast<int>(LisStatus::kCount);
const char* ToString(LisStatus s);

// Nested near depth ranges a search may visit before the full one (LisOptions::near_bands).
inline constexpr int kMaxNearBands = 3;

struct LisOptions {
  // Depth range of the ray search; max_depth_m <= 0: automatic (the beacon map's diameter +
  // workspace_margin_m). Near-double roots kept to 1e-3 (P3pOptions::near_double_residual):
  // three nearly collinear beacons in one camera have a double root that noise turns complex,
  // and nothing near the truth came out (docs/acquisition.md, session 45). 64 scan steps: half
  // the cost of 128 for a cross-camera triple, and the same root misses (2-5 in 20000 random
  // triples to 8 m).
  P3pOptions p3p{0.1, 0.0, 64, 1e-3};
  int max_hypotheses = 20000;  // work units per search (LisResult::work), 1..limits::kMaxLisHypotheses
  // CPU cost per search (LisResult::cost), > 0; infinity: none. The tracker's time budget.
  double max_cost = std::numeric_limits<double>::infinity();
  int max_blobs = limits::kMaxLisBlobs;            // blobs used for triples, 3..limit
  // Work units of a hypothesis on a cross-camera blob triple: its solve scans the depth of
  // one ray where a same-camera triple's is closed-form (measured ~2.2x the time per
  // hypothesis, fourth-blob test included), so that a budget in units stays a time budget
  // whichever triples the search meets first. 1..8.
  int cross_camera_work = 2;
  MatchOptions hypothesis_match{15.0, 15.0, false};  // scoring raw P3P poses
  MatchOptions refine_match{4.0, 15.0, false};       // re-matching refined poses
  double miss_weight = 1.0;       // score penalty per missing beacon
  double min_score_margin = 2.0;  // best - second-best consistent score needed for a fix
  int max_missing = 0;            // a refined pose with more missing beacons is refuted
  // ... not counting one beacon whose prediction has a free blob within near_miss_px (a blob
  // the pose matched to no beacon), when the pose explains at least near_miss_min_beacons
  // beacons (0: never). A beacon moved since the survey leaves its blob beyond the tight
  // re-match, so that the true pose missed it and every pose was refuted (free-flight, a beacon
  // moved 5 mm: its blob 6.5 px off; no fix in 8-9-beacon views until it left the view); the
  // tracker then leaves it out and beacon health flags it. A wrong pose rarely explains five
  // beacons and leaves a blob beside a sixth; its score still counts the miss.
  int near_miss_min_beacons = 5;
  double near_miss_px = 15.0;     // (> 0)
  int min_beacons = 3;            // distinct beacons of a fix (>= 3)
  int confirm_beacons = 5;        // a pose with this many beacons, none missing and few
                                  // expected false alarms ends the search (0: never)
  double max_false_alarms = 1e-3;  // (see FalseAlarms)
  // A raw P3P pose with confirm_beacons beacons or more is refined (and may confirm) when it
  // misses at most max_missing plus one beacon per this many it explains (0: none beyond
  // max_missing). Its three blobs' noise, levered out to far beacons, leaves some of a dense
  // view outside the raw gate (measured in 256-beacon cylinders: 1-11 missing against 12-36
  // explained, none once refined; such searches ran 20 frame sets short of a fix); a wrong
  // pose misses more beacons than it explains (8-43 against 5-12).
  int raw_matches_per_miss = 2;
  double pair_angle_tolerance_rad = 0.01;  // slack of the co-visibility table's angle ranges
  // Maps with at least this many beacons score a P3P pose only when some fourth selected blob
  // sees a beacon within fourth_blob_max_rad of its ray (its list of three-beacon poses could
  // never be complete, nor a three-beacon pose a fix). Not under a prior: near a followed pose
  // the three-beacon poses are few, and with three beacons in view they are all there is
  // (without it, a track in a large map was never re-identified with three beacons in view).
  // Nor when two blobs of every triple are anchored (LisPrior::anchors): ~N beacon triples each.
  int fourth_blob_min_beacons = 32;
  // With at least four steady blobs selected, a triple of steady blobs passes that test only on
  // a steady fourth: a beacon lined up with a flickering spurious blob was the common pass in a
  // dense view, each a full reprojection. A pose whose only fourth is unsteady is deferred: kept
  // (up to limits::kMaxLisDeferred) and scored after the last item, so a search that reaches
  // its end lists every pose as without the rule; one that deferred more than it could keep
  // cannot say it listed every pose: it fixes only on a confirmed pose (kAmbiguous otherwise).
  // (Scoring them also when the items stop at max_hypotheses was measured: it gives back the
  // rule's gains, docs/acquisition.md session 38.)
  bool steady_fourth = true;
  // A steady list: with at least four steady blobs selected (and no anchors), the search visits
  // first, for every four steady blobs, the cheapest of the four triples they make (by its
  // beacon triples over the full range), scoring only poses that explain a steady fourth (also
  // under a prior), and ends once those items are done: LisResult::steady_complete. A pose that
  // explains four steady blobs with four distinct beacons is a root of each of their triples,
  // so the list then holds every such pose (near the prior; barring a missed P3P root, or a
  // raw root whose fourth blob lies beyond fourth_blob_max_rad), where listing every pose takes
  // all the triples: in a
  // 64-beacon map a triple over three cameras holds every ordered beacon triple, 241 920
  // (docs/acquisition.md, session 43). Only when those items' work fits max_hypotheses
  // (LostInSpace::steady_list() says whether it applied). Never a fix unless confirmed: the
  // tracker follows the list. False: the search as before.
  bool steady_list = false;
  // Each blob triple is also searched with beacons paired as if within this depth of the
  // cameras, a cheaper work item visited earlier (<= 0: no such items; see SetRange), and then
  // within twice, four times ... that depth: near_bands ranges in all (those below the full
  // one), each searching only the beacon triples the one before did not. The depth that prunes
  // best depends on the map's density and the cameras' field of view (measured: 1 m best for
  // 256-beacon boxes, 1.5-2 m for 64-beacon ones seen by f = 760 px cameras; docs/acquisition.md,
  // session 32): nested ranges serve both.
  double near_depth_m = 1.0;
  int near_bands = 2;  // 1..kMaxNearBands
  double fourth_blob_max_rad = 0.015;
  // In a steady list's items: a raw root of weak geometry (LostInSpace::WeakRoot: another root
  // of its triple within 25 % in every depth - the camera near the triple's danger cylinder -
  // or a nearly collinear triangle) asks for a steady fourth blob within this angle instead,
  // and is listed only if its refinement onto that blob's beacon explains four beacons. Such
  // roots are centimetres off the truth, and their fourth beacon up to 0.25 rad from its blob
  // (seen: 5 of 119 exhaustive steady lists of clean four-beacon views lacked the truth, each
  // for a weak triple; 1 with this and near_double_residual; docs/acquisition.md, session 45).
  double weak_fourth_blob_max_rad = 0.3;
  double max_rms_px = 2.0;        // refined residual RMS of a consistent pose
  double pair_tolerance_m = 0.01;  // slack of the pair distance test
  // A pose confirms only when no other copy of its beacons in the map, congruent within this
  // (m), gives a pose that explains the blobs as well (LostInSpace::RepeatedElsewhere): a
  // regular grid or a symmetric layout repeats views exactly, and the a-contrario test, which
  // takes wrong poses for chance ones, confirmed one of the copies (docs/acquisition.md,
  // session 33: thousands of wrong fixes 180 deg off on regular grids). 0: no check.
  double repeat_tolerance_m = 0.01;
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
  int work = 0;                   // budget units spent: P3P solves (cross_camera_work each on a
                                  // cross-camera triple), plus under a prior (or two
                                  // anchors per triple) one per pose fully reprojected (no
                                  // fourth-blob test there)
  // The search's CPU cost in units of one same-camera P3P hypothesis (~0.6 us on the host):
  // its hypotheses' work, each scored pose's fourth-blob test (beacons x blobs), each full
  // reprojection (beacons) and refinement, by a model fitted to the measured time of whole
  // frame sets (docs/acquisition.md, session 17). Deterministic: no clock is read.
  double cost = 0.0;
  double false_alarms = 0.0;      // FalseAlarms of the confirmed pose (confirmed only)
  int poses_scored = 0;           // P3P solutions scored
  int blob_triples = 0;           // blob triples visited
  int deferred = 0;               // poses deferred by LisOptions::steady_fourth (scored last, if reached)
  bool search_complete = false;   // every feasible triple was tried
  bool confirmed = false;         // ended early on a confirmed pose
  int repeats = 0;                // poses not confirmed: the map repeats their beacons (repeat_tolerance_m)
  // Every distinct pose consistent with the blobs, best first. Complete when the search was
  // neither cut nor overflowed, so that the true pose is among them (barring a missed P3P
  // root, about 1e-4 of triples) - except where the fourth-blob test applies (no prior poses
  // nor two anchors per triple, a map of >= fourth_blob_min_beacons): there the list holds
  // the poses that also explain a fourth blob, and a view of three beacons has the truth in
  // none (docs/acquisition.md, session 21).
  int num_consistent = 0;
  std::array<BodyPose, limits::kMaxLisCandidates> consistent_poses{};
  std::array<double, limits::kMaxLisCandidates> consistent_scores{};
  bool complete = false;
  // LisOptions::steady_list: the search ended once every pose (near the prior) that explains four
  // steady blobs was listed (the list not overflowed): the consistent poses hold them all, and
  // perhaps others. complete is false (the other triples were not searched).
  bool steady_complete = false;
};

// The missing beacons that refute a refined pose (LisResult, the tracker's solves): all of them,
// less one near miss when the pose explains near_miss_min_beacons beacons or more.
template <int kCapacity>
int UnexcusedMissing(const MatchList<kCapacity>& m, const LisOptions& o) {
  const bool excuse = o.near_miss_min_beacons > 0 && m.num_beacons >= o.near_miss_min_beacons && m.num_near_missing > 0;
  return m.num_missing - (excuse ? 1 : 0);
}

// A tight re-match `tight` that also counts near misses (when LisOptions enables them).
inline MatchOptions WithNearMisses(MatchOptions tight, const LisOptions& o) {
  tight.near_miss_px = o.near_miss_min_beacons > 0 ? o.near_miss_px : 0.0;
  return tight;
}

// A blob whose beacon is known before the search (LisPrior::anchors): its index in the blob
// list given to Identify / Begin, and the beacon.
struct LisAnchor {
  int blob = -1;
  int beacon = -1;
};

// Optional prior for Identify: only poses within max_m / max_rad of one of `poses` are
// considered (the tracker passes the poses it still follows). Raw P3P poses get raw_slack_m /
// raw_slack_rad more, for their noise. Each pose narrows each blob to the beacons it may see
// along it, and a blob triple is searched with the beacon triples one pose allows for all three
// blobs (up to limits::kMaxLisCandidates poses; beyond, the union of their beacons): the cost
// grows with the poses' own views.
// No poses (num_poses 0) with anchors: a search anywhere that keeps the anchors (the tracker's
// cold search after a gap).
struct LisPrior {
  const BodyPose* poses = nullptr;
  int num_poses = 0;
  double max_m = 0.0;
  double max_rad = 0.0;
  double raw_slack_m = 0.05;
  double raw_slack_rad = 0.05;
  // Identities known before the search (optional; the tracker's image tracks of beacons it
  // identified in an accepted pose, blob_tracks.h): the poses sought name at least
  // n = min(anchored blobs, 3) anchored blobs their beacons. Only blob triples holding n
  // anchored blobs are searched (such a pose is a root of one), and a consistent pose must keep
  // n anchors: "complete" means every consistent pose near the prior poses that keeps n of
  // the anchors (with four or more anchors, one wrong anchor - a track that hopped to a
  // spurious blob - still leaves the truth). Anchors with a blob or beacon out of range, or
  // naming a blob or a beacon (in one camera) twice, are ignored. Copied by Begin.
  const LisAnchor* anchors = nullptr;
  int num_anchors = 0;
};

// The expected number of poses, among `tests` wrong hypotheses, that would match as many
// beacons by chance (an a-contrario test): a refined pose predicts `predicted` beacons in view
// and matches `matched` of them, three of which its hypothesis fitted exactly; each other
// prediction lands within gate_px of one of the frame set's blobs with probability
// p = min(1, blobs_per_image * pi * gate_px^2 / image_area_px2), so chance gives at least
// matched - 3 such landings with the binomial tail. Returns tests * tail.
double FalseAlarms(int matched, int predicted, double blobs_per_image, double gate_px, double image_area_px2,
                   double tests);

class LostInSpace {
 public:
  // Precomputes beacon distances and the automatic depth range / workspace. The rig must stay
  // alive and unchanged until the next Reset. Returns false when the rig is unusable.
  // Also samples the workspace for the co-visibility table (about 0.1 s for 256 beacons on the
  // host).
  bool Reset(const Rig& rig);

  // Beacons never predicted (matched or missing) in scoring and refinement until the next call
  // (none after Reset; BeaconMatcher::SetExcluded). A hypothesis on one of them refines onto the
  // others.
  void SetExcluded(const BeaconSet& beacons) { matcher_.SetExcluded(beacons); }

  // Identifies blobs[0..num_blobs) (num_blobs <= limits::kMaxObservations). Never allocates.
  // With a prior, only poses near it are sought and listed (complete then means: every
  // consistent pose near the prior).
  // cameras: those that delivered a frame (BeaconMatcher::SetBlobs); the others refute nothing.
  // steady (optional, one flag per blob): blobs whose image track is steady (blob_tracks.h)
  // are selected first, and the triples of three steady blobs are searched before all others
  // (when at least three are selected); the result is the same for a complete search.
  LisStatus Identify(const BlobObs* blobs, int num_blobs, const LisOptions& options, LisResult* result,
                     const LisPrior* prior = nullptr, std::uint32_t cameras = kAllCameras,
                     const std::uint8_t* steady = nullptr);

  // The same search spread over several calls, so that a frame set's time budget is kept:
  // Begin checks and copies the blobs (the caller's list need not outlive the call) and
  // returns kSearching, or a final status at once (bad input, too few blobs); each Continue
  // spends at most `budget` work units (LisResult::work; o.max_hypotheses in all) and returns kSearching while
  // the search goes on, else the final status and result as Identify. `prior` (optional) must
  // stay alive until then. Identify = Begin + Continue(options.max_hypotheses). Any Identify
  // or Begin abandons a search in progress.
  LisStatus Begin(const BlobObs* blobs, int num_blobs, const LisOptions& options, LisResult* result,
                  const LisPrior* prior = nullptr, std::uint32_t cameras = kAllCameras,
                  const std::uint8_t* steady = nullptr);
  // cost_budget: this call also pauses once it has spent that much LisResult::cost.
  LisStatus Continue(int budget, LisResult* result,
                     double cost_budget = std::numeric_limits<double>::infinity());
  bool searching() const { return searching_; }
  // Whether the search in progress (or the last one) is a steady list (LisOptions::steady_list,
  // when it applied: four steady blobs, no anchors, and its items within max_hypotheses).
  bool steady_list() const { return num_steady_items_ > 0; }
  // Whether the search in progress (or the last one) dropped from its full list a pose that may
  // be consistent: its list can no longer be complete (LisResult::complete).
  bool overflowed() const { return overflow_; }
  // Whether the search in progress may still end with a complete list: not overflowed, and,
  // with at most one prior pose, the work spent plus its beacon triples not tried yet (counted
  // once per search, exactly: each blob triple's feasible ones over the full depth range) fit
  // within max_hypotheses work units. (A search that cannot complete gives a fix only by
  // confirming one, and its time is better spent on the next frame set's blobs: seen,
  // 16-24-beacon stations with 8 blobs a frame set, searches of 20 000 units, ~20 ms, that
  // ended incomplete.) The count's cost is charged to *result.
  bool MayComplete(LisResult* result);
  // Ends the search in progress as if its budget had run out: the result as Continue's then
  // (kBudgetExhausted, or the poses found so far, the list incomplete). Without a search in
  // progress, result->status.
  LisStatus Stop(LisResult* result);

 private:
  struct Candidate {
    BodyPose pose;
    MatchList<limits::kMaxLisCandidateMatches> set;
    double score = 0.0;
    double rms_px = 0.0;
    bool refined = false;
    // The fourth blob's beacon that the fourth-blob test found along its ray (ExplainsAFourth)
    // when the raw match left that blob free (blob -1: none): Refine solves with it.
    Match fourth;
    bool weak = false;  // found by the wide fourth-blob test of a weak root: listed only if refined to four beacons
  };
  struct Triple {
    std::uint8_t i, j, k;  // selected-blob indices, i < j < k
  };
  void SelectBlobs(const LisOptions& o, const std::uint8_t* steady);
  void PriorBeacons(LisResult* result);
  void ApplyAnchors(BeaconSet* allowed) const;
  void CoVisibilityTable();
  void SampleCoVisibility(const Eigen::Vector3d& p, double min_depth_m);
  void OrderItems(int num_bands);
  void SteadyItemsFirst(LisResult* result);
  const std::array<BeaconSet, limits::kMaxBeacons>& Feasible(int i, int j);  // i < j, lazily, current range
  bool PairTriedIn(const Triple& tr, int band, int a, int b) const;
  BeaconSet ThirdsTriedIn(const Triple& tr, int band, int a, int b) const;
  void Confirm(Candidate* c, const LisOptions& o, LisResult* result);
  bool RepeatedElsewhere(const Candidate& c, const LisOptions& o, LisResult* result);
  bool CopyExplainsTheBlobs(const Candidate& c, const Eigen::Matrix3d& R, const Eigen::Vector3d& t, int n,
                            const LisOptions& o);
  enum class Fourth : unsigned char { kNone, kUnsteadyOnly, kFound };
  // found (kFound): the selected blob along whose ray a beacon lies.
  Fourth ExplainsAFourth(const BodyPose& pose, int t_i, int t_j, int t_k, float cos_sq, bool steady_only,
                         int* found);
  int BeaconAlong(const BodyPose& pose, int s) const;
  enum class SearchEnd : unsigned char { kDone, kPaused, kBudgetOut };
  SearchEnd Search(int budget, double cost_budget, LisResult* result);
  // The budgets of one Search call: what was spent when it began.
  struct Spent {
    int work = 0;
    double cost = 0.0;
    int budget = 0;
    double cost_budget = 0.0;
  };
  bool Hypothesis(int a, int b, int c, int unit, const Spent& since, LisResult* result, SearchEnd* end);
  bool FirstTry(int a, int b, int c);
  long CountTriples(const Triple& tr, long cap);
  void TryTriple(int a, int b, int c, LisResult* result);
  // Whether a raw pose of beacons (a, b, c) is worth scoring: in the workspace, facing all
  // three, near the prior if there is one.
  bool Plausible(const BodyPose& pose, int a, int b, int c) const;
  void SetRange(int band);
  void Score(const BodyPose& pose, const LisOptions& o, LisResult* result, bool weak = false);
  void ScoreMatched(const BodyPose& pose, const LisOptions& o, LisResult* result, int fourth_sel = -1, bool weak = false);
  bool WeakRoot(int s, int n) const;
  SearchEnd ScoreDeferred(const Spent& since, LisResult* result);
  bool WithinBudget(const Spent& since, const LisResult& result, SearchEnd* end, bool work_cap) const;
  SearchEnd SearchItems(const Spent& since, LisResult* result);
  bool Refine(Candidate* c, const LisOptions& o);
  bool SamePose(const Candidate& a, const Candidate& b, const LisOptions& o) const;
  void Insert(const Candidate& c, const LisOptions& o);
  bool InWorkspace(const Eigen::Vector3d& r_w_wb, const LisOptions& o) const;
  bool NearPrior(const BodyPose& pose, double slack_m, double slack_rad) const;
  bool PosePrior() const { return prior_ != nullptr && prior_->num_poses > 0; }
  void SetAnchors();
  bool KeepsAnchors(const Candidate& c, const LisOptions& o);
  LisStatus Decide(bool budget_out, const LisOptions& o, LisResult* result);

  const Rig* rig_ = nullptr;
  double map_diameter_m_ = 0.0;
  Eigen::Vector3d map_min_w_ = Eigen::Vector3d::Zero(), map_max_w_ = Eigen::Vector3d::Zero();
  std::array<std::array<float, limits::kMaxBeacons>, limits::kMaxBeacons> dist_{};
  // Co-visibility table: cosines of the smallest and largest angle under which beacons (a, b),
  // a < b, are seen together from a sampled workspace point (both facing it); > 1.5: never.
  std::array<std::array<float, limits::kMaxBeacons>, limits::kMaxBeacons> cos_min_angle_{}, cos_max_angle_{};
  double p3p_min_m_ = 0.1, p3p_max_m_ = 1.0;   // the current range's depths
  // Depth ranges (SetRange): nested, band_max_m_[0] < ... < band_max_m_[num_bands_ - 1], the
  // last one the full range.
  static constexpr int kMaxBands = kMaxNearBands + 1;
  int band_ = 0;                               // the current range
  int num_bands_ = 1;
  std::array<double, kMaxBands> band_max_m_{};
  double pair_tol_m_ = 0.0, pair_tol_rad_ = 0.0;
  double image_area_px2_ = 1.0;
  std::array<float, limits::kMaxBeacons> beacon_x_{}, beacon_y_{}, beacon_z_{};  // SoA, world
  int cur_i_ = 0, cur_j_ = 0, cur_k_ = 0;  // the blob triple being searched
  float fourth_cos_sq_ = 1.0F;
  float weak_fourth_cos_sq_ = 1.0F;  // of options_.weak_fourth_blob_max_rad
  const BlobObs* blobs_ = nullptr;
  std::array<BlobObs, limits::kMaxObservations> own_blobs_{};
  LisOptions options_;
  P3pOptions p3p_;
  bool searching_ = false;
  // The next hypothesis of a paused search: work item `item`, beacons (a, b, c) (-1: the set's first).
  struct Cursor {
    int item = 0, p = 0, a = 0, b = -1, c = -1;  // p: the prior pose whose beacon sets are searched
    bool ready = false;  // triple_ holds the item's rays
  };
  Cursor cur_;
  int num_blobs_ = 0;
  const LisPrior* prior_ = nullptr;
  BeaconMatcher matcher_;
  int num_sel_ = 0;
  std::array<int, limits::kMaxLisBlobs> sel_{};  // selected blob indices
  std::array<bool, limits::kMaxLisBlobs> sel_steady_{};  // the selected blob's image track is steady
  int num_sel_steady_ = 0;
  // Anchors (LisPrior::anchors): the beacon of each blob of the list (-1: none), the anchored
  // blobs among the selected ones, and how many of them every searched triple holds.
  std::array<short, limits::kMaxObservations> blob_anchor_{};
  std::array<bool, limits::kMaxLisBlobs> sel_anchored_{};
  int num_anchors_ = 0;
  int anchors_per_triple_ = 0;
  std::array<BodyRay, limits::kMaxLisBlobs> rays_{};
  // ExplainsAFourth's scratch: one camera's offsets to the beacons under the pose being scored.
  struct CameraOffsets {
    std::array<float, limits::kMaxBeacons> x{}, y{}, z{}, cos_sq_len_sq{};
  };
  std::array<CameraOffsets, limits::kMaxCameras> offsets_{};
  // feasible_[band][pair(i, j)][a]: bit b set when beacons (a, b) may be seen along rays (i, j)
  // within the depth range `band`.
  static constexpr int kMaxPairs = limits::kMaxLisBlobs * (limits::kMaxLisBlobs - 1) / 2;
  std::array<std::array<std::array<BeaconSet, limits::kMaxBeacons>, kMaxPairs>, kMaxBands> feasible_{};
  std::array<std::array<bool, kMaxPairs>, kMaxBands> feasible_done_{};
  std::array<BeaconSet, limits::kMaxLisBlobs> allowed_{};  // per selected blob (prior): the union over its poses
  // Under a pose prior, each prior pose's own beacon sets per selected blob (PriorBeacons), and
  // the selected blobs for which its set is not empty (bit i): a search item's beacon triples
  // are those one pose allows for all three blobs, so that following many poses costs what
  // each one's view does, not what their union's does (the union of 256 poses in a 16-beacon
  // map is the map: a search as dear as a cold one, session 35).
  static_assert(limits::kMaxLisBlobs <= 16, "pose_blobs_ is a 16-bit mask");
  int num_pose_sets_ = 0;  // 0: no pose prior (the union sets alone)
  std::array<std::array<BeaconSet, limits::kMaxLisBlobs>, limits::kMaxLisCandidates> pose_allowed_{};
  std::array<std::uint16_t, limits::kMaxLisCandidates> pose_blobs_{};
  // Beacon triples tried in the current item (FirstTry): poses near each other allow the same
  // ones. Open addressing, stamped by item; a full table only lets a triple be tried twice.
  struct TriedSlot {
    std::uint32_t key = 0, stamp = 0;
  };
  static constexpr int kTriedSlots = 4096;
  std::array<TriedSlot, kTriedSlots> tried_{};
  std::uint32_t tried_stamp_ = 0;
  static constexpr int kMaxTriples = limits::kMaxLisBlobs * (limits::kMaxLisBlobs - 1) * (limits::kMaxLisBlobs - 2) / 6;
  std::array<Triple, kMaxTriples> triples_{};
  std::array<std::array<bool, kMaxTriples>, kMaxBands> band_done_{};  // the triple's item of the band is done
  // The work list (OrderItems): a blob triple over one depth range, in visiting order.
  struct Item {
    std::uint16_t t;    // triples_ index
    std::uint8_t band;  // depth range
    bool same_camera;
    int group;          // (class, band): same-camera, cross-camera (after those of steady triples,
                        // whose items of every band form one group, visited band by band)
    float key;          // order within the group
  };
  std::array<Item, kMaxBands * kMaxTriples> items_{};
  int num_items_ = 0;
  // LisOptions::steady_list: items_[0, num_steady_items_) are those of the steady triples that
  // cover every four steady blobs (SteadyItemsFirst); 0: no steady list in this search.
  int num_steady_items_ = 0;
  bool steady_end_ = false;  // the search ended after them
  std::array<long, kMaxTriples> triple_count_{};  // SteadyItemsFirst's scratch
  std::array<Item, kMaxBands * kMaxTriples> items_scratch_{};
  bool SearchPoseSets(const Item& item, const Spent& since, LisResult* result, SearchEnd* end);
  P3pRayTriple triple_;
  std::array<BodyPose, limits::kMaxP3pSolutions> solutions_{};
  std::array<Eigen::Vector3d, limits::kMaxP3pSolutions> depths_{};  // solutions_' depths along the rays
  int num_cand_ = 0;
  bool overflow_ = false;
  // Poses whose only fourth blob was unsteady (steady_fourth), scored after the last item
  // (ScoreDeferred); deferred_lost_: more than the array holds, so the list cannot be complete.
  std::array<BodyPose, limits::kMaxLisDeferred> deferred_{};
  int num_deferred_ = 0;
  int next_deferred_ = 0;  // the first not yet scored (a search may pause among them)
  bool deferred_lost_ = false;
  int work_bound_ = -1;  // MayComplete's count of the search in progress (-1: not counted)
  int hypothesis_work_ = 0;  // the work units of the hypotheses tried so far (LisResult::work less the scoring's)
  // Beacon sets this search found repeated elsewhere in the map (RepeatedElsewhere's memo). A
  // regular map's view has as many copies as its symmetries take it to, and the search meets
  // them in turn: a regular grid in a cube gave a cycle of 24 (its rotations).
  static constexpr int kRepeatMemo = 64;
  std::array<BeaconSet, kRepeatMemo> repeated_{};
  int num_repeated_ = 0;  // found this search (the memo keeps the last kRepeatMemo)
  std::array<Candidate, limits::kMaxLisCandidates> cand_{};
  Candidate scratch_{};
  Candidate confirmed_{};  // the pose that ended the search (LisResult::confirmed)
  SolveResult solve_{};
  MatchSet match_scratch_{};
};

}  // namespace mfns::fw
