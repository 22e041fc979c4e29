// Issue 16's must-show for beacon health, through the navigator mfns-navd runs (fw::Navigator)
// on the blob-level simulation of several scenarios: the beacon seen most often is moved 5 mm
// after the survey (the map the navigator gets keeps it where it was, 5 mm across its mean line
// of sight). It must be flagged inconsistent within 50 frame sets of being in view, no pose may
// be published as fix that is wrong (issue 13's measure: off by more than max(20 mm, 10 x its
// own 1-sigma) or 1 deg), and the fixes must not get much rarer than with the true map, where no
// beacon is ever flagged inconsistent. The navigator starts from the first true pose (as the
// demo's mfns-navd does); issue 13's matrix covers cold starts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "firmware/app/navd/navigator.h"
#include "host/sim/navmatrix/matrix.h"
#include "host/sim/navmatrix/navmatrix.h"
#include "host/sim/observe/observe.h"
#include "host/sim/scenario/scenario.h"

namespace mfns::host {
namespace {

struct Flight {
  Scenario scenario;
  std::vector<FrameTruth> truth;
  std::vector<BlobFrameSet> blobs;
};

Flight Simulate(const RunSpec& spec) {
  Flight f{MatrixScenario(spec), {}, {}};
  f.truth = SimulateTrajectory(f.scenario);
  for (const FrameTruth& t : f.truth) f.blobs.push_back(SimulateBlobs(f.scenario, t));
  return f;
}

bool Sees(const BlobFrameSet& b, int beacon) {
  for (const std::vector<int>& v : b.visible)
    if (std::find(v.begin(), v.end(), beacon) != v.end()) return true;
  return false;
}

// The beacon in view in the most frame sets, and a 5 mm shift across its mean line of sight.
// rank 1: the second most seen (ties in beacon order), and so on.
int MostSeen(const Flight& f, const Rig& rig, Eigen::Vector3d* shift, int rank = 0) {
  std::vector<int> seen(static_cast<std::size_t>(rig.num_beacons), 0);
  for (const BlobFrameSet& b : f.blobs)
    for (int m = 0; m < rig.num_beacons; ++m) seen[static_cast<std::size_t>(m)] += Sees(b, m) ? 1 : 0;
  std::vector<int> order(seen.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return seen[static_cast<std::size_t>(a)] > seen[static_cast<std::size_t>(b)]; });
  const int best = order[static_cast<std::size_t>(rank)];
  Eigen::Vector3d ray = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < f.blobs.size(); ++i)
    if (Sees(f.blobs[i], best)) ray += (rig.beacons_w[static_cast<std::size_t>(best)] - f.truth[i].pose.r_w_wb).normalized();
  *shift = 5e-3 * ray.normalized().unitOrthogonal();
  return best;
}

struct Outcome {
  int fixes = 0, wrong_fixes = 0;
  int in_view_until_flag = -1;  // in-view frame sets of `watched` until it was flagged (-1: never)
  int second_until_flag = -1;   // ... of `second`, when watched
  int inconsistent_frames = 0;  // frame sets with any other beacon flagged inconsistent
  bool flagged_at_end = false;  // `watched` flagged (inconsistent or missing) after the last frame set
  std::uint32_t left_out = 0;   // poses published with one beacon left out (TrackCounters::left_out)
};

// second (>= 0): a second watched beacon (moved too), not counted among the others.
Outcome Navigate(const Flight& f, const Rig& rig, int watched, int second = -1) {
  auto nav = std::make_unique<fw::Navigator>();
  const NavMatrixOptions o;
  const char* why = nullptr;
  EXPECT_TRUE(nav->Init(rig, o.navigator, &why)) << why;
  nav->SetInitialPose(f.truth.front().pose, 0.01, 0.01);
  auto out = std::make_unique<fw::NavOutput>();
  Outcome r;
  int in_view = 0, second_in_view = 0;
  for (std::size_t i = 0; i < f.blobs.size(); ++i) {
    const BlobFrameSet& b = f.blobs[i];
    std::uint32_t delivered = 0;
    for (int k = 0; k < rig.num_cameras; ++k) delivered |= b.delivered[static_cast<std::size_t>(k)] ? 1U << k : 0U;
    nav->Step(b.blobs.data(), static_cast<int>(b.blobs.size()), static_cast<std::uint64_t>(f.truth[i].t_ns), delivered,
              false, out.get());
    in_view += Sees(b, watched) ? 1 : 0;
    second_in_view += second >= 0 && Sees(b, second) ? 1 : 0;
    const fw::BeaconHealth& h = nav->beacon_health();
    if (r.in_view_until_flag < 0 && h.stats(watched).state == fw::BeaconState::kInconsistent) r.in_view_until_flag = in_view;
    if (second >= 0 && r.second_until_flag < 0 && h.stats(second).state == fw::BeaconState::kInconsistent)
      r.second_until_flag = second_in_view;
    bool other = false;
    for (int m = 0; m < rig.num_beacons; ++m)
      other |= m != watched && m != second && h.stats(m).state == fw::BeaconState::kInconsistent;
    r.inconsistent_frames += other ? 1 : 0;
    if (out->status != fw::NavStatus::kFix) continue;
    ++r.fixes;
    const FrameRecord rec = RecordFrame(b.NumVisible(), *out, f.truth[i].pose, 0.0);
    r.wrong_fixes += WrongPose(rec.position_error_m, rec.attitude_error_rad, rec.position_sigma_m, o) ? 1 : 0;
  }
  r.flagged_at_end = nav->beacon_health().stats(watched).state != fw::BeaconState::kOk;
  r.left_out = nav->counters().left_out;
  return r;
}

// max_in_view: the frame sets in view by which the beacon must be flagged inconsistent (0: not
// held to it). The paper's turntable sweep (10 beacons, 3-6 in view at 0.6-1.6 m) is not: its
// moved beacon (9) is camera 2's only beacon from the first frame set on, every view of its
// first 64 in-view frame sets has 3 or 4 beacons, all with it, and neither a three-beacon view
// (an exact fit) nor a four-beacon one (one of four is off, not which) can single it out
// (docs/navd.md, "Beacon health"). Its five-beacon views (frame sets 210-225) can: the tracker
// leaves it out (TrackOptions::leave_one_out) and beacon health flags it there (missing: its
// blob lies beyond the 12 px search), and never another beacon. Cylinder 128 seed 2: the fixes
// the moved beacon bent before its flag (after 71 in view) pushed two neighbours over the
// threshold with it, flagged for the rest of the run until one beacon turned inconsistent per
// update (BeaconHealth::Update); since near misses are excused (below) it is flagged after 8.
// Box 128 seed 3: the moved beacon's blob falls outside the tight gate in views of 9-11
// beacons, refusing every pose; never flagged (66 fixes of 249) until the leave-one-out took
// up to 32 beacons (TrackOptions::leave_one_out_max_beacons). Free-flight seed 4: in views of
// 8-9 beacons its blob lay 6.5 px off, beyond the 4 px tight gate, so every pose missed it and
// was refuted (lost-in-space and tracking: lost for 30 frame sets at a time, flagged after 160
// in view, 141 fixes of 299) until one near miss was excused on poses of >= 5 beacons
// (LisOptions::near_miss_min_beacons): flagged after 8, 262 fixes.
TEST(BeaconHealthNavTest, AMovedBeaconIsFlaggedAndNeverMakesAWrongFix) {
  struct Case {
    RunSpec spec;
    int max_in_view;
    bool leaves_out;  // poses with the moved beacon left out must be published
  } cases[] = {
      {{.preset = "paper-turntable", .seed = 1, .frames = 300}, 0, true},
      {{.preset = "free-flight", .seed = 2, .frames = 300}, 50, false},
      {{.preset = "free-flight", .seed = 4, .frames = 300}, 50, false},
      {{.preset = "station-box", .count = 64, .seed = 3, .frames = 300}, 50, false},
      {{.preset = "station-cylinder", .count = 128, .seed = 4, .frames = 300}, 50, false},
      {{.preset = "station-cylinder", .count = 128, .seed = 2, .frames = 300}, 50, false},
      {{.preset = "station-box", .count = 128, .seed = 3, .frames = 300}, 50, false},
  };
  for (const Case& c : cases) {
    const RunSpec& spec = c.spec;
    const Flight f = Simulate(spec);
    const Rig believed = BelievedRig(f.scenario);
    Eigen::Vector3d shift;
    const int moved = MostSeen(f, believed, &shift);
    Rig map = believed;
    map.beacons_w[static_cast<std::size_t>(moved)] += shift;
    const Outcome base = Navigate(f, believed, moved), with = Navigate(f, map, moved);
    std::printf("%s seed %d: beacon %d moved 5 mm: flagged inconsistent after %d frame sets in view, flagged at the "
                "end %d; fixes %d (true map %d), wrong %d; frame sets with another beacon inconsistent %d (true map "
                "%d); poses with a beacon left out %u (true map %u)\n",
                spec.preset.c_str(), static_cast<int>(spec.seed), moved, with.in_view_until_flag, with.flagged_at_end,
                with.fixes, base.fixes, with.wrong_fixes, with.inconsistent_frames, base.inconsistent_frames,
                with.left_out, base.left_out);
    EXPECT_GT(base.fixes, 150) << spec.preset;
    EXPECT_EQ(base.wrong_fixes, 0) << spec.preset;
    EXPECT_EQ(base.inconsistent_frames, 0) << spec.preset;
    EXPECT_EQ(base.in_view_until_flag, -1) << spec.preset << ": flagged on the true map";
    EXPECT_EQ(with.wrong_fixes, 0) << spec.preset;
    EXPECT_EQ(with.inconsistent_frames, 0) << spec.preset;
    EXPECT_FALSE(base.flagged_at_end) << spec.preset;
    EXPECT_TRUE(with.flagged_at_end) << spec.preset;
    if (c.leaves_out) {
      EXPECT_GT(with.left_out, 0u) << spec.preset;
    }
    if (c.max_in_view == 0) continue;
    EXPECT_GT(with.in_view_until_flag, 0) << spec.preset << ": never flagged";
    EXPECT_LE(with.in_view_until_flag, c.max_in_view) << spec.preset;
    // Down-weighted, it leaves the fixes that had a fourth beacon only through it.
    EXPECT_GE(with.fixes, 0.5 * base.fixes) << spec.preset;
  }
}

// Two beacons moved together (a panel with two of its LEDs), the most seen 5 mm one way and the
// second most seen 5 mm the other. Cylinder 64 seed 2: both are in its first views (6 beacons,
// two of them 5-7 px off), so every pose was refused from the first frame set on: four beacons
// within the tight gate leave no near miss excused, and every leave-one-out keeps a moved
// beacon. Neither was ever flagged (97 fixes of 287) until pairs were left out when no single
// leave-out fits (TrackOptions::leave_two_out_*). Over 25 such runs (docs/navd.md, "Two moved
// beacons"): 0 wrong fixes, both flagged within 50 frame sets in view in 18.
TEST(BeaconHealthNavTest, TwoMovedBeaconsAreBothFlagged) {
  const RunSpec spec{.preset = "station-cylinder", .count = 64, .seed = 2, .frames = 300};
  const Flight f = Simulate(spec);
  const Rig believed = BelievedRig(f.scenario);
  Eigen::Vector3d shift_a, shift_b;
  const int a = MostSeen(f, believed, &shift_a), b = MostSeen(f, believed, &shift_b, 1);
  Rig map = believed;
  map.beacons_w[static_cast<std::size_t>(a)] += shift_a;
  map.beacons_w[static_cast<std::size_t>(b)] -= shift_b;
  const Outcome with = Navigate(f, map, a, b);
  std::printf("%s %d seed %d: beacons %d and %d moved 5 mm: flagged after %d and %d frame sets in view; fixes %d, "
              "wrong %d; frame sets with a third beacon inconsistent %d; poses with beacons left out %u\n",
              spec.preset.c_str(), spec.count, static_cast<int>(spec.seed), a, b, with.in_view_until_flag,
              with.second_until_flag, with.fixes, with.wrong_fixes, with.inconsistent_frames, with.left_out);
  EXPECT_EQ(with.wrong_fixes, 0);
  EXPECT_EQ(with.inconsistent_frames, 0);
  EXPECT_GT(with.in_view_until_flag, 0);
  EXPECT_LE(with.in_view_until_flag, 50);
  EXPECT_GT(with.second_until_flag, 0);
  EXPECT_LE(with.second_until_flag, 50);
}

}  // namespace
}  // namespace mfns::host
