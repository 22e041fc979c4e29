// BlobTracks (blob_tracks.h): on a smooth 6-DOF path, the images of scene points (beacons and
// unmapped reflecting points alike) become steady after three frame sets, transient clutter
// (random spots, reflections jittering beside a beacon) almost never does; tracks start over
// after a gap or a camera that did not deliver; bad input is no crash.
#include "firmware/modules/identify/blob_tracks.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <utility>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "firmware/modules/identify/match.h"
#include "firmware/modules/identify/noise_model.h"
#include "firmware/modules/solve/synthetic_scene.h"

namespace mfns::fw {
namespace {

using testing::Scene;

constexpr double kFrameRateHz = 18.6;

std::uint64_t FrameNs(int f) { return static_cast<std::uint64_t>(std::llround(f * 1e9 / kFrameRateHz)); }

// Yaw at up to 0.9 rad/s with +-20 deg of roll and pitch, the body moving +-0.1 m: near the
// tracker's rate bound (1 rad/s).
BodyPose FastPath(double t) {
  BodyPose p;
  p.r_w_wb = Eigen::Vector3d(0.1 * std::sin(0.6 * t), 0.1 * std::sin(0.45 * t + 1.0), 0.05 * std::sin(0.3 * t + 2.0));
  const EulerAngles e{DegToRad(20.0) * std::sin(0.9 * t), DegToRad(20.0) * std::sin(0.7 * t + 1.0),
                      0.9 * t - 0.2 * std::cos(0.5 * t)};
  p.C_w_b = EulerToMatrix(e).transpose();
  return p;
}

// The paper rig with `extra` unmapped points (reflectors) 0.2-0.5 m beside its beacons: scene
// points the tracks cannot tell from beacons. Their indices follow the beacons'.
Rig RigWithReflectors(int extra, std::mt19937_64* rng) {
  Rig rig = PaperRig();
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n0 = rig.num_beacons;
  for (int i = 0; i < extra && rig.num_beacons < limits::kMaxBeacons; ++i) {
    const Eigen::Vector3d off(u(*rng), u(*rng), u(*rng));
    rig.beacons_w[static_cast<std::size_t>(rig.num_beacons++)] =
        rig.beacons_w[static_cast<std::size_t>(i % n0)] + (0.2 + 0.3 * std::abs(u(*rng))) * off.normalized();
  }
  return rig;
}

// A point seen in this many frame sets before: its track may have started late by one or two
// (a reflection beside it nearer the first position than its own next blob).
constexpr int kHistory = 4;

struct Counts {
  int continuing = 0, continuing_steady = 0;  // scene points seen in this and the kHistory previous frame sets
  int transient = 0, transient_steady = 0;    // clutter blobs
};

TEST(BlobTracksTest, ScenePointsBecomeSteadyClutterDoesNot) {
  std::mt19937_64 rng(7);
  const Rig scene_rig = RigWithReflectors(12, &rng);
  const double px_per_rad = LargestFocalPx(scene_rig);
  BlobTracks tracks;
  tracks.Reset();
  const BlobTrackOptions o;
  const int spur = 6;  // random spots and reflections beside beacons, each per frame set
  Scene s;
  // (camera, point) of the previous frame sets, the last first.
  std::array<std::set<std::pair<int, int>>, kHistory> history;
  Counts c;
  for (int f = 0; f < 600; ++f) {  // (~10 ms: the full count under qemu and the sanitizers too)
    testing::Observe(scene_rig, FastPath(f / kFrameRateHz), 0.15, &rng, &s);
    testing::AddSpurious(scene_rig, spur, &rng, &s);
    testing::AddReflections(scene_rig, spur, 5.0, 40.0, &rng, &s);
    tracks.Update(s.blobs.data(), s.num_blobs, FrameNs(f), kAllCameras, px_per_rad, o);
    std::set<std::pair<int, int>> seen;
    for (int i = 0; i < s.num_blobs; ++i) {
      const auto si = static_cast<std::size_t>(i);
      const std::pair<int, int> key{s.blobs[si].camera, s.truth_beacon[si]};
      if (s.truth_beacon[si] < 0) {
        ++c.transient;
        c.transient_steady += tracks.steady(i) ? 1 : 0;
        continue;
      }
      seen.insert(key);
      bool continuing = true;
      for (const auto& h : history) continuing = continuing && h.count(key) > 0;
      if (!continuing) continue;
      ++c.continuing;
      c.continuing_steady += tracks.steady(i) ? 1 : 0;
    }
    for (int h = kHistory - 1; h > 0; --h) history[static_cast<std::size_t>(h)] = std::move(history[static_cast<std::size_t>(h - 1)]);
    history[0] = std::move(seen);
  }
  ASSERT_GT(c.continuing, 500);
  ASSERT_GT(c.transient, 3000);
  // Measured (seed 7, 600 frame sets): on the host 1616 of 1632 continuing points steady, 9 of
  // 4932 clutter blobs (the gates 3-6 px and 0.1-0.3 of the displacement all give 98.8-99.5 %
  // and 0.1-0.3 %); on aarch64 (other roundings, another scene) 1712 of 1769. The misses: at
  // 0.9 rad/s a beacon's image moves ~60 px per frame set, and a reflection beside its new
  // position may lie nearer its first one, taking its second step (the track starts over).
  EXPECT_GE(c.continuing_steady, 0.95 * c.continuing) << c.continuing_steady << " of " << c.continuing;
  EXPECT_LE(c.transient_steady, 0.01 * c.transient) << c.transient_steady << " of " << c.transient;
  int steady = 0;
  for (int i = 0; i < s.num_blobs; ++i) steady += tracks.steady(i) ? 1 : 0;
  EXPECT_EQ(tracks.num_steady(), steady);
}

// Three frame sets of one static scene (a point at rest: zero image velocity).
void StaticFrames(BlobTracks* tracks, const Scene& s, int first, std::uint32_t cameras, const BlobTrackOptions& o) {
  for (int f = first; f < first + 3; ++f) tracks->Update(s.blobs.data(), s.num_blobs, FrameNs(f), cameras, 1000.0, o);
}

TEST(BlobTracksTest, GapsAndSilentCamerasStartOver) {
  const Rig rig = PaperRig();
  std::mt19937_64 rng(3);
  Scene s;
  testing::Observe(rig, testing::YawPose(0.3), 0.0, &rng, &s);
  ASSERT_GE(s.num_blobs, 3);
  const BlobTrackOptions o;
  BlobTracks tracks;
  tracks.Reset();
  StaticFrames(&tracks, s, 0, kAllCameras, o);
  EXPECT_EQ(tracks.num_steady(), s.num_blobs);
  EXPECT_EQ(tracks.age(0), 3);
  // Each track keeps its id while it continues; ids differ between tracks and are never 0.
  std::set<std::uint32_t> ids;
  for (int i = 0; i < s.num_blobs; ++i) ids.insert(tracks.id(i));
  EXPECT_EQ(ids.size(), static_cast<std::size_t>(s.num_blobs));
  EXPECT_EQ(ids.count(0U), 0U);
  const std::uint32_t first_id = tracks.id(0);
  tracks.Update(s.blobs.data(), s.num_blobs, FrameNs(3), kAllCameras, 1000.0, o);
  EXPECT_EQ(tracks.id(0), first_id);
  // A gap beyond max_gap_s: every track is new, with a new id.
  const auto late = static_cast<int>(std::ceil((o.max_gap_s + 0.1) * kFrameRateHz)) + 4;
  tracks.Update(s.blobs.data(), s.num_blobs, FrameNs(late), kAllCameras, 1000.0, o);
  EXPECT_EQ(tracks.num_steady(), 0);
  EXPECT_EQ(tracks.age(0), 1);
  for (int i = 0; i < s.num_blobs; ++i) EXPECT_EQ(ids.count(tracks.id(i)), 0U) << "blob " << i;
  // A camera that did not deliver in the previous frame set starts its tracks over.
  tracks.Reset();
  StaticFrames(&tracks, s, 0, kAllCameras, o);
  const int cam = s.blobs[0].camera;
  tracks.Update(s.blobs.data(), s.num_blobs, FrameNs(3), kAllCameras & ~(1u << cam), 1000.0, o);
  tracks.Update(s.blobs.data(), s.num_blobs, FrameNs(4), kAllCameras, 1000.0, o);
  EXPECT_EQ(tracks.age(0), 1);
  EXPECT_LT(tracks.num_steady(), s.num_blobs);
  // A repeated or backward time stamp: no association, no crash.
  tracks.Update(s.blobs.data(), s.num_blobs, FrameNs(4), kAllCameras, 1000.0, o);
  EXPECT_EQ(tracks.num_steady(), 0);
}

TEST(BlobTracksTest, BadInputIsNoCrash) {
  BlobTracks tracks;
  tracks.Reset();
  BlobTrackOptions o;
  EXPECT_TRUE(o.IsValid());
  std::array<BlobObs, 3> b{};
  b[0].camera = -2;
  b[1].camera = 99;
  b[2].camera = 0;
  b[2].x_n = Eigen::Vector2d(std::nan(""), 0.0);
  for (int f = 0; f < 4; ++f) tracks.Update(b.data(), 3, FrameNs(f), kAllCameras, 1000.0, o);
  EXPECT_EQ(tracks.num_steady(), 0);
  tracks.Update(nullptr, 5, FrameNs(5), kAllCameras, 1000.0, o);
  EXPECT_EQ(tracks.num_steady(), 0);
  tracks.Update(b.data(), -4, FrameNs(6), kAllCameras, 1000.0, o);
  EXPECT_EQ(tracks.num_steady(), 0);
  o.tight_gate_px = std::nan("");
  EXPECT_FALSE(o.IsValid());
  o = BlobTrackOptions{};
  o.steady_age = 1;
  EXPECT_FALSE(o.IsValid());
}

}  // namespace
}  // namespace mfns::fw
