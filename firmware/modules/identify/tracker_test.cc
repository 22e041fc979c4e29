#include "firmware/modules/identify/tracker.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "firmware/modules/solve/synthetic_scene.h"
#include "firmware/lib/testing/alloc_counter.h"

namespace mfns::fw {
namespace {

using testing::AngleBetween;
using testing::Scene;

Tracker g_tracker;
TrackResult g_result;
Scene g_scene;

constexpr std::uint64_t kFrameNs = 33333333;  // 30 Hz

bool IdentitiesRight(const Scene& s, const MatchSet& m) {
  for (int i = 0; i < m.num_matches; ++i) {
    const Match& x = m.matches[static_cast<std::size_t>(i)];
    if (s.truth_beacon[static_cast<std::size_t>(x.blob)] != x.beacon) return false;
  }
  return true;
}

struct Sweep {
  int frames = 0;
  int first_fix = -1;
  int eligible_after_first = 0;  // frames with >= 3 visible beacons after the first fix
  int accepted_after_first = 0;
  int wrong = 0;
  int tracked = 0, lis = 0, acquired = 0;
  int lost_with_few = 0;  // frames with < 3 visible beacons (lost by necessity)
  // Recovery after gaps (runs of frames with < 3 beacons) shorter than max_coast_s that
  // interrupt a fix: frames with >= 3 beacons after the gap until the next accepted frame.
  int gap_len = 0;
  bool gap_after_fix = false;  // the frame before the gap had a fix
  bool last_accepted = false;
  int since_gap = -1;  // >= 0: counting frames after a short gap until a fix
  int short_gaps = 0;
  int worst_recovery = 0;

  void Print(const char* what) const {
    std::printf("%s: %d frames, first fix at frame %d; after it %d of %d frames with >= 3 beacons accepted; "
                "tracked %d, lost-in-space %d, acquired %d; %d gaps < max_coast_s, worst recovery %d frames; "
                "wrong %d\n",
                what, frames, first_fix, accepted_after_first, eligible_after_first, tracked, lis, acquired, short_gaps,
                worst_recovery, wrong);
  }
};

void Step(const Rig& rig, const Scene& s, std::uint64_t t_ns, const TrackOptions& o, Sweep* run,
          std::uint32_t cameras = kAllCameras) {
  const int visible = s.NumVisibleBeacons();
  const TrackStatus st = g_tracker.Track(s.blobs.data(), s.num_blobs, t_ns, o, &g_result, cameras);
  const bool accepted = st != TrackStatus::kLost;
  if (std::getenv("TRACK_DEBUG") != nullptr)
    std::printf("frame %d visible %d blobs %d: %s %s %s lis %s chain %d\n", run->frames, visible, s.num_blobs,
                ToString(st), ToString(g_result.reason), ToString(g_result.source),
                g_result.lis_run ? ToString(g_result.lis_status) : "-", g_result.acquisition_poses);
  if (accepted) {
    // Right identities, and a pose error consistent with the reported covariance (a weak
    // three-beacon geometry may be centimetres off, and says so).
    Eigen::Matrix<double, 6, 1> e;
    e.head<3>() = g_result.pose.r_w_wb - s.pose.r_w_wb;
    e.tail<3>() = LogSO3(s.pose.C_w_b.transpose() * g_result.pose.C_w_b);
    const double mahalanobis_sq = e.dot(g_result.solve.covariance.ldlt().solve(e));
    const bool right = IdentitiesRight(s, g_result.matches) && mahalanobis_sq < 50.0;
    EXPECT_TRUE(right) << "frame " << run->frames << " source " << ToString(g_result.source) << " identities "
                       << (IdentitiesRight(s, g_result.matches) ? "right" : "WRONG") << ", error "
                       << e.head<3>().norm() << " m, Mahalanobis^2 " << mahalanobis_sq << ", beacons "
                       << g_result.matches.num_beacons << ", rms " << g_result.solve.rms_px;
    if (std::getenv("TRACK_DEBUG") != nullptr)
      for (int i = 0; i < g_result.matches.num_matches; ++i) {
        const Match& x = g_result.matches.matches[static_cast<std::size_t>(i)];
        std::printf("  blob %d cam %d -> beacon %d (truth %d)\n", x.blob, x.camera, x.beacon,
                    s.truth_beacon[static_cast<std::size_t>(x.blob)]);
      }
    run->wrong += !right;
    // (A pose published degraded for a reflection beside a beacon names only the identities
    // not in doubt: maybe fewer than three.)
    if (g_result.reason != TrackReason::kAmbiguous) {
      EXPECT_GE(g_result.matches.num_beacons, 3);
    }
    if (run->first_fix < 0) run->first_fix = run->frames;
    run->tracked += g_result.source == TrackSource::kTracked;
    run->lis += g_result.source == TrackSource::kLostInSpace;
    run->acquired += g_result.source == TrackSource::kAcquired;
  }
  if (run->first_fix >= 0 && run->first_fix < run->frames && visible >= 3) {
    ++run->eligible_after_first;
    run->accepted_after_first += accepted;
  }
  if (visible < 3) ++run->lost_with_few;
  if (run->first_fix >= 0 && run->first_fix < run->frames) {
    if (visible < 3) {
      if (run->gap_len == 0) run->gap_after_fix = run->last_accepted;
      ++run->gap_len;
    } else {
      if (run->gap_len > 0 && run->gap_after_fix && static_cast<std::uint64_t>(run->gap_len) * kFrameNs * 1e-9 < o.max_coast_s) {
        ++run->short_gaps;
        run->since_gap = 0;
      }
      run->gap_len = 0;
      if (run->since_gap >= 0) {
        if (accepted) {
          run->worst_recovery = std::max(run->worst_recovery, run->since_gap);
          run->since_gap = -1;
        } else {
          ++run->since_gap;
        }
      }
    }
  }
  run->last_accepted = accepted;
  (void)rig;
  ++run->frames;
}

TEST(TrackerTest, PaperYawSweep) {
  const Rig rig = PaperRig();
  // (Under qemu and the sanitizers only the harder case, with spurious blobs, runs.)
  for (int spurious = testing::Trials(0, 2); spurious <= 2; spurious += 2) {
    ASSERT_TRUE(g_tracker.Reset(rig));
    std::mt19937_64 rng(300 + static_cast<std::uint64_t>(spurious));
    Sweep run;
    const std::uint64_t allocations = testing::AllocationCount();
    const int frames = testing::Trials(720, 200);  // two turns
    for (int step = 0; step < frames; ++step) {
      testing::Observe(rig, testing::YawPose(DegToRad(step)), 0.2, &rng, &g_scene);
      testing::AddSpurious(rig, spurious, &rng, &g_scene);
      Step(rig, g_scene, static_cast<std::uint64_t>(step) * kFrameNs, TrackOptions{}, &run);
    }
    char what[64];
    std::snprintf(what, sizeof what, "paper yaw sweep, %d spurious", spurious);
    run.Print(what);
    EXPECT_EQ(testing::AllocationCount() - allocations, 0u);
    EXPECT_EQ(run.wrong, 0);
    EXPECT_GE(run.first_fix, 0);
    EXPECT_LT(run.first_fix, 60);
    // Clean: every frame set with >= 3 beacons after the acquisition has a fix (a second exact
    // three-beacon pose is refused only within the prediction's bounds). With reflections, a
    // gap too long for the tracking gate ends with a re-identification seeded by the
    // prediction that must outlive min_acquire_frames frame sets (TrackOptions).
    if (spurious == 0) {
      EXPECT_EQ(run.accepted_after_first, run.eligible_after_first);
    }
    EXPECT_GE(run.accepted_after_first, run.eligible_after_first * 97 / 100);
    EXPECT_GT(run.short_gaps, 0);
    EXPECT_LE(run.worst_recovery, spurious == 0 ? 0 : TrackOptions{}.min_acquire_frames);
  }
}

// A smooth 6-DOF path among the paper's beacons: position on Lissajous curves (+-0.1 m
// about the turntable centre), attitude yawing at ~29 deg/s with +-15 deg of roll and pitch.
BodyPose PathPose(double t) {
  BodyPose p;
  p.r_w_wb = Eigen::Vector3d(0.1 * std::sin(0.6 * t), 0.1 * std::sin(0.45 * t + 1.0), 0.05 * std::sin(0.3 * t + 2.0));
  const EulerAngles e{DegToRad(15.0) * std::sin(0.7 * t), DegToRad(15.0) * std::sin(0.5 * t + 1.0), 0.5 * t};
  p.C_w_b = EulerToMatrix(e).transpose();
  return p;
}

TEST(TrackerTest, SmoothSixDofPath) {
  const Rig rig = PaperRig();
  const int frames = testing::Trials(900, 240);
  for (int spurious = testing::Trials(0, 1); spurious <= 1; ++spurious) {
    ASSERT_TRUE(g_tracker.Reset(rig));
    std::mt19937_64 rng(500 + static_cast<std::uint64_t>(spurious));
    Sweep run;
    int gaps = 0;
    for (int f = 0; f < frames; ++f) {
      const std::uint64_t t_ns = static_cast<std::uint64_t>(f) * kFrameNs;
      testing::Observe(rig, PathPose(static_cast<double>(t_ns) * 1e-9), 0.2, &rng, &g_scene);
      testing::AddSpurious(rig, spurious, &rng, &g_scene);
      gaps += g_scene.NumVisibleBeacons() < 3;
      Step(rig, g_scene, t_ns, TrackOptions{}, &run);
    }
    char what[80];
    std::snprintf(what, sizeof what, "6-DOF path, %d spurious (%d frames with < 3 beacons)", spurious, gaps);
    run.Print(what);
    EXPECT_EQ(run.wrong, 0);
    EXPECT_GE(run.first_fix, 0);
    EXPECT_GT(gaps, 0);  // the path has gaps to recover from
    // Gaps shorter than max_coast_s are bridged by tracking or, beyond the gate, by the
    // prediction seeding re-identification (with reflections in view, confirmed over
    // min_acquire_frames frame sets); gaps beyond max_seed_s need a new acquisition, which can
    // take many frame sets with three beacons in view.
    EXPECT_GT(run.short_gaps, 0);
    EXPECT_LE(run.worst_recovery, spurious == 0 ? 0 : TrackOptions{}.min_acquire_frames);
    EXPECT_GE(run.accepted_after_first, run.eligible_after_first * (spurious == 0 ? 90 : 75) / 100);
  }
}

// A reflection beside a beacon (5-20 px: a shiny panel next to the LED) falls inside its
// tracking gate. Left out, the beacon is lost to the track, and with three or four beacons in
// view so is the pose; tried with either blob, the track holds (and never on the reflection).
// Measured on the frame sets that tracking decides: >= 4 beacons in view and a pose in the
// frame set before. (With three beacons and a reflection beside one, two exact poses a few
// pixels apart remain: refused, never guessed.)
struct ReflectionRun {
  int eligible = 0, posed = 0, wrong = 0;
};

ReflectionRun YawSweepWithReflections(const TrackOptions& o, int frames, int min_visible = 4) {
  const Rig rig = PaperRig();
  ReflectionRun run;
  if (!g_tracker.Reset(rig)) return run;
  g_tracker.SetPose(testing::YawPose(0.0), 0);
  std::mt19937_64 rng(1300);
  Sweep sweep;
  bool posed_before = false;
  for (int step = 0; step < frames; ++step) {
    testing::Observe(rig, testing::YawPose(DegToRad(0.5 * step)), 0.1, &rng, &g_scene);
    testing::AddReflections(rig, 2, 5.0, 20.0, &rng, &g_scene);
    const int before = sweep.wrong;
    Step(rig, g_scene, static_cast<std::uint64_t>(step) * kFrameNs, o, &sweep);
    run.wrong += sweep.wrong - before;
    const bool posed = g_result.status != TrackStatus::kLost;
    if (g_scene.NumVisibleBeacons() >= min_visible && posed_before) {
      ++run.eligible;
      run.posed += posed;
    }
    posed_before = posed;
  }
  return run;
}

// Reflections that flicker (a new place every frame set) are resolved by the blob tracks
// (TrackOptions::continue_blob_tracks, FlickeringReflectionsFollowTheBlobTracks): the trials are
// measured without them.
TrackOptions TrialsAlone() {
  TrackOptions o;
  o.continue_blob_tracks = false;
  return o;
}

TEST(TrackerTest, ReflectionsBesideBeaconsKeepTheTrack) {
  const int frames = testing::Trials(400, 160);
  TrackOptions none = TrialsAlone();
  none.max_ambiguous_tried = 0;
  const ReflectionRun left_out = YawSweepWithReflections(none, frames);
  const ReflectionRun tried = YawSweepWithReflections(TrialsAlone(), frames);
  std::printf("reflections beside beacons: posed %d of %d frame sets with >= 4 beacons after a pose (tried), "
              "%d of %d (left out)\n", tried.posed, tried.eligible, left_out.posed, left_out.eligible);
  EXPECT_EQ(tried.wrong, 0);
  EXPECT_EQ(left_out.wrong, 0);
  // (Measured: 100 of 100 tried, 59 of 68 left out since the gate is the last fix's covariance
  // projected into the images (Tracker::PredictionGatePx; 99 of 100 and 31 of 47 with the wider
  // pose-space gate); 93 of 97 before trials that disagree were decided by the motion
  // (MotionDecidesBetweenTrialsThatDisagree), 77 of 88 before a disagreement within
  // ambiguity_max_spread_m was published degraded. Every published pose, degraded ones
  // included, lies within its covariance: Step checks it.)
  ASSERT_GT(tried.eligible, frames / 8);
  EXPECT_GE(tried.posed * 100, tried.eligible * 75);
  EXPECT_GT(tried.posed * left_out.eligible, left_out.posed * tried.eligible);  // the trials keep more
  EXPECT_GT(g_tracker.counters().ambiguous_tried, 0U);
  EXPECT_GT(g_tracker.counters().ambiguous_published, 0U);
  EXPECT_LE(g_tracker.counters().ambiguous_published, g_tracker.counters().ambiguous_refused);
}

// Beyond the spread PublishAmbiguous covers, trials that disagree are decided by the motion: the
// constant-velocity filter's prediction (MotionModel::filter) weighs each trial, and one near it
// with every other far is published degraded and followed. Counted over the frame sets with >= 3
// beacons after a pose: more are posed than with the decision off, none wrong (Step checks every
// published pose against the truth and its covariance). The spread is held at 1 cm / 5 mrad (the
// default before session 35): with the default 3 cm / 1 deg this sweep's disagreements are
// mostly published by PublishAmbiguous, and the reduced run (Trials) has none left to decide.
TEST(TrackerTest, MotionDecidesBetweenTrialsThatDisagree) {
  const int frames = testing::Trials(400, 160);
  TrackOptions on = TrialsAlone();
  on.ambiguity_max_spread_m = 0.01;
  on.ambiguity_max_spread_rad = 0.005;
  TrackOptions off = on;
  off.ambiguity_accept_m2 = 0.0;
  const ReflectionRun without = YawSweepWithReflections(off, frames, 3);
  EXPECT_EQ(g_tracker.counters().ambiguous_decided, 0U);
  const ReflectionRun with = YawSweepWithReflections(on, frames, 3);
  const std::uint32_t decided = g_tracker.counters().ambiguous_decided;
  std::printf("trials that disagree: posed %d of %d frame sets with >= 3 beacons after a pose (%u decided by the "
              "motion), %d of %d without\n", with.posed, with.eligible, decided, without.posed, without.eligible);
  EXPECT_EQ(with.wrong, 0);
  EXPECT_EQ(without.wrong, 0);
  EXPECT_GT(decided, 0U);
  EXPECT_GT(with.posed * without.eligible, without.posed * with.eligible);
}

// A reflection that flickers beside a beacon (a new blob every frame set) does not continue the
// beacon's steady image track: the beacon keeps its blob without trials (counted in
// ambiguity_continued), and three-beacon frame sets that the trials leave ambiguous (two exact
// poses) keep their pose. Every published pose is checked against the truth (Step). (Reflections
// that move with the scene are steady like beacons and still tried: NavMatrix.
// ReflectionsMovingWithTheSceneGiveNoWrongFix.)
TEST(TrackerTest, FlickeringReflectionsFollowTheBlobTracks) {
  const int frames = testing::Trials(400, 160);
  const ReflectionRun alone = YawSweepWithReflections(TrialsAlone(), frames, 3);
  EXPECT_EQ(g_tracker.counters().ambiguity_continued, 0U);
  const ReflectionRun tracks = YawSweepWithReflections(TrackOptions{}, frames, 3);
  const std::uint32_t continued = g_tracker.counters().ambiguity_continued;
  std::printf("flickering reflections: posed %d of %d frame sets with >= 3 beacons after a pose (%u beacons kept "
              "by their blob tracks), %d of %d by the trials alone\n",
              tracks.posed, tracks.eligible, continued, alone.posed, alone.eligible);
  EXPECT_EQ(tracks.wrong, 0);
  EXPECT_EQ(alone.wrong, 0);
  EXPECT_GT(continued, 0U);
  // (Measured: 257 of 258, 110 of 121 alone; 160 frame sets: see the fast-mode line.)
  ASSERT_GT(tracks.eligible, frames / 4);
  EXPECT_GT(tracks.posed * alone.eligible, alone.posed * tracks.eligible);
  EXPECT_GE(tracks.posed * 100, tracks.eligible * 95);
}

// The body is "kidnapped": after tracking, its attitude jumps by 120 deg. The tracker must not
// follow the old pose into a wrong fix; it re-identifies and tracks again.
TEST(TrackerTest, KidnappedBodyIsReidentified) {
  const Rig rig = PaperRig();
  ASSERT_TRUE(g_tracker.Reset(rig));
  std::mt19937_64 rng(600);
  Sweep run;
  int fixes_after_jump = 0;
  const int frames = testing::Trials(400, 260);
  for (int f = 0; f < frames; ++f) {
    const int deg = f < 120 ? f : f + 120;
    testing::Observe(rig, testing::YawPose(DegToRad(deg)), 0.2, &rng, &g_scene);
    Step(rig, g_scene, static_cast<std::uint64_t>(f) * kFrameNs, TrackOptions{}, &run);
    if (f >= 120 && g_result.status != TrackStatus::kLost) ++fixes_after_jump;
  }
  run.Print("kidnapped at frame 120");
  EXPECT_EQ(run.wrong, 0);
  EXPECT_GT(fixes_after_jump, 50);
  EXPECT_GE(g_tracker.counters().lis_runs, 1U);
}

// The pose at frame set f (30 Hz) of a path from `start` at constant v_w (m/s, world) and
// omega_b (rad/s, body).
BodyPose ConstantRatePose(const BodyPose& start, const Eigen::Vector3d& v_w, const Eigen::Vector3d& omega_b, int f) {
  const double t = static_cast<double>(f) * kFrameNs * 1e-9;
  return BodyPose{start.C_w_b * ExpSO3(omega_b * t), start.r_w_wb + v_w * t};
}

// The slow path of the stall tests: 5 cm/s along x_w and 3 deg/s about the body's z axis.
BodyPose SlowPathPose(const BodyPose& start, int f) {
  return ConstantRatePose(start, Eigen::Vector3d(0.05, 0.0, 0.0), Eigen::Vector3d(0.0, 0.0, 0.05), f);
}

// Frame sets [0, frames) of the slow path, no frame from any camera in [from, to) (a stall:
// nothing seen, nothing refuted), `spurious` spots per frame set.
struct Stall {
  int from = 0, to = 0, frames = 0;
  int spurious = 0;
};

// Tracks the slow path from `start`, given (SetPose), through the stall; every published pose is
// checked (Step, into *run). Returns the frame sets from the stall's end to the first pose after
// it (-1: none); *lost_before: frame sets before the stall without a pose.
int TrackThroughStall(const Rig& rig, const BodyPose& start, const Stall& st, const TrackOptions& o,
                      std::mt19937_64* rng, Sweep* run, int* lost_before) {
  EXPECT_TRUE(g_tracker.Reset(rig));
  g_tracker.SetPose(start, 0, 0.0, 0.0);
  int recovered = -1;
  *lost_before = 0;
  for (int f = 0; f < st.frames; ++f) {
    testing::Observe(rig, SlowPathPose(start, f), 0.1, rng, &g_scene);
    testing::AddSpurious(rig, st.spurious, rng, &g_scene);
    const auto t_ns = static_cast<std::uint64_t>(f) * kFrameNs;
    if (f >= st.from && f < st.to) {
      g_tracker.Track(g_scene.blobs.data(), 0, t_ns, o, &g_result, 0U);
      continue;
    }
    Step(rig, g_scene, t_ns, o, run);
    const bool posed = g_result.status != TrackStatus::kLost;
    if (f < st.from) *lost_before += !posed;
    if (f >= st.to && recovered < 0 && posed) recovered = f - st.to;
  }
  return recovered;
}

// After a gap in a large map (no frame from any camera for 1.5 s: nothing seen, nothing
// refuted), the prediction seeds the re-identification within its grown bounds (0.13 m,
// 0.25 rad): found again within a few frame sets, never wrong, with 2 reflections per camera.
TEST(TrackerTest, LargeMapStallIsBridgedBySeededSearch) {
  std::mt19937_64 rng(820);
  static Rig rig;
  rig = testing::RandomCylinderRig(128, true, &rng);
  ASSERT_TRUE(g_tracker.Reset(rig));
  const TrackOptions o;
  constexpr Stall kStall{.from = 30, .to = 75, .frames = 115, .spurious = 6};
  int worst = 0, cases = 0;
  for (int trial = 0; trial < testing::Trials(4, 2); ++trial) {
    BodyPose start;
    do {
      start = testing::RandomCylinderPose(&rng, 2.1, 6.0, 0.8);
      testing::Observe(rig, start, 0.1, &rng, &g_scene);
    } while (g_scene.NumVisibleBeacons() < 6);
    Sweep run;
    int lost_before = 0;
    const int recovered = TrackThroughStall(rig, start, kStall, o, &rng, &run, &lost_before);
    std::printf("trial %d: track found again %d frame sets after the gap\n", trial, recovered);
    EXPECT_EQ(lost_before, 0) << "trial " << trial << ": lost before the gap";
    EXPECT_EQ(run.wrong, 0);
    EXPECT_GE(recovered, 0) << "trial " << trial << ": never found again";
    worst = std::max(worst, recovered < 0 ? kStall.frames : recovered);
    ++cases;
  }
  EXPECT_LE(worst, 10);  // measured 0-2
  EXPECT_GT(cases, 0);
}

// A search near the prediction that one frame set's budget cuts goes on over the next ones
// (TrackOptions::spread_seeded_search). After a 2 s stall (nothing from any camera; tracking
// gives up after max_coast_s = 0.5 s), four or five beacons in view and 4 spots a frame set in
// random 64-beacon cylinders: the prediction's bounds have grown past what one budget searches,
// and a search of each frame set afresh is cut every time. Spread, the searches end, and the
// track is found again sooner, never later, never wrong (measured on 24 draws: 5 found sooner
// when spread - after 1 frame set against 2, 39, 48, 52 or never; the others identical, 4 of
// them never found in 60 frame sets either way).
TEST(TrackerTest, SeededSearchCutByTheBudgetGoesOnOverFrameSets) {
  std::mt19937_64 rng(2812);
  static Rig rig;
  // (Under qemu and the sanitizers: 12 draws, 30 frame sets after the stall.)
  const Stall kStall{.from = 20, .to = 80, .frames = 80 + testing::Trials(60, 30), .spurious = 4};
  const int draws = testing::Trials(24, 12);
  int cases = 0, lost_fresh = 0, lost_spread = 0;  // frame sets after the stall until a pose
  std::uint32_t spread_ended = 0;
  for (int trial = 0; cases < draws && trial < 2000; ++trial) {
    rig = testing::RandomCylinderRig(64, true, &rng);
    const BodyPose start = testing::RandomCylinderPose(&rng, 2.1, 6.0, 0.8);
    bool few = true;  // four or five beacons in view before the stall and after it
    for (int f : {0, kStall.from - 1, kStall.to, kStall.to + 4}) {
      testing::Observe(rig, SlowPathPose(start, f), 0.1, &rng, &g_scene);
      few = few && g_scene.NumVisibleBeacons() >= 4 && g_scene.NumVisibleBeacons() <= 5;
    }
    if (!few) continue;
    ++cases;
    std::array<int, 2> recovered{};
    for (const bool spread : {false, true}) {
      TrackOptions o;
      o.max_coast_s = 0.5;
      o.spread_seeded_search = spread;
      std::mt19937_64 noise(static_cast<std::uint64_t>(trial));  // the same frame sets in both
      Sweep run;
      int lost_before = 0;
      recovered[spread] = TrackThroughStall(rig, start, kStall, o, &noise, &run, &lost_before);
      EXPECT_EQ(run.wrong, 0) << "trial " << trial << " spread " << spread;
      EXPECT_EQ(lost_before, 0) << "trial " << trial << " spread " << spread;
      if (spread) spread_ended += g_tracker.counters().seeded_spread_ended;
    }
    std::printf("trial %d: found again %d frame sets after the stall searching afresh, %d spread\n", trial,
                recovered[0], recovered[1]);
    const int never = kStall.frames - kStall.to;
    lost_fresh += recovered[0] >= 0 ? recovered[0] : never;
    lost_spread += recovered[1] >= 0 ? recovered[1] : never;
    if (recovered[0] >= 0) {
      EXPECT_GE(recovered[1], 0) << "trial " << trial;
      EXPECT_LE(recovered[1], recovered[0] + 2) << "trial " << trial;
    }
  }
  EXPECT_EQ(cases, draws);
  EXPECT_LT(lost_spread, lost_fresh);
  EXPECT_GT(spread_ended, 0U);
}

// A cold start in a sparse view: four beacons of a random 64-beacon cylinder in view (4 spots
// per frame set; a lost-in-space fix confirms on five), then a fifth comes into view. The cold
// search in progress starts over on a frame set with more blobs or more steady ones
// (restart_cold_search), where it went on with the older blobs until its work ran out or
// cold_search_s passed. Both modes on the same frame sets, without steady lists (with them the
// four-beacon view is often acquired before the fifth beacon comes, at the same frame set in
// both modes: all 8 draws of the fast set alike, 4 of them at frame set 4-5): never wrong, the
// first pose never later by more than 2 frame sets with the restart, sooner in all. With steady
// lists too (the default): never wrong, and in all no later than with the restart alone
// (measured over the 16 draws: 296, 279 and 228 frame sets to the first poses in all).
TEST(TrackerTest, ColdSearchStartsOverForABeaconComeIntoView) {
  std::mt19937_64 rng(4021);
  static Rig rig;
  const int draws = testing::Trials(16, 8);
  constexpr int kFrames = 60;
  const Eigen::Vector3d v_w(0.15, 0.0, 0.0), omega_b(0.0, 0.0, 0.2);  // m/s, rad/s
  int cases = 0;
  std::array<int, 3> total{};  // frame sets to the first pose: without the restart, with it, the defaults
  std::uint32_t restarts = 0;
  for (int trial = 0; cases < draws && trial < 4000; ++trial) {
    rig = testing::RandomCylinderRig(64, true, &rng);
    const BodyPose start = testing::RandomCylinderPose(&rng, 2.1, 6.0, 0.8);
    bool sparse_then_more = true;
    for (int f : {0, 4, 20, 30}) {
      testing::Observe(rig, ConstantRatePose(start, v_w, omega_b, f), 0.1, &rng, &g_scene);
      const int n = g_scene.NumVisibleBeacons();
      sparse_then_more = sparse_then_more && (f <= 4 ? n == 4 : n >= 5);
    }
    if (!sparse_then_more) continue;
    ++cases;
    std::array<int, 3> first{};
    for (const int mode : {0, 1, 2}) {
      const bool restart = mode > 0;
      TrackOptions o;
      o.restart_cold_search = restart;
      o.steady_lists = mode == 2;
      std::mt19937_64 noise(static_cast<std::uint64_t>(trial));  // the same frame sets in all
      EXPECT_TRUE(g_tracker.Reset(rig));
      Sweep run;
      for (int f = 0; f < kFrames; ++f) {
        testing::Observe(rig, ConstantRatePose(start, v_w, omega_b, f), 0.1, &noise, &g_scene);
        testing::AddSpurious(rig, 4, &noise, &g_scene);
        Step(rig, g_scene, static_cast<std::uint64_t>(f) * kFrameNs, o, &run);
      }
      EXPECT_EQ(run.wrong, 0) << "trial " << trial << " mode " << mode;
      first[static_cast<std::size_t>(mode)] = run.first_fix >= 0 ? run.first_fix : kFrames;
      if (mode == 1) restarts += g_tracker.counters().cold_search_restarted;
    }
    std::printf("trial %d: first pose at frame set %d going on, %d starting over, %d with steady lists too\n", trial,
                first[0], first[1], first[2]);
    EXPECT_LE(first[1], first[0] + 2) << "trial " << trial;
    for (int m = 0; m < 3; ++m) total[static_cast<std::size_t>(m)] += first[static_cast<std::size_t>(m)];
  }
  EXPECT_EQ(cases, draws);
  EXPECT_LT(total[1], total[0]);
  EXPECT_LE(total[2], total[1]);
  EXPECT_GT(restarts, 0U);
}

// After a stall longer than max_coast_s (0.5 s here; no frame from any camera), the last pose
// still seeds re-identification (max_seed_s). With spots in view that no beacon explains, a
// seeded survivor on three beacons waits min_acquire_frames frame sets (two beacons and a
// reflection fit an exact pose); one on four beacons has residuals to test and is accepted from
// the first list near the prediction. Four beacons in view (random 64-beacon cylinders, facing
// in the map, 4 spots per frame set), so that no lost-in-space fix is confirmed on its own (that
// needs five).
TEST(TrackerTest, SeededSurvivorOnFourBeaconsIsAcceptedAtOnce) {
  std::mt19937_64 rng(2812);
  static Rig rig;
  TrackOptions o;
  o.max_coast_s = 0.5;  // so that a short stall, whose prediction bounds are narrow, is re-identified
  constexpr Stall kStall{.from = 20, .to = 44, .frames = 60, .spurious = 4};  // 0.8 s at 30 Hz
  int cases = 0;
  for (int trial = 0; cases < testing::Trials(6, 3) && trial < 400; ++trial) {
    rig = testing::RandomCylinderRig(64, true, &rng);
    const BodyPose start = testing::RandomCylinderPose(&rng, 2.1, 6.0, 0.8);
    bool four = true;  // four beacons in view before the stall and for 5 frame sets after it
    for (int f : {0, kStall.from - 1, kStall.to, kStall.to + 4}) {
      testing::Observe(rig, SlowPathPose(start, f), 0.1, &rng, &g_scene);
      four = four && g_scene.NumVisibleBeacons() == 4;
    }
    if (!four) continue;
    ++cases;
    Sweep run;
    int lost_before = 0;
    const int recovered = TrackThroughStall(rig, start, kStall, o, &rng, &run, &lost_before);
    std::printf("trial %d: posed again %d frame sets after the stall (acquired %d)\n", trial, recovered, run.acquired);
    EXPECT_EQ(run.wrong, 0);
    EXPECT_EQ(recovered, 0) << "trial " << trial;
  }
  EXPECT_EQ(cases, testing::Trials(6, 3));
}

// After a gap with two beacons in view, a third comes into view with reflections flickering
// beside the beacons (a new blob every frame set) and spots elsewhere: two beacons and a
// reflection fit a pose exactly, centimetres from the truth, and two beacons and two
// reflections may fit a pose metres away. Every published pose is checked against the truth
// and its covariance (Step), the two-beacon frame sets too. Wrong poses found here: a
// lost-in-space fix on two beacons and two reflections 2.4 m off at 0.74 px RMS (now refused by
// the chi-square test of its residuals, residual_test_sigmas), acquired three-beacon poses on a
// reflection 20-32 mm off at 40 of their 1-sigma (a three-beacon acquired pose now waits until
// its blobs are steady, unsteady_refused; trials that fit alike prefer steady blobs; the
// acquired pose's own blobs win Unambiguous's trials). The map keeps three beacons in view
// along the path (the others it would show face away: the navigator's map says so too);
// during the gap the third beacon's camera delivers nothing. Random cylinder maps and paths.
struct ThirdBeaconRun {
  int eligible = 0, posed = 0, wrong = 0;
  std::uint32_t continued = 0;  // TrackCounters::continued over the paths
};

constexpr int kGapFrom = 20, kThirdFrom = 45, kPathFrames = 90, kReflections = 2;

BodyPose PathPoseFrom(const BodyPose& start, int f) {
  return ConstantRatePose(start, Eigen::Vector3d(0.02, 0.0, 0.01), Eigen::Vector3d(0.0, 0.03, 0.02), f);
}

// A cylinder map and a path along which exactly three beacons are in view, two in one camera and
// one in another (*third_camera); false when the attempts found none.
bool ThreeBeaconPath(std::mt19937_64* rng, Rig* rig, BodyPose* start, int* third_camera) {
  for (int attempt = 0; attempt < 200; ++attempt) {
    *rig = testing::RandomCylinderRig(64, true, rng);
    *start = testing::RandomCylinderPose(rng, 2.1, 6.0, 0.8);
    // Beacons seen at both ends of the path, by camera.
    std::array<std::array<bool, limits::kMaxBeacons>, limits::kMaxCameras> both{}, end_seen{};
    testing::Observe(*rig, PathPoseFrom(*start, kPathFrames - 1), 0.0, rng, &g_scene);
    for (int i = 0; i < g_scene.num_blobs; ++i)
      end_seen[static_cast<std::size_t>(g_scene.blobs[static_cast<std::size_t>(i)].camera)]
              [static_cast<std::size_t>(g_scene.truth_beacon[static_cast<std::size_t>(i)])] = true;
    testing::Observe(*rig, *start, 0.0, rng, &g_scene);
    for (auto& per_camera : both) per_camera.fill(false);
    for (int i = 0; i < g_scene.num_blobs; ++i) {
      const auto k = static_cast<std::size_t>(g_scene.blobs[static_cast<std::size_t>(i)].camera);
      const auto b = static_cast<std::size_t>(g_scene.truth_beacon[static_cast<std::size_t>(i)]);
      both[k][b] = end_seen[k][b];
    }
    std::array<int, 3> keep{-1, -1, -1};
    // Two beacons of camera a, one of camera c.
    int a = -1, c = -1;
    for (int k = 0; k < rig->num_cameras; ++k) {
      int n = 0;
      for (int b = 0; b < rig->num_beacons; ++b) n += both[static_cast<std::size_t>(k)][static_cast<std::size_t>(b)];
      if (n >= 2 && a < 0) a = k;
      else if (n >= 1 && c < 0) c = k;
    }
    if (a < 0 || c < 0) continue;
    int n = 0;
    for (int b = 0; b < rig->num_beacons && n < 2; ++b)
      if (both[static_cast<std::size_t>(a)][static_cast<std::size_t>(b)]) keep[static_cast<std::size_t>(n++)] = b;
    for (int b = 0; b < rig->num_beacons; ++b)
      if (both[static_cast<std::size_t>(c)][static_cast<std::size_t>(b)] && b != keep[0] && b != keep[1]) keep[2] = b;
    if (keep[2] < 0) continue;
    // Every other beacon seen along the path faces away from the module's inside.
    bool three = true;
    for (int f = 0; f < kPathFrames; ++f) {
      testing::Observe(*rig, PathPoseFrom(*start, f), 0.0, rng, &g_scene);
      for (int i = 0; i < g_scene.num_blobs; ++i) {
        const auto b = static_cast<std::size_t>(g_scene.truth_beacon[static_cast<std::size_t>(i)]);
        if (std::find(keep.begin(), keep.end(), static_cast<int>(b)) == keep.end())
          rig->beacon_normal_w[b] = -rig->beacon_normal_w[b];
      }
    }
    for (int f = 0; f < kPathFrames && three; ++f) {
      testing::Observe(*rig, PathPoseFrom(*start, f), 0.0, rng, &g_scene);
      three = g_scene.NumVisibleBeacons() == 3 && g_scene.per_camera[static_cast<std::size_t>(c)] == 1;
    }
    if (!three) continue;
    *third_camera = c;
    return true;
  }
  return false;
}

// gap: the third beacon's camera is silent for frame sets kGapFrom..kThirdFrom, and the frame
// sets from kThirdFrom on are counted; else every frame set after the first is.
ThirdBeaconRun ThirdBeaconBesideReflections(const TrackOptions& o, int trials, bool gap = true) {
  std::mt19937_64 rng(1700);
  static Rig rig;
  ThirdBeaconRun out;
  for (int trial = 0; trial < trials; ++trial) {
    BodyPose start;
    int third_camera = -1;
    if (!ThreeBeaconPath(&rng, &rig, &start, &third_camera) || !g_tracker.Reset(rig)) continue;
    g_tracker.SetPose(start, 0, 0.0, 0.0);
    Sweep run;
    for (int f = 0; f < kPathFrames; ++f) {
      testing::Observe(rig, PathPoseFrom(start, f), 0.1, &rng, &g_scene);
      testing::AddReflections(rig, kReflections, 5.0, 40.0, &rng, &g_scene);
      testing::AddSpurious(rig, 3, &rng, &g_scene);
      const auto t_ns = static_cast<std::uint64_t>(f) * kFrameNs;
      if (gap && f >= kGapFrom && f < kThirdFrom) {
        // The third beacon's camera delivers nothing: two beacons in view.
        Step(rig, g_scene, t_ns, o, &run, kAllCameras & ~(1u << third_camera));
        continue;
      }
      Step(rig, g_scene, t_ns, o, &run);
      if (f >= (gap ? kThirdFrom : 1)) {
        ++out.eligible;
        out.posed += g_result.status != TrackStatus::kLost;
      }
    }
    out.wrong += run.wrong;
    out.continued += g_tracker.counters().continued;
  }
  return out;
}

TEST(TrackerTest, ThirdBeaconBesideFlickeringReflectionsIsNeverWrong) {
  const ThirdBeaconRun run = ThirdBeaconBesideReflections(TrackOptions{}, testing::Trials(12, 4));
  std::printf("a third beacon beside flickering reflections: posed %d of %d frame sets after the gap, wrong %d\n",
              run.posed, run.eligible, run.wrong);
  // (Session 17's tracker: wrong poses in these 12 paths, the lost-in-space fix 2.4 m off among
  // them.)
  EXPECT_EQ(run.wrong, 0);
  ASSERT_GT(run.eligible, 0);
  // (Measured: 462 of 540 (86 %) on the host, 367 before the track went on on continuing blobs;
  // in the fast mode's four paths 167 of 180 on the host (161 before), 96 of 180 on aarch64
  // (qemu) before, where rounding takes other branches. A
  // path's outcome hangs on when its first acquisition succeeds, so the floor is loose: it
  // fails a tracker that stops posing, not one that poses a path later.)
  EXPECT_GE(run.posed * 100, run.eligible * 30);
}

// The same three-beacon paths without the gap, from a known (verified) start: a pose on three
// beacons (two in one camera) is centimetres uncertain, so its prediction's gate exceeds
// max_gate_px and nearest-blob tracking stops. The blobs that continue its beacons' steady image
// tracks carry their identities instead (TrackOptions::continuity_max_m2): without them each
// re-identified pose was followed by two frame sets of re-identification, with them the track
// goes on. Never a wrong pose either way. (An unverified track, as after the gap above, is not
// carried on: its identities may be an unmapped light's alias.)
TEST(TrackerTest, ThreeBeaconStretchesFollowTheBlobTracks) {
  const int trials = testing::Trials(12, 6);
  TrackOptions off;
  off.continuity_max_m2 = 0.0;
  const ThirdBeaconRun with = ThirdBeaconBesideReflections(TrackOptions{}, trials, false);
  const ThirdBeaconRun without = ThirdBeaconBesideReflections(off, trials, false);
  std::printf("three-beacon stretches: posed %d of %d frame sets on continuing blobs (wrong %d; %u tracked on "
              "them), %d without (wrong %d)\n",
              with.posed, with.eligible, with.wrong, with.continued, without.posed, without.wrong);
  EXPECT_EQ(with.wrong, 0);
  EXPECT_EQ(without.wrong, 0);
  ASSERT_EQ(with.eligible, without.eligible);
  // (Measured on the host: 462 of 540 against 366 without; 4 paths: see the fast mode's line.)
  EXPECT_GE(with.posed - without.posed, with.eligible / 10);
  EXPECT_GE(with.posed * 100, with.eligible * 60);
}

// Yaw sweep of the paper rig, tracked with a surveyed map (every beacon coordinate off by
// N(0, sigma_mm)) while the blobs come from the true one: frame sets with >= 3 beacons after
// the first fix, and how many of them have a pose. Every pose must name the right beacons and
// lie near the truth (a three-beacon pose carries the map error, amplified: centimetres).
struct MapErrorRun {
  int eligible = 0, posed = 0, wrong = 0;
};

MapErrorRun YawSweepWithMapError(std::uint64_t seed, double sigma_mm, bool allow, int frames) {
  const Rig truth = PaperRig();
  Rig map = truth;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  for (int m = 0; m < map.num_beacons; ++m)
    for (int i = 0; i < 3; ++i) map.beacons_w[static_cast<std::size_t>(m)](i) += 1e-3 * sigma_mm * n01(rng);
  map.beacon_sigma = 1e-3 * sigma_mm;
  TrackOptions o;
  if (allow) o.AllowForMapError(BeaconMapErrorPx(map, o.gate_depth_m));
  MapErrorRun run;
  if (!g_tracker.Reset(map)) return run;
  bool fixed_once = false;
  for (int step = 0; step < frames; ++step) {
    testing::Observe(truth, testing::YawPose(DegToRad(step)), 0.1, &rng, &g_scene);
    const TrackStatus st = g_tracker.Track(g_scene.blobs.data(), g_scene.num_blobs,
                                           static_cast<std::uint64_t>(step) * kFrameNs, o, &g_result);
    const bool posed = st != TrackStatus::kLost;
    if (posed) {
      const double dr = (g_result.pose.r_w_wb - g_scene.pose.r_w_wb).norm();
      const double da = AngleBetween(g_result.pose.C_w_b, g_scene.pose.C_w_b);
      run.wrong += !IdentitiesRight(g_scene, g_result.matches) || dr > 0.05 || da > DegToRad(5.0);
    }
    if (fixed_once && g_scene.NumVisibleBeacons() >= 3) {
      ++run.eligible;
      run.posed += posed;
    }
    fixed_once = fixed_once || posed;
  }
  return run;
}

// Seen on the turntable: with the residual bounds sized for centroid noise, a fourth beacon
// entering the view is dropped as an outlier (or a three-beacon pose predicts it pixels off),
// the track is refuted and re-acquisition takes tens of frame sets. AllowForMapError keeps
// the track (and never on the wrong beacons).
TEST(TrackerTest, SurveyedMapKeepsTheTrack) {
  const int frames = testing::Trials(360, 200);
  MapErrorRun plain, allowed;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const MapErrorRun p = YawSweepWithMapError(900 + seed, 0.4, false, frames);
    const MapErrorRun a = YawSweepWithMapError(900 + seed, 0.4, true, frames);
    std::printf("map draw %d: posed %d of %d (wrong %d) with the map allowance, %d of %d (wrong %d) without\n",
                static_cast<int>(seed), a.posed, a.eligible, a.wrong, p.posed, p.eligible, p.wrong);
    plain.eligible += p.eligible;
    plain.posed += p.posed;
    allowed.eligible += a.eligible;
    allowed.posed += a.posed;
    allowed.wrong += a.wrong;
  }
  EXPECT_EQ(allowed.wrong, 0);
  EXPECT_GT(allowed.eligible, 0);
  EXPECT_GE(allowed.posed, allowed.eligible * 97 / 100);
  EXPECT_GE(allowed.posed, plain.posed);
  // Unknown map error: the options stay as they were.
  TrackOptions o;
  o.AllowForMapError(BeaconMapErrorPx(PaperRig(), 0.0));
  EXPECT_EQ(o.refine_gate_px, TrackOptions{}.refine_gate_px);
  o.AllowForMapError(0.0);
  EXPECT_EQ(o.max_rms_px, TrackOptions{}.max_rms_px);
  EXPECT_EQ(o.solve.outlier_threshold_px, TrackOptions{}.solve.outlier_threshold_px);
}

// The gates keep their angular size: the factor is the rig's largest focal length over the
// paper cameras' 1600 px/rad (the same optics at a quarter of the pixels: a quarter).
TEST(TrackerTest, PixelGateScaleFollowsTheFocalLength) {
  Rig rig = PaperRig();
  double f = 0.0;
  for (int k = 0; k < rig.num_cameras; ++k)
    f = std::max({f, rig.cameras[static_cast<std::size_t>(k)].intrinsics.alpha_x,
                  rig.cameras[static_cast<std::size_t>(k)].intrinsics.alpha_y});
  EXPECT_NEAR(PixelGateScale(rig), f / 1600.0, 1e-12);
  EXPECT_NEAR(PixelGateScale(rig), 1.0, 0.01);  // Table 2's cameras: ~1600 px/rad
  for (int k = 0; k < rig.num_cameras; ++k) {
    rig.cameras[static_cast<std::size_t>(k)].intrinsics.alpha_x /= 4;
    rig.cameras[static_cast<std::size_t>(k)].intrinsics.alpha_y /= 4;
  }
  EXPECT_NEAR(PixelGateScale(rig), f / 6400.0, 1e-12);
  rig.num_cameras = 0;
  EXPECT_EQ(PixelGateScale(rig), 1.0);
}

TEST(TrackerTest, StatusesCountersAndOptions) {
  Tracker& tr = g_tracker;
  Tracker fresh;  // never Reset: refuses
  EXPECT_EQ(fresh.Track(nullptr, 0, 0, TrackOptions{}, &g_result), TrackStatus::kLost);
  EXPECT_EQ(g_result.reason, TrackReason::kBadInput);
  const Rig rig = PaperRig();
  ASSERT_TRUE(tr.Reset(rig));
  std::mt19937_64 rng(700);
  testing::Observe(rig, testing::YawPose(DegToRad(10.0)), 0.2, &rng, &g_scene);
  EXPECT_EQ(tr.Track(g_scene.blobs.data(), 0, 0, TrackOptions{}, &g_result), TrackStatus::kLost);
  EXPECT_EQ(g_result.reason, TrackReason::kTooFewBlobs);
  Scene bad = g_scene;
  bad.blobs[0].camera = -1;
  EXPECT_EQ(tr.Track(bad.blobs.data(), bad.num_blobs, 1, TrackOptions{}, &g_result), TrackStatus::kLost);
  EXPECT_EQ(g_result.reason, TrackReason::kBadInput);
  TrackOptions o;
  const char* why = nullptr;
  EXPECT_TRUE(o.IsValid(&why));
  o.max_gate_px = 5.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_STREQ(why, "max_gate_px");
  EXPECT_EQ(tr.Track(g_scene.blobs.data(), g_scene.num_blobs, 2, o, &g_result), TrackStatus::kLost);
  EXPECT_EQ(g_result.reason, TrackReason::kBadInput);
  o = {};
  o.min_acquire_frames = 1;
  EXPECT_FALSE(o.IsValid(&why));
  o = {};
  o.leave_two_out_min_beacons = 5;  // a leave-two-out must keep four beacons
  EXPECT_FALSE(o.IsValid(&why));
  o = {};
  o.continuity_max_m2 = -1.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_STREQ(why, "continuity_max_m2");
  o = {};
  o.lis.max_blobs = 2;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_STREQ(why, "max_blobs");
  for (const int work : {0, limits::kMaxLisHypotheses + 1}) {
    o = {};
    o.seeded_max_hypotheses = work;
    EXPECT_FALSE(o.IsValid(&why));
    EXPECT_STREQ(why, "seeded_max_hypotheses");
  }
  const TrackCounters& c = tr.counters();
  EXPECT_EQ(c.frames, 3U);
  EXPECT_EQ(c.by_status[static_cast<std::size_t>(TrackStatus::kLost)], 3U);
  EXPECT_EQ(c.by_reason[static_cast<std::size_t>(TrackReason::kBadInput)], 2U);
  EXPECT_EQ(c.by_reason[static_cast<std::size_t>(TrackReason::kTooFewBlobs)], 1U);
  for (int i = 0; i < kNumTrackReason; ++i)
    EXPECT_STRNE(ToString(static_cast<TrackReason>(i)), "unknown track reason");
  for (int i = 0; i < kNumTrackStatus; ++i)
    EXPECT_STRNE(ToString(static_cast<TrackStatus>(i)), "unknown track status");
}

}  // namespace
}  // namespace mfns::fw
