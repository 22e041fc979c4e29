#include "firmware/modules/identify/lost_in_space.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <random>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "firmware/modules/identify/tracker.h"
#include "firmware/modules/solve/synthetic_scene.h"
#include "firmware/lib/testing/alloc_counter.h"

namespace mfns::fw {
namespace {

using testing::AngleBetween;
using testing::Scene;

// Big objects live in static storage, as on the flyer.
LostInSpace g_lis;
LisResult g_res;
Scene g_scene;

// Every identity of the result is the truth of its blob.
bool IdentitiesRight(const Scene& s, const MatchSet& m) {
  for (int i = 0; i < m.num_matches; ++i) {
    const Match& x = m.matches[static_cast<std::size_t>(i)];
    if (s.truth_beacon[static_cast<std::size_t>(x.blob)] != x.beacon) return false;
  }
  return true;
}

struct Tally {
  int frames = 0;
  int eligible = 0;     // >= 3 visible beacons
  int eligible5 = 0;    // >= 5 visible beacons
  int fixes = 0;
  int eligible_fixes = 0;
  int eligible5_fixes = 0;
  int wrong = 0;
  int ambiguous = 0;
  int budget = 0;
  int no_hypothesis = 0;
  int complete = 0;
  long hypotheses = 0;
  int max_hypotheses = 0;

  void Print(const char* what) const {
    std::printf("%s: %d frames; >= 3 beacons: %d, fix %d (%.0f%%); >= 5 beacons: %d, fix %d; ambiguous %d "
                "(list complete in %d frames), budget out %d, no pose %d; WRONG %d; P3P solves mean %.0f max %d\n",
                what, frames, eligible, eligible_fixes, eligible > 0 ? 100.0 * eligible_fixes / eligible : 0.0, eligible5,
                eligible5_fixes, ambiguous, complete, budget, no_hypothesis, wrong,
                frames > 0 ? static_cast<double>(hypotheses) / frames : 0.0, max_hypotheses);
  }
};

// Runs lost-in-space on one frame set; a fix must have the true identities and a pose
// consistent with the truth (5 cm, 2 deg: far beyond the noise used).
void IdentifyAndCheck(const Scene& s, const LisOptions& o, Tally* t, const std::uint8_t* steady = nullptr) {
  ++t->frames;
  const int visible = s.NumVisibleBeacons();
  t->eligible += visible >= 3;
  t->eligible5 += visible >= 5;
  const LisStatus st = g_lis.Identify(s.blobs.data(), s.num_blobs, o, &g_res, nullptr, kAllCameras, steady);
  t->hypotheses += g_res.hypotheses;
  t->max_hypotheses = std::max(t->max_hypotheses, g_res.hypotheses);
  t->complete += g_res.complete;
  switch (st) {
    case LisStatus::kFix: {
      ++t->fixes;
      t->eligible_fixes += visible >= 3;
      t->eligible5_fixes += visible >= 5;
      const bool right = IdentitiesRight(s, g_res.matches) && (g_res.pose.r_w_wb - s.pose.r_w_wb).norm() < 0.05 &&
                         AngleBetween(g_res.pose.C_w_b, s.pose.C_w_b) < DegToRad(2.0);
      t->wrong += !right;
      EXPECT_TRUE(right) << "wrong fix: frame " << t->frames << ", " << g_res.matches.num_beacons
                         << " beacons, position error " << (g_res.pose.r_w_wb - s.pose.r_w_wb).norm() << " m";
      EXPECT_GE(g_res.matches.num_beacons, 3);
      EXPECT_TRUE(g_res.solve.has_covariance);
      EXPECT_EQ(g_res.solve.status, SolveStatus::kOk);
      break;
    }
    case LisStatus::kAmbiguous: ++t->ambiguous; break;
    case LisStatus::kBudgetExhausted: ++t->budget; break;
    case LisStatus::kNoHypothesis: ++t->no_hypothesis; break;
    default: break;
  }
  // A complete list always holds the true pose when >= 3 beacons are in view.
  if (g_res.complete && visible >= 3 && (st == LisStatus::kAmbiguous || st == LisStatus::kFix)) {
    bool found = false;
    for (int i = 0; i < g_res.num_consistent && !found; ++i) {
      const BodyPose& p = g_res.consistent_poses[static_cast<std::size_t>(i)];
      found = (p.r_w_wb - s.pose.r_w_wb).norm() < 0.05 && AngleBetween(p.C_w_b, s.pose.C_w_b) < DegToRad(2.0);
    }
    EXPECT_TRUE(found) << "frame " << t->frames << ": the true pose is missing from a complete list";
  }
}

// Lost-in-space reset on a random station cylinder of `beacons` facing beacons; the rig lives
// in static storage (the search keeps a pointer to it). Null when the reset fails.
const Rig* ResetOnCylinder(int beacons, std::mt19937_64* rng) {
  static Rig rig;
  rig = testing::RandomCylinderRig(beacons, true, rng);
  return g_lis.Reset(rig) ? &rig : nullptr;
}

// The tracker's budget of one frame set (TrackOptions::lis_budget_per_frame).
LisOptions TrackerBudget() {
  LisOptions o;
  o.max_hypotheses = 2500;
  return o;
}

// The paper rig's yaw sweep (body at the origin, 1 deg steps), 0.2 px centroid noise, with 0-3
// spurious blobs as bright as beacons anywhere in any image.
TEST(LostInSpaceTest, PaperYawSweepNeverWrong) {
  const Rig rig = PaperRig();
  ASSERT_TRUE(g_lis.Reset(rig));
  for (int spurious = 0; spurious <= 3; ++spurious) {
    // (Spurious blobs multiply the hypotheses: fewer frames for them.)
    const int stride = spurious < 2 ? testing::Trials(8, 60) : testing::Trials(16, 120);
    std::mt19937_64 rng(100 + static_cast<std::uint64_t>(spurious));
    Tally t;
    for (int step = spurious; step < 360; step += stride) {
      testing::Observe(rig, testing::YawPose(DegToRad(step)), 0.2, &rng, &g_scene);
      testing::AddSpurious(rig, spurious, &rng, &g_scene);
      IdentifyAndCheck(g_scene, LisOptions{}, &t);
    }
    char what[64];
    std::snprintf(what, sizeof what, "paper yaw sweep, %d spurious", spurious);
    t.Print(what);
    EXPECT_EQ(t.wrong, 0);
  }
}

// Random 6-DOF poses in a 2 x 2 x 2 m module with 10-20 beacons on its walls.
TEST(LostInSpaceTest, RandomPosesAndLayoutsNeverWrong) {
  std::mt19937_64 rng(200);
  std::uniform_int_distribution<int> n_beacons(10, 20);
  LisOptions o;
  o.max_hypotheses = 5000;  // keeps the test fast; a cut search reports kBudgetExhausted
  for (int spurious = 0; spurious <= 3; spurious += 3) {
    Tally t;
    for (int trial = 0; trial < testing::Trials(30, 3); ++trial) {
      static Rig rig;
      rig = testing::RandomBoxRig(n_beacons(rng), &rng);
      ASSERT_TRUE(g_lis.Reset(rig));
      // Poses that see at least 3 beacons (as the requirement is stated for those).
      for (int tries = 0; tries < 50; ++tries) {
        testing::Observe(rig, testing::RandomBoxPose(&rng), 0.2, &rng, &g_scene);
        if (g_scene.NumVisibleBeacons() >= 3) break;
      }
      testing::AddSpurious(rig, spurious, &rng, &g_scene);
      IdentifyAndCheck(g_scene, o, &t);
    }
    char what[64];
    std::snprintf(what, sizeof what, "random module poses, %d spurious", spurious);
    t.Print(what);
    EXPECT_EQ(t.wrong, 0);
  }
}

// With many beacons in view the identification is unique and immediate.
TEST(LostInSpaceTest, FixesWhenManyBeaconsAreInView) {
  Rig rig = PaperRig();
  const BodyPose truth = testing::YawPose(DegToRad(40.0));
  // Two extra beacons in each camera, at 0.6-0.9 m.
  const Eigen::Vector2d spots[] = {{300, 300}, {950, 700}};
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 2; ++j) {
      BlobObs b;
      b.camera = k;
      ASSERT_EQ(Unproject(rig.cameras[static_cast<std::size_t>(k)].intrinsics, spots[j], &b.x_n), UnprojectStatus::kOk);
      const BodyRay ray = RayOfBlob(rig, b);
      rig.beacons_w[static_cast<std::size_t>(rig.num_beacons++)] =
          truth.C_w_b * (ray.o_b + (0.6 + 0.3 * j) * ray.d_b) + truth.r_w_wb;
    }
  }
  ASSERT_TRUE(g_lis.Reset(rig));
  std::mt19937_64 rng(7);
  testing::Observe(rig, truth, 0.2, &rng, &g_scene);
  ASSERT_GE(g_scene.NumVisibleBeacons(), 6);
  for (int spurious = 0; spurious <= 2; ++spurious) {
    if (spurious > 0) testing::AddSpurious(rig, 1, &rng, &g_scene);
    ASSERT_EQ(g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, LisOptions{}, &g_res), LisStatus::kFix)
        << spurious << " spurious";
    EXPECT_TRUE(IdentitiesRight(g_scene, g_res.matches));
    EXPECT_EQ(g_res.matches.num_beacons, g_scene.NumVisibleBeacons());
    EXPECT_LT((g_res.pose.r_w_wb - truth.r_w_wb).norm(), 0.01);
  }
}

// A map symmetric under a 90 degree turn about z, seen from its axis: every identification
// is as good as three others. Lost-in-space must say so, not pick one.
TEST(LostInSpaceTest, SymmetricMapIsAmbiguous) {
  Rig rig = PaperRig();
  rig.num_beacons = 0;
  for (int q = 0; q < 4; ++q) {
    const Eigen::Matrix3d R = R3(q * kPi / 2.0).transpose();
    rig.beacons_w[static_cast<std::size_t>(rig.num_beacons++)] = R * Eigen::Vector3d(0.8, 0.2, 0.1);
    rig.beacons_w[static_cast<std::size_t>(rig.num_beacons++)] = R * Eigen::Vector3d(0.7, -0.3, 0.4);
    rig.beacons_w[static_cast<std::size_t>(rig.num_beacons++)] = R * Eigen::Vector3d(0.9, 0.1, -0.3);
  }
  ASSERT_TRUE(g_lis.Reset(rig));
  std::mt19937_64 rng(8);
  int seen = 0;
  for (int step = 0; step < 360; step += 10) {
    testing::Observe(rig, testing::YawPose(DegToRad(step)), 0.1, &rng, &g_scene);
    if (g_scene.NumVisibleBeacons() < 3) continue;
    ++seen;
    const LisStatus st = g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, LisOptions{}, &g_res);
    EXPECT_NE(st, LisStatus::kFix) << "step " << step;
    if (st == LisStatus::kAmbiguous && g_res.complete) {
      EXPECT_GE(g_res.num_consistent, 4);
    }
  }
  EXPECT_GT(seen, 0);
}

// A regular grid of beacons (a layout a user may well choose) repeats views exactly: a 2 m cube
// with a 4 x 4 grid on each wall looks the same after any of its 24 turns. Seen in the
// acquisition matrix with --jitter 0 (docs/acquisition.md, session 33): thousands of wrong fixes,
// 180 deg off, each from a pose confirmed on one copy of its beacons (the a-contrario test takes
// the other copies for chance). A pose whose beacons the map repeats, the moved pose explaining
// the blobs as well, is not confirmed (LisOptions::repeat_tolerance_m); without the check the
// same views fix on copies.
TEST(LostInSpaceTest, RegularGridViewsAreNeverConfirmedOnACopy) {
  static Rig rig;
  rig = testing::CubeGridRig();
  ASSERT_TRUE(g_lis.Reset(rig));
  LisOptions unchecked;
  unchecked.repeat_tolerance_m = 0.0;
  std::mt19937_64 rng(33);
  int views = 0, fixes = 0, wrong = 0, repeats = 0, wrong_unchecked = 0;
  for (int trial = 0; trial < testing::Trials(40, 12); ++trial) {
    testing::Observe(rig, testing::RandomBoxPose(&rng), 0.1, &rng, &g_scene);
    if (g_scene.NumVisibleBeacons() < 5) continue;
    ++views;
    if (g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, LisOptions{}, &g_res) == LisStatus::kFix) {
      ++fixes;
      wrong += !IdentitiesRight(g_scene, g_res.matches);
    }
    repeats += g_res.repeats;
    if (g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, unchecked, &g_res) == LisStatus::kFix)
      wrong_unchecked += !IdentitiesRight(g_scene, g_res.matches);
  }
  std::printf("regular grid in a cube: %d views of >= 5 beacons, %d fixes (%d wrong), %d poses not confirmed for a "
              "copy; unchecked: %d wrong fixes\n", views, fixes, wrong, repeats, wrong_unchecked);
  ASSERT_GT(views, 0);
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(repeats, 0);
  EXPECT_GT(wrong_unchecked, 0);  // the check is what keeps them out
}

// Under a prior (a followed pose, 5 cm / 3 deg) the copies far from it are no competitors: a
// regular grid's view near the prior is confirmed at once, on its own beacons (a re-
// identification after a short loss), while a prior that admits the copy still refuses it.
TEST(LostInSpaceTest, APriorTellsARegularGridViewFromItsCopies) {
  static Rig rig;
  rig = testing::CubeGridRig();
  ASSERT_TRUE(g_lis.Reset(rig));
  std::mt19937_64 rng(34);
  int views = 0, confirmed = 0, wrong = 0, refused_wide = 0;
  for (int trial = 0; trial < testing::Trials(40, 12); ++trial) {
    testing::Observe(rig, testing::RandomBoxPose(&rng), 0.1, &rng, &g_scene);
    if (g_scene.NumVisibleBeacons() < 5) continue;
    ++views;
    const BodyPose near = g_scene.pose;
    LisPrior prior{&near, 1, 0.05, DegToRad(3.0)};
    const LisStatus st = g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, LisOptions{}, &g_res, &prior);
    EXPECT_EQ(g_res.repeats, 0) << "view " << views;
    confirmed += g_res.confirmed;
    if (st == LisStatus::kFix) wrong += !IdentitiesRight(g_scene, g_res.matches);
    // A prior wide enough for a copy (the whole cube, any attitude) decides nothing.
    prior.max_m = 4.0;
    prior.max_rad = kPi;
    g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, LisOptions{}, &g_res, &prior);
    refused_wide += g_res.repeats > 0;
    EXPECT_FALSE(g_res.confirmed) << "view " << views;
  }
  std::printf("regular grid, prior at the truth: %d views of >= 5 beacons, %d confirmed at once (%d wrong); a prior "
              "admitting the copies refused a copy in %d\n", views, confirmed, wrong, refused_wide);
  ASSERT_GT(views, 0);
  EXPECT_EQ(wrong, 0);
  EXPECT_GE(2 * confirmed, views);
  EXPECT_GE(2 * refused_wide, views);
}

// Why mfns-navd needs ~20 frame sets to acquire from a cold start on the paper sweep (or a start
// pose): in frame sets 1-11 each camera sees one beacon, and ~30 other poses inside the
// workspace explain those three blobs exactly while predicting no other beacon in any image, so
// no
// single-frame method can tell them from the truth. Checked independently of lost-in-space's
// scoring: each pose it lists far from the truth is re-projected here with the camera model.
// (In frame sets 12-21, 1+2+1 beacons, only the truth explains all four blobs; the ~150 other
// poses listed explain three and leave one as a possible reflection. Lost-in-space needs a
// margin of 2 matches over them, and the tracker's acquisition follows them until the motion
// refutes them, at frame set 22.)
TEST(LostInSpaceTest, ColdStartFramesOfThePaperSweepAreGenuinelyAmbiguous) {
  const Rig rig = PaperRig();
  ASSERT_TRUE(g_lis.Reset(rig));
  std::mt19937_64 rng(31);
  for (int yaw_deg = 1; yaw_deg <= 11; yaw_deg += testing::Trials(1, 5)) {
    testing::Observe(rig, testing::YawPose(DegToRad(yaw_deg)), 0.1, &rng, &g_scene);
    const int visible = g_scene.NumVisibleBeacons();
    ASSERT_EQ(visible, 3) << "yaw " << yaw_deg;
    const LisStatus st = g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, LisOptions{}, &g_res);
    EXPECT_EQ(st, LisStatus::kAmbiguous) << "yaw " << yaw_deg;
    EXPECT_TRUE(g_res.complete);
    int impostors = 0;
    for (int i = 0; i < g_res.num_consistent; ++i) {
      const BodyPose& p = g_res.consistent_poses[static_cast<std::size_t>(i)];
      if ((p.r_w_wb - g_scene.pose.r_w_wb).norm() < 0.1 && AngleBetween(p.C_w_b, g_scene.pose.C_w_b) < DegToRad(5.0))
        continue;
      // Every blob has a beacon within 1 px at p, and p puts no other beacon in any image.
      int in_image = 0, explained = 0;
      for (int k = 0; k < rig.num_cameras; ++k) {
        const RigCamera& cam = rig.cameras[static_cast<std::size_t>(k)];
        for (int m = 0; m < rig.num_beacons; ++m) {
          Eigen::Vector2d uv;
          if (ProjectBeacon(cam, p, rig.beacons_w[static_cast<std::size_t>(m)], &uv) != ProjectStatus::kOk ||
              !InImage(cam.intrinsics, uv))
            continue;
          ++in_image;
          for (int b = 0; b < g_scene.num_blobs; ++b) {
            const BlobObs& o = g_scene.blobs[static_cast<std::size_t>(b)];
            explained += o.camera == k && (o.uv_px - uv).norm() < 1.0;
          }
        }
      }
      impostors += in_image == visible && explained == visible;
    }
    std::printf("yaw %d deg: %d consistent poses, %d of them far from the truth and explaining the blobs exactly\n",
                yaw_deg, g_res.num_consistent, impostors);
    EXPECT_GE(impostors, 1) << "yaw " << yaw_deg;
  }
}

TEST(LostInSpaceTest, StatusesForFewBlobsAndBadInput) {
  const Rig rig = PaperRig();
  LostInSpace& lis = g_lis;
  LostInSpace fresh;  // never Reset
  EXPECT_EQ(fresh.Identify(nullptr, 0, LisOptions{}, &g_res), LisStatus::kBadInput);
  ASSERT_TRUE(lis.Reset(rig));
  std::mt19937_64 rng(9);
  testing::Observe(rig, testing::YawPose(DegToRad(30.0)), 0.2, &rng, &g_scene);
  ASSERT_GE(g_scene.num_blobs, 3);
  EXPECT_EQ(lis.Identify(g_scene.blobs.data(), 2, LisOptions{}, &g_res), LisStatus::kTooFewBlobs);
  Scene bad = g_scene;
  bad.blobs[1].camera = 7;
  EXPECT_EQ(lis.Identify(bad.blobs.data(), bad.num_blobs, LisOptions{}, &g_res), LisStatus::kBadInput);
  bad = g_scene;
  bad.blobs[0].x_n.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(lis.Identify(bad.blobs.data(), bad.num_blobs, LisOptions{}, &g_res), LisStatus::kBadInput);
  LisOptions o;
  const char* why = nullptr;
  EXPECT_TRUE(o.IsValid(&why));
  o.max_hypotheses = limits::kMaxLisHypotheses + 1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_STREQ(why, "max_hypotheses");
  EXPECT_EQ(lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res), LisStatus::kBadInput);
  o = {};
  o.min_score_margin = 0.0;
  EXPECT_FALSE(o.IsValid(&why));
  o = {};
  o.solve.sigma_px = -1.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_STREQ(why, "sigma_px");
  Rig broken = rig;
  broken.cameras[0].C_k_b(0, 0) = 3.0;
  EXPECT_FALSE(fresh.Reset(broken));
  // A tiny budget is reported, never turned into a guess.
  o = {};
  o.max_hypotheses = 5;
  const LisStatus st = lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res);
  EXPECT_TRUE(st == LisStatus::kBudgetExhausted || st == LisStatus::kAmbiguous) << ToString(st);
  // (a cross-camera hypothesis costs cross_camera_work units)
  EXPECT_GE(g_res.work, 5);
  EXPECT_LE(g_res.hypotheses, 5);
  EXPECT_GE(g_res.hypotheses * o.cross_camera_work, 5);
  EXPECT_FALSE(g_res.complete);
  o.cross_camera_work = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_STREQ(why, "cross_camera_work");
  for (int i = 0; i < kNumLisStatus; ++i)
    EXPECT_STRNE(ToString(static_cast<LisStatus>(i)), "unknown lost-in-space status");
}

// A prior restricts the search to poses near it; the true pose is found there.
TEST(LostInSpaceTest, PriorKeepsOnlyNearbyPoses) {
  const Rig rig = PaperRig();
  ASSERT_TRUE(g_lis.Reset(rig));
  std::mt19937_64 rng(10);
  testing::Observe(rig, testing::YawPose(DegToRad(100.0)), 0.2, &rng, &g_scene);
  ASSERT_GE(g_scene.NumVisibleBeacons(), 3);
  BodyPose near = testing::YawPose(DegToRad(103.0));
  LisPrior prior;
  prior.poses = &near;
  prior.num_poses = 1;
  prior.max_m = 0.05;
  prior.max_rad = DegToRad(5.0);
  g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, LisOptions{}, &g_res, &prior);
  ASSERT_GE(g_res.num_consistent, 1);
  for (int i = 0; i < g_res.num_consistent; ++i)
    EXPECT_LT(AngleBetween(g_res.consistent_poses[static_cast<std::size_t>(i)].C_w_b, near.C_w_b), DegToRad(5.1));
  EXPECT_LT(AngleBetween(g_res.consistent_poses[0].C_w_b, g_scene.pose.C_w_b), DegToRad(0.5));
}

// Under a prior, a large map's three-beacon poses are scored too (the fourth-blob test is the
// cold search's): with three beacons in view, a lost track is re-identified near its last
// pose. (It was not: every pose of a three-blob frame set failed the fourth-blob test.)
TEST(LostInSpaceTest, PriorFindsThreeBeaconPosesInALargeMap) {
  std::mt19937_64 rng(710);
  static Rig rig;
  rig = testing::RandomCylinderRig(128, true, &rng);
  ASSERT_GE(rig.num_beacons, LisOptions{}.fourth_blob_min_beacons);
  ASSERT_TRUE(g_lis.Reset(rig));
  int cases = 0;
  for (int trial = 0; trial < 5000 && cases < 5; ++trial) {
    testing::Observe(rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
    if (g_scene.NumVisibleBeacons() != 3 || g_scene.num_blobs != 3) continue;
    ++cases;
    BodyPose near = g_scene.pose;
    near.r_w_wb += Eigen::Vector3d(0.02, -0.01, 0.01);
    near.C_w_b = near.C_w_b * ExpSO3(Eigen::Vector3d(0.01, 0.0, -0.01));
    const LisPrior prior{&near, 1, 0.05, 0.05};
    const LisStatus st = g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, LisOptions{}, &g_res, &prior);
    EXPECT_NE(st, LisStatus::kNoHypothesis) << "case " << cases;
    EXPECT_TRUE(g_res.complete);
    bool found = false;
    for (int i = 0; i < g_res.num_consistent; ++i) {
      const BodyPose& q = g_res.consistent_poses[static_cast<std::size_t>(i)];
      // (A three-beacon pose amplifies the centroid noise: measured up to 38 mm, 1.2 deg; the
      // P3P's other roots lie much farther.)
      found = found || ((q.r_w_wb - g_scene.pose.r_w_wb).norm() < 0.06 && AngleBetween(q.C_w_b, g_scene.pose.C_w_b) < DegToRad(2.0));
    }
    EXPECT_TRUE(found) << "case " << cases << ": the true pose is not among " << g_res.num_consistent;
    if (st == LisStatus::kFix) {
      EXPECT_TRUE(IdentitiesRight(g_scene, g_res.matches)) << "case " << cases;
    }
  }
  EXPECT_EQ(cases, 5);
}

// A station module (4.2 m cylinder, 6 m long) with 64 or 256 wall beacons facing inward, random
// 6-DOF poses anywhere inside, 2 spurious blobs per camera: never wrong, and a fix from this
// one frame set alone in a good share of the frame sets with >= 4 beacons (the acquisition
// over several frame sets is the tracker's). Measured with 8000 solves: 50 % at 64 beacons and
// 26 % at 256 (40 poses on the host; 63 % and 28 % before same-camera triples were searched
// first, which reaches the truth sooner over several frame sets: docs/acquisition.md); with the
// fast trials' 24 poses the share varies more between the host and aarch64, whose rounding
// (fused multiply-adds) changes which poses see enough beacons. A search that always answered
// "ambiguous" fails here.
TEST(LostInSpaceTest, StationModuleFixesAnywhereFromNoPrior) {
  struct Case {
    int beacons;
    double min_fix_rate;
  };
  for (const Case c : {Case{64, 0.3}, Case{256, 0.15}}) {
    std::mt19937_64 rng(700 + static_cast<std::uint64_t>(c.beacons));
    static Rig rig;
    rig = testing::RandomCylinderRig(c.beacons, true, &rng);
    ASSERT_TRUE(g_lis.Reset(rig));
    LisOptions o;
    o.max_hypotheses = 8000;
    Tally t;
    int eligible4 = 0, fixes4 = 0;
    for (int trial = 0; trial < testing::Trials(40, 24); ++trial) {
      testing::Observe(rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
      if (g_scene.NumVisibleBeacons() < 4) continue;
      testing::AddSpurious(rig, 6, &rng, &g_scene);
      const int fixes_before = t.fixes;
      IdentifyAndCheck(g_scene, o, &t);
      ++eligible4;
      fixes4 += t.fixes - fixes_before;
    }
    char what[64];
    std::snprintf(what, sizeof what, "cylinder module, %d beacons, 2 spurious per camera", c.beacons);
    t.Print(what);
    EXPECT_EQ(t.wrong, 0);
    EXPECT_GE(fixes4, c.min_fix_rate * eligible4) << fixes4 << " fixes of " << eligible4;
  }
}

// Dense views (issue 13): a 256-beacon cylinder seen with >= 20 beacons, 2 spurious blobs per
// camera, beacon blobs steady (as the tracker marks them), one frame set's budget. The raw P3P
// pose of the truth misses a few far beacons (outside the raw gate); refined first, it is
// confirmed as soon as its triple comes up. Without (raw_matches_per_miss 0) such searches ran out of
// the budget (the matrix's cylinder 256 seed 4: 20 frame sets before its first fix, 0 after).
TEST(LostInSpaceTest, DenseViewsAreConfirmedFromTheirFirstTriples) {
  std::mt19937_64 rng(1301);
  const Rig* cylinder = ResetOnCylinder(256, &rng);
  ASSERT_NE(cylinder, nullptr);
  const Rig& rig = *cylinder;
  LisOptions refined = TrackerBudget(), raw = TrackerBudget();
  raw.raw_matches_per_miss = 0;
  Tally with, without;
  std::array<std::uint8_t, limits::kMaxObservations> marks{};
  for (int views = 0; views < testing::Trials(30, 12);) {
    testing::Observe(rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
    if (g_scene.NumVisibleBeacons() < 20) continue;
    ++views;
    testing::AddSpurious(rig, 6, &rng, &g_scene);
    for (int i = 0; i < g_scene.num_blobs; ++i)
      marks[static_cast<std::size_t>(i)] = g_scene.truth_beacon[static_cast<std::size_t>(i)] >= 0 ? 1 : 0;
    IdentifyAndCheck(g_scene, refined, &with, marks.data());
    IdentifyAndCheck(g_scene, raw, &without, marks.data());
  }
  with.Print("256-beacon cylinder, >= 20 beacons, 2 spurious per camera, 2500 hypotheses, raw poses refined");
  without.Print("the same, only raw poses missing none refined");
  EXPECT_EQ(with.wrong + without.wrong, 0);
  // Measured (30 views): 21 fixes against 14; the others' true triple came later than 2500
  // hypotheses (the tracker goes on over the next frame sets).
  EXPECT_GE(with.eligible5_fixes, 0.6 * with.eligible5);
  EXPECT_GE(with.eligible5_fixes, without.eligible5_fixes + with.eligible5 / 6);
}

// Wide cameras (f = 760 px, k1 = -0.27: ~100 deg across the diagonal) see many beacons at large
// angles to each other, where the co-visibility table prunes little: a same-camera triple's
// full depth range then holds ~20 000 beacon triples, and the truth at 1.5-2 m lies beyond one
// near range of 1 m (docs/acquisition.md, session 32: a wide two-camera rig in a 64-beacon box
// went 83 frame sets without a fix with 4-8 beacons in one camera). Nested near ranges
// (LisOptions::near_bands: 1 m, then 2 m) reach it within one search. Random 64-beacon
// cylinders, views with >= 5 beacons, 2 spurious blobs per camera, one cold search of 20 000
// hypotheses each way.
TEST(LostInSpaceTest, NestedDepthRangesFindWideCameraViews) {
  std::mt19937_64 rng(1701);
  static Rig rig;
  rig = testing::RandomCylinderRig(64, true, &rng);
  for (int k = 0; k < rig.num_cameras; ++k) {
    CameraIntrinsics& in = rig.cameras[static_cast<std::size_t>(k)].intrinsics;
    in.alpha_x = in.alpha_y = 760.0;
    in.skew = 0.0;
    in.u0 = 0.5 * in.width;
    in.v0 = 0.5 * in.height;
    in.kc = {-0.27, 0.08, 0.0, 0.0, 0.0};
  }
  ASSERT_TRUE(g_lis.Reset(rig));
  LisOptions nested, one;
  one.near_bands = 1;
  ASSERT_EQ(nested.near_bands, 2);
  Tally with, without;
  for (int views = 0; views < testing::Trials(40, 16);) {
    testing::Observe(rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
    if (g_scene.NumVisibleBeacons() < 5) continue;
    ++views;
    testing::AddSpurious(rig, 6, &rng, &g_scene);
    IdentifyAndCheck(g_scene, nested, &with);
    IdentifyAndCheck(g_scene, one, &without);
  }
  with.Print("wide cameras, 64-beacon cylinder, >= 5 beacons, near ranges 1 and 2 m");
  without.Print("the same, one near range of 1 m");
  EXPECT_EQ(with.wrong + without.wrong, 0);
  // Measured: 38 of 40 fixed against 28, 4 945 solves a view against 8 667 (fast mode: 15 of
  // 16 against 9).
  EXPECT_GE(with.eligible5_fixes, without.eligible5_fixes + with.eligible5 / 8);
  EXPECT_GE(with.eligible5_fixes * 10, with.eligible5 * 8);
  EXPECT_LT(with.hypotheses, without.hypotheses);
}

// A beacon moved since the survey (issue 16): its blob lies 6-12 px from where the map puts
// it, beyond the 4 px tight re-match. The true pose missed it, and max_missing 0 refuted every
// pose (free-flight, 5 mm: no fix in 8-9-beacon views). One such near miss is excused on a pose
// of near_miss_min_beacons (5) beacons or more; the fix must still be the truth, and must not
// take the moved beacon's blob.
TEST(LostInSpaceTest, AMovedBeaconIsANearMissNotARefutation) {
  std::mt19937_64 rng(1601);
  const Rig* cylinder = ResetOnCylinder(64, &rng);
  ASSERT_NE(cylinder, nullptr);
  const Rig& rig = *cylinder;
  LisOptions near;
  near.max_hypotheses = 8000;
  LisOptions strict = near;
  strict.near_miss_min_beacons = 0;
  Tally with, without;
  std::uniform_real_distribution<double> shift_px(6.0, 12.0), angle(0.0, 2.0 * kPi);
  for (int views = 0; views < testing::Trials(40, 16);) {
    testing::Observe(rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
    if (g_scene.NumVisibleBeacons() < 6) continue;
    ++views;
    testing::AddSpurious(rig, 6, &rng, &g_scene);
    int moved = -1;  // a beacon's blob (the scene lists them before the spurious ones)
    while (moved < 0 || g_scene.truth_beacon[static_cast<std::size_t>(moved)] < 0)
      moved = static_cast<int>(rng() % static_cast<std::uint64_t>(g_scene.num_blobs));
    BlobObs& b = g_scene.blobs[static_cast<std::size_t>(moved)];
    const double a = angle(rng);
    b.uv_px += shift_px(rng) * Eigen::Vector2d(std::cos(a), std::sin(a));
    ASSERT_EQ(Unproject(rig.cameras[static_cast<std::size_t>(b.camera)].intrinsics, b.uv_px, &b.x_n),
              UnprojectStatus::kOk);
    IdentifyAndCheck(g_scene, near, &with);
    if (g_res.status == LisStatus::kFix) {
      EXPECT_LT(g_res.matches.BeaconOfBlob(moved), 0) << "the moved blob was used";
    }
    IdentifyAndCheck(g_scene, strict, &without);
  }
  with.Print("64-beacon cylinder, >= 6 beacons, one moved 6-12 px, 2 spurious per camera, near misses excused");
  without.Print("the same, no near miss excused");
  EXPECT_EQ(with.wrong + without.wrong, 0);
  // Measured: 16 of 40 against 2 (64-beacon views fix at ~0.3-0.4 in 8000 hypotheses).
  EXPECT_GE(with.fixes, 0.3 * with.frames);
  EXPECT_GE(with.fixes, without.fixes + with.frames / 4);
}

// Steady blobs (blob_tracks.h) searched first: with the beacons' blobs marked steady (as the
// tracker's blob tracks mark them after three frame sets) and 2 spurious blobs per camera in a
// 128-beacon cylinder, a budget of 2500 hypotheses (the tracker's per frame set) fixes more
// views, never wrongly; marks on spurious blobs instead (a steady reflection) cost fixes but
// never give a wrong one.
TEST(LostInSpaceTest, SteadyBlobsAreSearchedFirst) {
  std::mt19937_64 rng(901);
  const Rig* cylinder = ResetOnCylinder(128, &rng);
  ASSERT_NE(cylinder, nullptr);
  const Rig& rig = *cylinder;
  const LisOptions o = TrackerBudget();
  Tally plain, marked, misled;
  std::array<std::uint8_t, limits::kMaxObservations> beacon_marks{}, clutter_marks{};
  for (int trial = 0; trial < testing::Trials(40, 24); ++trial) {
    testing::Observe(rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
    if (g_scene.NumVisibleBeacons() < 5) continue;
    testing::AddSpurious(rig, 6, &rng, &g_scene);
    for (int i = 0; i < g_scene.num_blobs; ++i) {
      const bool beacon = g_scene.truth_beacon[static_cast<std::size_t>(i)] >= 0;
      beacon_marks[static_cast<std::size_t>(i)] = beacon ? 1 : 0;
      clutter_marks[static_cast<std::size_t>(i)] = beacon ? 0 : 1;
    }
    IdentifyAndCheck(g_scene, o, &plain);
    IdentifyAndCheck(g_scene, o, &marked, beacon_marks.data());
    IdentifyAndCheck(g_scene, o, &misled, clutter_marks.data());
  }
  plain.Print("128-beacon cylinder, 2 spurious per camera, 2500 hypotheses, no marks");
  marked.Print("the same, beacon blobs marked steady");
  misled.Print("the same, spurious blobs marked steady");
  EXPECT_EQ(plain.wrong + marked.wrong + misled.wrong, 0);
  ASSERT_GE(marked.eligible5, 10);
  // Measured (40 views): 20 fixes unmarked, 30 marked, of 37 views with >= 5 beacons.
  EXPECT_GE(marked.eligible5_fixes, 0.65 * marked.eligible5);
  EXPECT_GE(marked.eligible5_fixes, plain.eligible5_fixes + marked.eligible5 / 6);
}

// A complete search tries the same hypotheses and decides the same whatever blobs are marked
// steady (only the order of the search changes; which of two nearly equal poses is kept as
// the distinct one may change, so the lists' lengths may differ by one or two): the paper
// sweep's frame sets with a spurious blob.
TEST(LostInSpaceTest, SteadyMarksLeaveACompleteSearchAlone) {
  const Rig rig = PaperRig();
  std::mt19937_64 rng(17);
  ASSERT_TRUE(g_lis.Reset(rig));
  LisOptions o;
  o.confirm_beacons = 0;  // no early end: the whole search
  std::array<std::uint8_t, limits::kMaxObservations> marks{};
  static LisResult unmarked;
  int compared = 0;
  for (int step = 0; step < 360; step += testing::Trials(10, 40)) {
    testing::Observe(rig, testing::YawPose(DegToRad(step)), 0.2, &rng, &g_scene);
    testing::AddSpurious(rig, 1, &rng, &g_scene);
    const LisStatus a = g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &unmarked);
    for (int i = 0; i < g_scene.num_blobs; ++i) marks[static_cast<std::size_t>(i)] = (i % 2 == 0) ? 1 : 0;
    const LisStatus b = g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res, nullptr, kAllCameras, marks.data());
    if (!unmarked.complete) continue;
    ++compared;
    EXPECT_EQ(a, b) << "step " << step;
    EXPECT_TRUE(g_res.complete);
    EXPECT_NEAR(unmarked.num_consistent, g_res.num_consistent, 2 + 0.02 * unmarked.num_consistent) << "step " << step;
    EXPECT_EQ(unmarked.hypotheses, g_res.hypotheses) << "step " << step;
    if (a == LisStatus::kFix && b == LisStatus::kFix) {
      EXPECT_LT((unmarked.pose.r_w_wb - g_res.pose.r_w_wb).norm(), 1e-6) << "step " << step;
    }
  }
  EXPECT_GE(compared, 5);
}

// Anchors (LisPrior::anchors: blobs whose beacon the tracker's image tracks tell) near a
// prediction whose bounds grew over a gap (0.3 m, 0.5 rad) in a 128-beacon cylinder with 2
// spurious blobs per camera, three or four beacons in view (no pose confirms itself early: the
// list must be complete): the search holds only the triples with the anchored blobs, so it
// ends within the tracker's 2500 hypotheses where the plain one is cut, and its complete list
// holds the truth. With four anchors of which one is wrong (a track that hopped onto a spurious
// blob), the truth still keeps three and is listed.
// LisResult::cost bounds a search (LisOptions::max_cost: cut, never a fix it did not confirm)
// and one call (Continue's cost_budget: paused), overshooting by at most one hypothesis (its
// P3P roots each scored, reprojected and refined) plus the refinement of the kept poses when it
// ends; a search paused by cost, then continued, ends exactly where an uncut one does.
TEST(LostInSpaceTest, CostCapsTheSearchAndResumesExactly) {
  std::mt19937_64 rng(1717);
  const Rig* cylinder = ResetOnCylinder(256, &rng);
  ASSERT_NE(cylinder, nullptr);
  const Rig& rig = *cylinder;
  const double nb = rig.num_beacons;
  const double per_hypothesis = 2.0 + 4.0 * (1.2e-3 * nb * limits::kMaxLisBlobs + 0.113 * nb + 14.0);
  const double decide = 14.0 * limits::kMaxLisCandidates;
  int cases = 0, paused_calls = 0;
  for (int trial = 0; trial < 2000 && cases < testing::Trials(12, 6); ++trial) {
    testing::Observe(rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
    if (g_scene.NumVisibleBeacons() < 3) continue;
    testing::AddSpurious(rig, 6, &rng, &g_scene);
    ++cases;
    const LisOptions uncut;
    const LisStatus full_status = g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, uncut, &g_res);
    const double full_cost = g_res.cost;
    const int full_hypotheses = g_res.hypotheses;
    const BodyPose full_pose = g_res.pose;
    ASSERT_GT(full_cost, 100.0) << "case " << cases;
    // A cap at half the whole search's cost cuts it there.
    LisOptions capped;
    capped.max_cost = 0.5 * full_cost;
    const LisStatus cut = g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, capped, &g_res);
    EXPECT_NE(cut, LisStatus::kFix) << "case " << cases;
    EXPECT_FALSE(g_res.complete) << "case " << cases;
    EXPECT_LT(g_res.hypotheses, full_hypotheses) << "case " << cases;
    EXPECT_GE(g_res.cost, capped.max_cost) << "case " << cases;
    EXPECT_LE(g_res.cost, capped.max_cost + per_hypothesis + decide) << "case " << cases;
    // Calls of a tenth of the cost each: every paused call within its budget plus one
    // hypothesis, and the same end as the uncut search.
    const double slice = 0.1 * full_cost;
    LisStatus st = g_lis.Begin(g_scene.blobs.data(), g_scene.num_blobs, uncut, &g_res);
    for (int call = 0; call < 40 && st == LisStatus::kSearching; ++call) {
      const double before = g_res.cost;
      st = g_lis.Continue(limits::kMaxLisHypotheses, &g_res, slice);
      if (st != LisStatus::kSearching) break;
      ++paused_calls;
      EXPECT_GE(g_res.cost - before, slice) << "case " << cases;
      EXPECT_LE(g_res.cost - before, slice + per_hypothesis) << "case " << cases;
    }
    EXPECT_EQ(st, full_status) << "case " << cases;
    EXPECT_EQ(g_res.hypotheses, full_hypotheses) << "case " << cases;
    EXPECT_NEAR(g_res.cost, full_cost, 1e-6 * full_cost) << "case " << cases;
    if (st == LisStatus::kFix) {
      EXPECT_LT((g_res.pose.r_w_wb - full_pose.r_w_wb).norm(), 1e-9) << "case " << cases;
    }
  }
  ASSERT_GE(cases, testing::Trials(12, 6));
  EXPECT_GE(paused_calls, cases * 5);  // most searches took several calls
}

// Whether a result's consistent poses hold `truth` (within 0.1 m and 3 deg: a three-beacon pose
// amplifies the centroid noise, seen 79 mm, 1.3 deg; other roots lie farther).
bool TruthListed(const LisResult& r, const BodyPose& truth) {
  for (int i = 0; i < r.num_consistent; ++i) {
    const BodyPose& q = r.consistent_poses[static_cast<std::size_t>(i)];
    if ((q.r_w_wb - truth.r_w_wb).norm() < 0.1 && AngleBetween(q.C_w_b, truth.C_w_b) < DegToRad(3.0)) return true;
  }
  return false;
}

TEST(LostInSpaceTest, AnchorsKeepTheSearchSmallAndTheTruth) {
  std::mt19937_64 rng(1301);
  const Rig* cylinder = ResetOnCylinder(128, &rng);
  ASSERT_NE(cylinder, nullptr);
  const Rig& rig = *cylinder;
  const LisOptions o = TrackerBudget();
  int cases = 0, plain_complete = 0, anchored_complete = 0, anchored_listed = 0, wrong_complete = 0, wrong_listed = 0;
  long plain_work = 0, anchored_work = 0;
  for (int trial = 0; trial < 4000 && cases < testing::Trials(30, 12); ++trial) {
    testing::Observe(rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
    const int visible = g_scene.NumVisibleBeacons();
    if (visible < 3 || visible > 4) continue;  // too few to confirm a pose: the list must be complete
    const int beacon_blobs = g_scene.num_blobs;  // Observe's blobs are all beacons
    testing::AddSpurious(rig, 6, &rng, &g_scene);
    ++cases;
    BodyPose near = g_scene.pose;
    near.r_w_wb += Eigen::Vector3d(0.1, -0.1, 0.05);
    near.C_w_b = near.C_w_b * ExpSO3(Eigen::Vector3d(0.15, -0.1, 0.1));
    LisPrior prior{&near, 1, 0.3, 0.5};
    g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res, &prior);
    plain_complete += g_res.complete;
    plain_work += g_res.work;
    // Two true anchors, as after a gap with two beacons in view.
    std::array<LisAnchor, 4> anchors{};
    for (int i = 0; i < 2; ++i) anchors[static_cast<std::size_t>(i)] = LisAnchor{i, g_scene.truth_beacon[static_cast<std::size_t>(i)]};
    prior.anchors = anchors.data();
    prior.num_anchors = 2;
    g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res, &prior);
    anchored_complete += g_res.complete;
    anchored_work += g_res.work;
    if (g_res.complete) anchored_listed += TruthListed(g_res, g_scene.pose);
    if (g_res.status == LisStatus::kFix) {
      EXPECT_TRUE(IdentitiesRight(g_scene, g_res.matches)) << "case " << cases;
    }
    // Three true anchors and a spurious blob anchored as a beacon that no blob shows.
    for (int i = 0; i < 3; ++i) anchors[static_cast<std::size_t>(i)] = LisAnchor{i, g_scene.truth_beacon[static_cast<std::size_t>(i)]};
    int absent = 0;
    while (std::any_of(g_scene.truth_beacon.begin(), g_scene.truth_beacon.begin() + beacon_blobs,
                       [&](int b) { return b == absent; }))
      ++absent;
    anchors[3] = LisAnchor{beacon_blobs, absent};
    prior.num_anchors = 4;
    g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res, &prior);
    wrong_complete += g_res.complete;
    if (g_res.complete) wrong_listed += TruthListed(g_res, g_scene.pose);
  }
  std::printf("%d views: complete plain %d (work %.0f), anchored %d (work %.0f, truth listed %d), one anchor wrong %d "
              "(truth listed %d)\n",
              cases, plain_complete, static_cast<double>(plain_work) / cases, anchored_complete,
              static_cast<double>(anchored_work) / cases, anchored_listed, wrong_complete, wrong_listed);
  ASSERT_GE(cases, testing::Trials(30, 12));
  EXPECT_EQ(anchored_listed, anchored_complete);
  EXPECT_EQ(wrong_listed, wrong_complete);
  EXPECT_GE(anchored_complete, 0.9 * cases);
  EXPECT_GE(wrong_complete, 0.9 * cases);
  EXPECT_LE(plain_complete, cases / 2);
  EXPECT_LT(anchored_work * 5, plain_work);
}

// The P3P root of the first three blobs' true beacons nearest the true pose: with three beacons
// the centroid noise moves the exact pose (seen 56 mm, 3.2 deg in a 2+1 view), and that root is
// what a list holds for the truth.
BodyPose TrueTripleRoot(const Rig& rig, const Scene& s) {
  P3pRayTriple tri;
  tri.Set({RayOfBlob(rig, s.blobs[0]), RayOfBlob(rig, s.blobs[1]), RayOfBlob(rig, s.blobs[2])}, P3pOptions{0.1, 20.0, 64});
  std::array<BodyPose, limits::kMaxP3pSolutions> roots;
  const auto beacon = [&](int i) { return rig.beacons_w[static_cast<std::size_t>(s.truth_beacon[static_cast<std::size_t>(i)])]; };
  const int n = tri.Solve({beacon(0), beacon(1), beacon(2)}, &roots);
  BodyPose nearest = s.pose;
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < n; ++k) {
    const BodyPose& r = roots[static_cast<std::size_t>(k)];
    const double d = (r.r_w_wb - s.pose.r_w_wb).norm() + AngleBetween(r.C_w_b, s.pose.C_w_b);
    if (d < best) {
      best = d;
      nearest = r;
    }
  }
  return nearest;
}

// Whether the result lists the truth: the true pose or that root.
bool TruthOrItsRootListed(const LisResult& r, const Rig& rig, const Scene& s) {
  return TruthListed(r, s.pose) || TruthListed(r, TrueTripleRoot(rig, s));
}

// A "2+1" view (two beacons in one camera, one in another) of a 64-beacon station cylinder
// (with and without facing data), 2 spurious blobs per camera, no pose prior: the cold search
// cannot list the truth (the fourth-blob test drops every three-beacon pose, and a cross-camera
// blob triple alone holds 10^4-10^5 beacon triples: docs/acquisition.md, session 21). With two
// blobs anchored to their beacons (two beacons whose image tracks continued through a gap
// from an accepted pose) the search is complete within one frame set's budget and its list
// holds the truth: a triple then holds ~N beacon triples, few enough to reproject every pose
// without the fourth-blob test. (With one anchor the search is still cut: each of the 28
// triples of the anchor and two of the other 8 blobs holds ~N^2.) Random maps and poses;
// measured 20 views: plain complete 0 (truth listed 0, 20 000 units each), anchored complete
// 20 (truth listed 20, 742 units on average, cost at most 2 241).
TEST(LostInSpaceTest, AnAnchorCompletesTwoPlusOneColdSearches) {
  std::mt19937_64 rng(2101);
  LisOptions o;  // the cold search's budget: max_hypotheses units over its frame sets
  int cases = 0, plain_complete = 0, plain_listed = 0, anchored_complete = 0, anchored_listed = 0;
  long plain_work = 0, anchored_work = 0;
  double anchored_cost_max = 0.0;
  const int wanted = testing::Trials(20, 8);
  for (int map = 0; map < 4 && cases < wanted; ++map) {
    static Rig rig;  // (the search keeps a pointer to it)
    rig = testing::RandomCylinderRig(64, map % 2 == 0, &rng);  // with and without facing data
    ASSERT_TRUE(g_lis.Reset(rig));
    for (int trial = 0, here = 0; trial < 20000 && here < (wanted + 3) / 4 && cases < wanted; ++trial) {
      testing::Observe(rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
      if (g_scene.num_blobs != 3 || *std::max_element(g_scene.per_camera.begin(), g_scene.per_camera.end()) != 2)
        continue;
      testing::AddSpurious(rig, 6, &rng, &g_scene);
      ++here;
      ++cases;
      g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res);
      plain_complete += g_res.complete;
      plain_listed += TruthOrItsRootListed(g_res, rig, g_scene);
      plain_work += g_res.work;
      const std::array<LisAnchor, 2> anchors{LisAnchor{0, g_scene.truth_beacon[0]}, LisAnchor{1, g_scene.truth_beacon[1]}};
      // (Blobs 0 and 1: Observe lists a camera's beacons together, so these are the two of one
      // camera or one of each.)
      LisPrior prior;
      prior.anchors = anchors.data();
      prior.num_anchors = 2;
      const LisStatus st = g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res, &prior);
      anchored_complete += g_res.complete;
      anchored_work += g_res.work;
      anchored_cost_max = std::max(anchored_cost_max, g_res.cost);
      if (g_res.complete) {
        const bool listed = TruthOrItsRootListed(g_res, rig, g_scene);
        anchored_listed += listed;
        EXPECT_TRUE(listed) << "view " << cases << ": a complete anchored list without the truth";
      }
      if (st == LisStatus::kFix) {
        EXPECT_TRUE(IdentitiesRight(g_scene, g_res.matches)) << "view " << cases;
      }
    }
  }
  std::printf("%d 2+1 views: plain complete %d (truth listed %d, work %.0f), anchored complete %d (truth listed %d, "
              "work %.0f, cost max %.0f)\n",
              cases, plain_complete, plain_listed, static_cast<double>(plain_work) / std::max(1, cases),
              anchored_complete, anchored_listed, static_cast<double>(anchored_work) / std::max(1, cases),
              anchored_cost_max);
  ASSERT_GE(cases, wanted);
  EXPECT_EQ(plain_listed, 0);
  EXPECT_GE(anchored_complete, 0.8 * cases);
  EXPECT_EQ(anchored_listed, anchored_complete);
  EXPECT_LT(anchored_work * 3, plain_work);
  EXPECT_LE(anchored_cost_max, TrackOptions{}.lis_budget_per_frame);  // one frame set's
}

// A beacon whose facing is unknown (InferFacing could not tell: a beam of pi, the placeholder
// normal +z) bounds no region of the co-visibility table. One such beacon once cut the table's
// sampled region to the slice above its height: beacon pairs seen only from below it were
// refused, and near-prior searches from there listed no pose at all (seen in a 64-beacon box
// without facing data: four beacons in view, lost for 50 frame sets).
TEST(LostInSpaceTest, ABeaconOfUnknownFacingBoundsNoRegion) {
  std::mt19937_64 rng(1302);
  static Rig rig;
  rig = testing::RandomCylinderRig(64, true, &rng);
  rig.beacons_w[0] = Eigen::Vector3d(-3.0, 0.0, 0.3);  // on an end cap, above the axis
  rig.beacon_normal_w[0] = Eigen::Vector3d::UnitZ();
  rig.beacon_half_angle[0] = kPi;
  ASSERT_TRUE(g_lis.Reset(rig));
  int cases = 0, listed = 0;
  for (int trial = 0; trial < 20000 && cases < testing::Trials(20, 10); ++trial) {
    BodyPose pose = testing::RandomCylinderPose(&rng);
    if (pose.r_w_wb.z() > -0.8) continue;  // well below the beacon's height
    testing::Observe(rig, pose, 0.1, &rng, &g_scene);
    // Three beacons in one camera: their pairs are the ones the table prunes.
    std::array<int, limits::kMaxCameras> per_camera{};
    for (int b = 0; b < g_scene.num_blobs; ++b) ++per_camera[static_cast<std::size_t>(g_scene.blobs[static_cast<std::size_t>(b)].camera)];
    if (*std::max_element(per_camera.begin(), per_camera.end()) < 3) continue;
    ++cases;
    BodyPose near = pose;
    near.r_w_wb += Eigen::Vector3d(0.01, 0.01, -0.01);
    const LisPrior prior{&near, 1, 0.05, 0.05};
    g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, LisOptions{}, &g_res, &prior);
    for (int i = 0; i < g_res.num_consistent; ++i) {
      const BodyPose& q = g_res.consistent_poses[static_cast<std::size_t>(i)];
      if ((q.r_w_wb - pose.r_w_wb).norm() < 0.06 && AngleBetween(q.C_w_b, pose.C_w_b) < DegToRad(2.0)) {
        ++listed;
        break;
      }
    }
  }
  ASSERT_GE(cases, testing::Trials(20, 10));
  EXPECT_EQ(listed, cases);
}

// The a-contrario bound against the binomial tail summed directly.
TEST(LostInSpaceTest, FalseAlarmsIsTheBinomialTail) {
  const double p = 4.0 * kPi * 2.0 * 2.0 / (1280.0 * 1024.0);
  const int n = 12, k = 3;  // 15 predicted, 6 matched
  double tail = 0.0;
  for (int x = k; x <= n; ++x) tail += std::tgamma(n + 1.0) / (std::tgamma(x + 1.0) * std::tgamma(n - x + 1.0)) *
                                       std::pow(p, x) * std::pow(1.0 - p, n - x);
  EXPECT_NEAR(FalseAlarms(6, 15, 4.0, 2.0, 1280.0 * 1024.0, 1000.0), 1000.0 * tail, 1e-9 * 1000.0 * tail);
  EXPECT_EQ(FalseAlarms(3, 15, 4.0, 2.0, 1280.0 * 1024.0, 1000.0), 1000.0);  // nothing beyond the hypothesis
  // More matches, fewer false alarms; denser images, more.
  EXPECT_LT(FalseAlarms(7, 15, 4.0, 2.0, 1280.0 * 1024.0, 1000.0), FalseAlarms(6, 15, 4.0, 2.0, 1280.0 * 1024.0, 1000.0));
  EXPECT_GT(FalseAlarms(6, 15, 40.0, 2.0, 1280.0 * 1024.0, 1000.0), FalseAlarms(6, 15, 4.0, 2.0, 1280.0 * 1024.0, 1000.0));
}

TEST(LostInSpaceTest, NoHeapAllocation) {
  const Rig rig = PaperRig();
  std::mt19937_64 rng(11);
  const std::uint64_t before = testing::AllocationCount();
  ASSERT_TRUE(g_lis.Reset(rig));
  int fixes = 0;
  for (int step = 0; step < 360; step += testing::Trials(12, 120)) {
    testing::Observe(rig, testing::YawPose(DegToRad(step)), 0.2, &rng, &g_scene);
    testing::AddSpurious(rig, 1, &rng, &g_scene);
    fixes += g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, LisOptions{}, &g_res) == LisStatus::kFix;
  }
  EXPECT_EQ(testing::AllocationCount() - before, 0u);
  (void)fixes;
}

// A search whose list overflowed (a pose that may be consistent dropped) can no longer give a
// complete list; Stop ends it there, with what it found (the tracker stops a small map's search
// at the frame set's budget once this happens: Tracker::RunSmallMapLis). A 16-beacon station
// cylinder seen with one or two beacons among 8 spurious blobs: searched in steps, the list
// overflows long before the search ends; stopped then, the result is incomplete and holds no
// more poses than the list's capacity; searched to the end, it is just as incomplete.
TEST(LostInSpaceTest, AnOverflowedSearchCanBeStoppedThere) {
  std::mt19937_64 rng(915);
  const Rig* rig = ResetOnCylinder(16, &rng);
  ASSERT_NE(rig, nullptr);
  int overflowed = 0;
  for (int trial = 0; trial < 20 && overflowed < 3; ++trial) {
    testing::Observe(*rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
    testing::AddSpurious(*rig, 8, &rng, &g_scene);
    const LisOptions o;
    LisStatus s = g_lis.Begin(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res);
    while (s == LisStatus::kSearching && !g_lis.overflowed()) s = g_lis.Continue(o.max_hypotheses, &g_res, 200.0);
    if (s != LisStatus::kSearching) continue;  // ended before its list overflowed
    ++overflowed;
    const double stopped_at = g_res.cost;
    s = g_lis.Stop(&g_res);
    EXPECT_FALSE(g_lis.searching());
    EXPECT_NE(s, LisStatus::kSearching);
    EXPECT_FALSE(g_res.complete);
    EXPECT_LE(g_res.num_consistent, limits::kMaxLisCandidates);
    EXPECT_EQ(g_lis.Stop(&g_res), s);  // nothing in progress: the same status
    const LisStatus full = g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res);
    EXPECT_TRUE(g_lis.overflowed());
    EXPECT_FALSE(g_res.complete);
    std::printf("trial %d: overflowed after cost %.0f, stopped: %s; searched to the end: %s, cost %.0f\n", trial,
                stopped_at, ToString(s), ToString(full), g_res.cost);
  }
  EXPECT_GE(overflowed, 3);
}

// Many prior poses (the acquisition follows up to 256) cost what each one's own view does:
// a search item's beacon triples are those one prior pose allows for all three blobs. The
// union of their allowed beacons is most of a small map, and searching it cost as much as a
// cold search (session 35). The list is the same: exactly the union of the lists of searches
// near each prior pose alone, with the truth among them.
TEST(LostInSpaceTest, ManyPriorPosesCostWhatTheirOwnViewsDo) {
  std::mt19937_64 rng(931);
  const Rig* rig = ResetOnCylinder(16, &rng);
  ASSERT_NE(rig, nullptr);
  static std::array<BodyPose, 48> poses;
  static LisResult one;
  const LisOptions o;
  const auto same = [&](const BodyPose& a, const BodyPose& b) {
    return (a.r_w_wb - b.r_w_wb).norm() <= o.same_pose_m && AngleBetween(a.C_w_b, b.C_w_b) <= o.same_pose_rad;
  };
  const auto listed = [&](const LisResult& r, const BodyPose& p) {
    for (int i = 0; i < r.num_consistent; ++i)
      if (same(r.consistent_poses[static_cast<std::size_t>(i)], p)) return true;
    return false;
  };
  int cases = 0, incomplete = 0;
  for (int trial = 0; trial < 400 && cases < testing::Trials(3, 1); ++trial) {
    testing::Observe(*rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
    if (g_scene.NumVisibleBeacons() < 3) continue;
    testing::AddSpurious(*rig, 6, &rng, &g_scene);  // two per camera
    ++cases;
    // The poses an acquisition follows: the truth and those a cold search lists (each a little
    // off, as a followed pose is a frame set later), then poses anywhere in the module.
    g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res);
    const double cold = g_res.cost;
    poses[0] = g_scene.pose;
    for (std::size_t i = 1; i < poses.size(); ++i)
      poses[i] = static_cast<int>(i) <= g_res.num_consistent ? g_res.consistent_poses[i - 1] : testing::RandomCylinderPose(&rng);
    for (BodyPose& p : poses) p.r_w_wb += Eigen::Vector3d(0.01, -0.01, 0.005);
    const LisPrior prior{poses.data(), static_cast<int>(poses.size()), 0.1, 0.1};
    g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res, &prior);
    const int num_listed = g_res.num_consistent;
    if (!g_res.complete) {  // (overflowed: nothing to compare; counted below)
      ++incomplete;
      --cases;
      continue;
    }
    EXPECT_TRUE(listed(g_res, g_scene.pose)) << "case " << cases << ": the truth is not listed";
    double alone_cost = 0.0;
    int alone_listed = 0;
    for (const BodyPose& p : poses) {
      const LisPrior just{&p, 1, 0.1, 0.1};
      g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &one, &just);
      EXPECT_TRUE(one.complete);
      alone_cost += one.cost;
      alone_listed += one.num_consistent;
      for (int i = 0; i < one.num_consistent; ++i)
        EXPECT_TRUE(listed(g_res, one.consistent_poses[static_cast<std::size_t>(i)])) << "case " << cases;
    }
    for (int i = 0; i < g_res.num_consistent; ++i) {
      bool found = false;
      for (const BodyPose& p : poses) {
        const LisPrior just{&p, 1, 0.1, 0.1};
        g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &one, &just);
        found = found || listed(one, g_res.consistent_poses[static_cast<std::size_t>(i)]);
      }
      EXPECT_TRUE(found) << "case " << cases << ": pose " << i << " is near no prior pose's own list";
    }
    const double together = g_res.cost;
    std::printf("case %d: %d blobs, %d poses listed (%d alone); cost together %.0f, alone summed %.0f, cold %.0f\n",
                cases, g_scene.num_blobs, num_listed, alone_listed, together, alone_cost, cold);
    EXPECT_LE(together, alone_cost) << "case " << cases;
    // More poses than the search keeps sets for: the union of their beacons (the search before
    // session 36, as dear as a cold one); whatever it lists lies near a prior pose.
    static std::array<BodyPose, limits::kMaxLisCandidates + 1> many;
    std::mt19937_64 more(static_cast<std::uint64_t>(cases));
    std::copy(poses.begin(), poses.end(), many.begin());
    for (std::size_t i = poses.size(); i < many.size(); ++i) many[i] = testing::RandomCylinderPose(&more);
    const LisPrior beyond{many.data(), static_cast<int>(many.size()), 0.1, 0.1};
    g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &one, &beyond);
    for (int i = 0; i < one.num_consistent; ++i) {
      const BodyPose& q = one.consistent_poses[static_cast<std::size_t>(i)];
      EXPECT_TRUE(std::any_of(many.begin(), many.end(), [&](const BodyPose& p) {
        return (q.r_w_wb - p.r_w_wb).norm() <= 0.1 && AngleBetween(q.C_w_b, p.C_w_b) <= 0.1;
      })) << "case " << cases << ": a pose listed under 257 poses is near none of them";
    }
  }
  EXPECT_EQ(cases, testing::Trials(3, 1));
  EXPECT_LE(incomplete, cases);
}

// MayComplete tells early which searches cannot end with a complete list (their beacon triples
// exceed max_hypotheses, counted exactly; or the list overflowed), so that a small map's search
// past the frame set's budget stops there (Tracker::RunSmallMapLis; seen: 16-24-beacon stations
// spending 20 000 units, ~20 ms, on searches that ended incomplete). Never wrong: a search it
// has said no to does not complete; and most of the work of those that do not comes after it.
TEST(LostInSpaceTest, ASearchThatCannotCompleteIsKnownEarly) {
  std::mt19937_64 rng(917);
  const Rig* rig = ResetOnCylinder(16, &rng);
  ASSERT_NE(rig, nullptr);
  int complete = 0, incomplete = 0, told = 0;
  double cost_after_told = 0.0, cost_incomplete = 0.0;
  const LisOptions o;
  for (int trial = 0; trial < testing::Trials(40, 12); ++trial) {
    testing::Observe(*rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
    testing::AddSpurious(*rig, 1 + trial % 8, &rng, &g_scene);
    // Without a prior, then near one pose with wide bounds (a seed's prediction after a gap).
    for (const bool seeded : {false, true}) {
      const LisPrior prior{&g_scene.pose, 1, 0.3, 0.5};
      LisStatus s = g_lis.Begin(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res, seeded ? &prior : nullptr);
      double told_at = -1.0;
      while (s == LisStatus::kSearching) {
        if (told_at < 0.0 && !g_lis.MayComplete(&g_res)) told_at = g_res.cost;
        s = g_lis.Continue(o.max_hypotheses, &g_res, 500.0);
      }
      if (g_res.complete) {
        ++complete;
        EXPECT_LT(told_at, 0.0) << "trial " << trial << (seeded ? ", seeded" : "") << ": told it could not complete";
      } else if (!g_res.confirmed) {
        ++incomplete;
        cost_incomplete += g_res.cost;
        if (told_at >= 0.0) {
          ++told;
          cost_after_told += g_res.cost - told_at;
        }
      }
    }
  }
  std::printf("%d searches complete, %d incomplete (cost %.0f), %d of them told early (%.0f of their cost after)\n",
              complete, incomplete, cost_incomplete, told, cost_after_told);
  EXPECT_GT(complete, 0);
  EXPECT_GT(incomplete, 0);
  EXPECT_GT(told, 0);
  // (The others ended early anyway: too few blobs, few triples.)
  EXPECT_GE(cost_after_told, 0.8 * cost_incomplete);
}

// MayComplete's count of a search's beacon triples is exact: a search of exactly that many
// hypotheses may complete, one fewer may not. (It subtracted a third beacon equal to the pair's
// own whenever either pair held it, not both: in a view of rays seen at similar angles - one
// camera's - every feasible pair did, and the count fell by up to two per pair, below zero for a
// same-camera triple of a 64-beacon map: searches that could not complete were let run on.)
// Reference: the hypotheses a search without early ends tries (one work unit each).
TEST(LostInSpaceTest, MayCompleteCountsTheBeaconTriplesExactly) {
  std::mt19937_64 rng(931);
  const Rig* rig = ResetOnCylinder(16, &rng);
  ASSERT_NE(rig, nullptr);
  LisOptions all;
  all.confirm_beacons = 0;  // no early end: every feasible triple is tried
  all.cross_camera_work = 1;
  all.max_hypotheses = limits::kMaxLisHypotheses;
  int checked = 0;
  const int wanted = testing::Trials(16, 5);
  for (int trial = 0; checked < wanted && trial < 400; ++trial) {
    testing::Observe(*rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
    testing::AddSpurious(*rig, trial % 5, &rng, &g_scene);
    if (g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, all, &g_res) == LisStatus::kTooFewBlobs) continue;
    if (!g_res.search_complete || g_res.hypotheses < 2) continue;
    ++checked;
    const int tried = g_res.hypotheses;
    for (const int cap : {tried, tried - 1}) {
      LisOptions o = all;
      o.max_hypotheses = cap;
      ASSERT_EQ(g_lis.Begin(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res), LisStatus::kSearching);
      EXPECT_EQ(g_lis.MayComplete(&g_res), cap == tried)
          << "trial " << trial << ": " << tried << " hypotheses tried, cap " << cap;
    }
  }
  // (Views skipped: fewer than three blobs, or more triples than the limit allows - a matter of
  // rounding which: 3 of the first 10 views were checked on aarch64, 5 on x86-64.)
  EXPECT_EQ(checked, wanted);
}

// A steady list (LisOptions::steady_list) holds every pose that explains four steady blobs
// with four distinct beacons:
// reference, the complete list of a search of every triple (a 28-beacon map, where one
// often completes), re-matched to find its poses on four steady blobs. Steady: the true beacons'
// blobs, and in every third view one spurious blob too (a reflection that moves with the scene).
// The steady list must hold each such pose and the truth (four true beacons in view), and cost
// less than the complete search.
TEST(LostInSpaceTest, ASteadyListHoldsEveryPoseOnFourSteadyBlobs) {
  std::mt19937_64 rng(947);
  static const Rig paper = PaperRig();
  const Rig* rig = &paper;
  ASSERT_TRUE(g_lis.Reset(paper));
  BeaconMatcher matcher;
  matcher.Reset(*rig);
  LisOptions all;
  all.confirm_beacons = 0;  // every triple, every pose on a fourth blob listed
  all.max_hypotheses = limits::kMaxLisHypotheses;
  all.fourth_blob_min_beacons = 3;  // (three-beacon poses would overflow the list)
  LisOptions steady_list = all;
  steady_list.steady_list = true;
  int checked = 0, on_four = 0;
  double cost_all = 0.0, cost_steady = 0.0;
  for (int trial = 0; trial < 400 && checked < testing::Trials(24, 8); ++trial) {
    testing::Observe(*rig, testing::YawPose(std::uniform_real_distribution<double>(0.0, 2.0 * kPi)(rng)), 0.2, &rng,
                     &g_scene);
    if (g_scene.NumVisibleBeacons() < 4) continue;
    testing::AddSpurious(*rig, 1 + trial % 4, &rng, &g_scene);
    std::array<std::uint8_t, limits::kMaxObservations> steady{};
    bool reflection = trial % 3 == 0;
    for (int b = 0; b < g_scene.num_blobs; ++b) {
      const bool spurious = g_scene.truth_beacon[static_cast<std::size_t>(b)] < 0;
      steady[static_cast<std::size_t>(b)] = !spurious || reflection;
      reflection = reflection && !spurious;  // (the first spurious blob only)
    }
    g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, all, &g_res, nullptr, kAllCameras, steady.data());
    if (!g_res.complete) continue;
    ++checked;
    cost_all += g_res.cost;
    const LisResult reference = g_res;
    g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, steady_list, &g_res, nullptr, kAllCameras, steady.data());
    cost_steady += g_res.cost;
    ASSERT_TRUE(g_res.steady_complete) << "trial " << trial;
    EXPECT_FALSE(g_res.complete);
    EXPECT_NE(g_res.status, LisStatus::kFix) << "trial " << trial << ": a steady list is no fix";
    const auto listed = [&](const BodyPose& q) {
      for (int i = 0; i < g_res.num_consistent; ++i) {
        const BodyPose& p = g_res.consistent_poses[static_cast<std::size_t>(i)];
        if ((p.r_w_wb - q.r_w_wb).norm() <= 0.05 && AngleBetween(p.C_w_b, q.C_w_b) <= 0.05) return true;
      }
      return false;
    };
    EXPECT_TRUE(listed(g_scene.pose)) << "trial " << trial << ": the truth is not in the steady list";
    matcher.SetBlobs(g_scene.blobs.data(), g_scene.num_blobs);
    for (int i = 0; i < reference.num_consistent; ++i) {
      const BodyPose& q = reference.consistent_poses[static_cast<std::size_t>(i)];
      MatchSet m;
      matcher.MatchPose(q, all.refine_match, &m);
      BeaconSet on_steady;  // (four distinct beacons: a P3P triple has three)
      for (int k = 0; k < m.num_matches; ++k) {
        const Match& x = m.matches[static_cast<std::size_t>(k)];
        if (steady[static_cast<std::size_t>(x.blob)] != 0) on_steady.Set(x.beacon);
      }
      const int steady_matched = on_steady.Count();
      if (steady_matched < 4) continue;
      ++on_four;
      EXPECT_TRUE(listed(q)) << "trial " << trial << ": a pose on " << steady_matched << " steady blobs is missing";
    }
  }
  std::printf("%d views, %d poses on four steady blobs; cost %.0f (every triple) vs %.0f (steady list)\n", checked,
              on_four, cost_all, cost_steady);
  EXPECT_GE(checked, testing::Trials(24, 8));
  EXPECT_GE(on_four, checked);
  EXPECT_LT(cost_steady, 0.5 * cost_all);
}

// A search cut by its budget before a confirmed pose gives neither a fix nor a complete list,
// so it ends where its budget does: it used to refine every raw pose it had kept (14 units
// each, up to limits::kMaxLisCandidates of them) after the budget had run out - +45 % on a
// small cluttered map's cold searches (the tracker's frame sets of 13 ms, session 37).
TEST(LostInSpaceTest, ASearchCutByItsBudgetEndsWithinIt) {
  std::mt19937_64 rng(937);
  const Rig* rig = ResetOnCylinder(10, &rng);
  ASSERT_NE(rig, nullptr);
  LisOptions o;
  o.max_cost = 1500.0;
  // One hypothesis past the budget: up to 8 P3P roots, each reprojected and refined.
  const double one_hypothesis = 8.0 * (14.0 + 0.113 * rig->num_beacons) + 4.0;
  int cut = 0, with_poses = 0;
  double worst_over = 0.0;
  for (int trial = 0; trial < testing::Trials(24, 8); ++trial) {
    testing::Observe(*rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
    testing::AddSpurious(*rig, 3 * rig->num_cameras, &rng, &g_scene);
    g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res);
    if (g_res.search_complete || g_res.confirmed) continue;
    ++cut;
    with_poses += g_res.poses_scored > 100 ? 1 : 0;
    worst_over = std::max(worst_over, g_res.cost - o.max_cost);
    EXPECT_LE(g_res.cost, o.max_cost + one_hypothesis) << "trial " << trial;
    EXPECT_NE(g_res.status, LisStatus::kFix) << "trial " << trial;
    EXPECT_FALSE(g_res.complete) << "trial " << trial;
  }
  std::printf("%d searches cut by the budget (%d with > 100 poses scored), worst %.0f units over it\n", cut,
              with_poses, worst_over);
  EXPECT_GE(cut, testing::Trials(24, 8) / 2);
  EXPECT_GT(with_poses, 0);
}

// Triples of steady blobs pass the fourth-blob test only on a steady fourth
// (LisOptions::steady_fourth): in a dense map a beacon lined up with a flickering spurious blob
// was the common pass, each a full reprojection (the matrix's box 256 seed 3: first fix 51 -> 19
// frame sets after the first view of four beacons: NavMatrix.
// ADenseBoxIsFixedSoonerWhenSteadyTriplesAskForASteadyFourth). A pose whose only fourth blob is
// unsteady is deferred: kept and scored after the last item, so a search that reaches its end
// lists the same poses as without the rule (the raw fourth test is noisy: the triples that hold
// the unsteady blob need not list that pose; seen here before deferred poses were scored, when
// such a search gave up its completeness, and with it the acquisition's chain in a static
// clutter). On a 10-beacon map with the test on from 8 beacons (a larger map's search seldom
// completes within its work units), the beacons just in view (not steady yet) beside four
// steady reflections: the case the rule defers most.
TEST(LostInSpaceTest, ASteadyFourthNeverShortensACompleteList) {
  std::mt19937_64 rng(983);
  const Rig* rig = ResetOnCylinder(10, &rng);
  ASSERT_NE(rig, nullptr);
  std::array<std::uint8_t, limits::kMaxObservations> steady{};
  int both_complete = 0, deferring = 0;
  // (Views drawn until two complete searches deferred a pose: one in ten to twenty does.)
  const int trials = testing::Trials(60, 20);
  for (int trial = 0; trial < 10 * trials && (trial < trials || deferring < 2); ++trial) {
    do testing::Observe(*rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
    while (g_scene.NumVisibleBeacons() < 4 || g_scene.num_blobs > 5);
    const int beacon_blobs = g_scene.num_blobs;
    testing::AddSpurious(*rig, 4, &rng, &g_scene);
    for (int i = 0; i < g_scene.num_blobs; ++i) steady[static_cast<std::size_t>(i)] = i >= beacon_blobs ? 1 : 0;
    std::array<LisResult, 2> r;
    for (const bool on : {true, false}) {
      LisOptions o;
      o.fourth_blob_min_beacons = 8;
      o.confirm_beacons = 0;  // (no confirmation: the search runs to its end)
      o.steady_fourth = on;
      g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &r[on ? 0 : 1], nullptr, kAllCameras, steady.data());
    }
    EXPECT_EQ(r[1].deferred, 0) << "trial " << trial;
    ASSERT_LE(r[0].deferred, limits::kMaxLisDeferred) << "trial " << trial << ": this test needs every pose kept";
    EXPECT_EQ(r[0].complete, r[1].complete) << "trial " << trial << ", " << r[0].deferred << " deferred";
    if (!r[0].complete || !r[1].complete) continue;
    ++both_complete;
    deferring += r[0].deferred > 0 ? 1 : 0;
    EXPECT_EQ(r[0].status, r[1].status) << "trial " << trial;
    ASSERT_EQ(r[0].num_consistent, r[1].num_consistent) << "trial " << trial;
    for (int i = 0; i < r[0].num_consistent; ++i) {
      const BodyPose& p = r[0].consistent_poses[static_cast<std::size_t>(i)];
      bool found = false;
      for (int k = 0; k < r[1].num_consistent && !found; ++k)
        found = (p.r_w_wb - r[1].consistent_poses[static_cast<std::size_t>(k)].r_w_wb).norm() < 1e-3;
      EXPECT_TRUE(found) << "trial " << trial << ": pose " << i << " of the steady-fourth list is not in the other";
    }
  }
  std::printf("%d complete lists alike, %d of them from searches that deferred a pose\n", both_complete, deferring);
  EXPECT_GE(both_complete, trials / 6);
  EXPECT_GE(deferring, 2);  // (the rule acted: else this test checks nothing)
}

}  // namespace

}  // namespace mfns::fw
