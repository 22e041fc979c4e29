#include "host/sim/observe/observe.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "common/camera/camera.h"
#include "host/sim/frames/render_run.h"
#include "host/core/image.h"
#include "host/sim/render/visibility.h"
#include "host/util/csv_table.h"

namespace mfns::host {
namespace {

// A station module with the paper rig wandering in it; error sources appended per test.
constexpr char kStation[] = R"(name: station-test
seed: 2
rig: paper
frame_rate_hz: 18.6
frames: 600
module: {shape: cylinder, diameter_mm: 4200, length_mm: 6000}
beacons: {layout: jittered-grid, count: 128, jitter: 0.25, half_angle_deg: 60}
trajectory: {kind: wander}
sensor: {flux_e_at_1m: 120000, edge_margin_px: 2}
)";

Scenario Station(const std::string& extra = "", int frames = 600) {
  Scenario s = ParseScenarioYaml(std::string(kStation) + extra, "station.yaml", ".");
  s.frames = frames;
  return s;
}

std::vector<BlobFrameSet> BlobRun(const Scenario& s) {
  std::vector<BlobFrameSet> out;
  for (const FrameTruth& f : SimulateTrajectory(s)) out.push_back(SimulateBlobs(s, f));
  return out;
}

int CameraIndex(const Scenario& s, const std::string& name) {
  for (int k = 0; k < s.rig.num_cameras; ++k)
    if (name == s.rig.cameras[static_cast<std::size_t>(k)].name.data()) return k;
  return -1;
}

std::filesystem::path TempDir() {
  std::string tmpl = (std::filesystem::temp_directory_path() / "mfns-observe-XXXXXX").string();
  EXPECT_NE(::mkdtemp(tmpl.data()), nullptr);
  return tmpl;
}

double Pixel(const cv::Mat& img, const Eigen::Vector2d& uv) {
  return img.at<std::uint8_t>(static_cast<int>(std::lround(uv.y())), static_cast<int>(std::lround(uv.x())));
}

// The rendered run and the blob-level simulation make one decision: blobs.csv lists exactly
// the beacons (and centres) SimulateBlobs gives, with every error source on; the images show
// the spurious spots, leave the occluded beacons out and saturate the blinded camera.
TEST(BlobSim, MatchesTheRenderedRun) {
  const std::string clutter = R"(clutter:
  spurious: {count: 4, near_fraction: 0.5, near_radius_px: [8, 30], static_reflections: 30}
  occlusions:
    - {frames: [0, 5], camera: x, rect_px: [0, 0, 640, 1024]}
  blinded:
    - {camera: y, frames: [2, 3], mode: saturated}
)";
  const Scenario s = Station(clutter, 6);
  const auto dir = TempDir();
  RenderOptions opt;
  opt.out_dir = dir;
  opt.progress = false;
  opt.threads = 2;
  RenderScenario(s, "", opt);
  const CsvTable blobs = CsvTable::Read(dir / "blobs.csv");
  const auto truth = SimulateTrajectory(s);
  Scenario unoccluded = s;
  unoccluded.clutter.occlusions.clear();
  std::size_t row = 0;
  int spots_checked = 0, occluded_checked = 0;
  for (const FrameTruth& f : truth) {
    const BlobFrameSet sim = SimulateBlobs(s, f);
    for (std::size_t j = 0; j < sim.blobs.size(); ++j) {
      if (sim.beacon[j] < 0) continue;
      ASSERT_LT(row, blobs.size());
      const std::size_t r = row++;
      EXPECT_EQ(static_cast<int>(blobs.Number(r, blobs.Column("frame"))), f.frame);
      EXPECT_EQ(CameraIndex(s, blobs.Cell(r, blobs.Column("camera"))), sim.blobs[j].camera);
      EXPECT_EQ(static_cast<int>(blobs.Number(r, blobs.Column("beacon"))), sim.beacon[j]);
      EXPECT_NEAR(blobs.Number(r, blobs.Column("u_px")), sim.blobs[j].uv_px.x(), 1e-6);
      EXPECT_NEAR(blobs.Number(r, blobs.Column("v_px")), sim.blobs[j].uv_px.y(), 1e-6);
    }
    char name[32];
    std::snprintf(name, sizeof(name), "%06d.pgm", f.frame);
    std::array<cv::Mat, 3> img;
    for (int k = 0; k < 3; ++k) img[static_cast<std::size_t>(k)] = ReadPgm((dir / "frames" / s.rig.cameras[static_cast<std::size_t>(k)].name.data() / name).string());
    // Spurious spots are drawn: the pixel nearest a spot's centre holds at least 0.1165 of its
    // flux (sigma 1 px, centre up to half a pixel off), over the 10 DN background, 40 e/DN.
    for (std::size_t j = 0; j < sim.blobs.size(); ++j) {
      if (sim.beacon[j] >= 0) continue;
      const double peak_dn = std::min(245.0, 0.1165 * static_cast<double>(sim.blobs[j].flux));  // flux is in DN
      EXPECT_GT(Pixel(img[static_cast<std::size_t>(sim.blobs[j].camera)], sim.blobs[j].uv_px), 10.0 + 0.8 * peak_dn - 4.0);
      ++spots_checked;
    }
    // Occluded beacons are not drawn.
    const BlobFrameSet open = SimulateBlobs(unoccluded, f);
    for (std::size_t j = 0; j < open.blobs.size(); ++j) {
      if (open.blobs[j].camera != 0 || open.beacon[j] < 0 || open.uv_geom_px[j].x() > 640) continue;
      EXPECT_LT(Pixel(img[0], open.uv_geom_px[j]), 14.0) << "beacon " << open.beacon[j];
      ++occluded_checked;
    }
    // The blinded camera's frame is saturated, and it has no blobs.
    if (f.frame == 2 || f.frame == 3) {
      double lo = 0, hi = 0;
      cv::minMaxLoc(img[1], &lo, &hi);
      EXPECT_EQ(lo, 255.0);
      EXPECT_TRUE(sim.visible[1].empty());
    }
  }
  EXPECT_EQ(row, blobs.size());
  EXPECT_GT(spots_checked, 20);
  EXPECT_GT(occluded_checked, 0);
  std::filesystem::remove_all(dir);
}

TEST(BlobSim, CentroidNoiseHasTheRequestedSigma) {
  Scenario s = Station("", 400);
  s.errors.centroid_sigma_px = 0.25;
  std::vector<double> d;
  for (const BlobFrameSet& b : BlobRun(s))
    for (std::size_t j = 0; j < b.blobs.size(); ++j) {
      if (b.beacon[j] < 0) continue;
      d.push_back(b.blobs[j].uv_px.x() - b.uv_geom_px[j].x());
      d.push_back(b.blobs[j].uv_px.y() - b.uv_geom_px[j].y());
    }
  ASSERT_GT(d.size(), 2000u);
  double mean = 0, sum2 = 0;
  for (double x : d) mean += x / d.size();
  for (double x : d) sum2 += (x - mean) * (x - mean);
  const double sigma = std::sqrt(sum2 / (d.size() - 1));
  const double se = 1.0 / std::sqrt(2.0 * d.size());  // relative standard error of a sigma
  std::printf("centroid noise: %zu samples, sigma %.4f px (asked 0.25), mean %.4f px\n", d.size(), sigma, mean);
  EXPECT_NEAR(sigma / 0.25, 1.0, 4 * se);
  EXPECT_LT(std::abs(mean), 4 * 0.25 / std::sqrt(d.size()));

  Scenario quiet = Station("", 20);
  quiet.errors.pixel_noise = false;  // off: the centres are the projections
  for (const BlobFrameSet& b : BlobRun(quiet))
    for (std::size_t j = 0; j < b.blobs.size(); ++j)
      if (b.beacon[j] >= 0) {
        EXPECT_EQ(b.blobs[j].uv_px, b.uv_geom_px[j]);
      }
}

TEST(BlobSim, SpuriousCountsAreExactAndNearOnesNearTheirBeacon) {
  const Scenario s = Station("clutter:\n  spurious: {count: 6, near_fraction: 0.5, near_radius_px: [5, 40]}\n", 200);
  int near_total = 0;
  for (const BlobFrameSet& b : BlobRun(s))
    for (int k = 0; k < 3; ++k) {
      int spurious = 0, near = 0;
      for (std::size_t j = 0; j < b.blobs.size(); ++j) {
        if (b.blobs[j].camera != k || b.beacon[j] >= 0) continue;
        ++spurious;
        EXPECT_TRUE(InImage(s.rig.cameras[static_cast<std::size_t>(k)].intrinsics, b.blobs[j].uv_px, 2.0));
        if (b.source[j] != SpotSource::kNearReflection) continue;
        ++near;
        // Its parent is a blob of the same camera, 5..40 px away.
        bool found = false;
        for (std::size_t i = 0; i < b.blobs.size(); ++i) {
          if (b.blobs[i].camera != k || b.beacon[i] != b.parent[j]) continue;
          const double r = (b.blobs[i].uv_px - b.blobs[j].uv_px).norm();
          EXPECT_GE(r, 5.0 - 1e-9);
          EXPECT_LE(r, 40.0 + 1e-9);
          found = true;
        }
        EXPECT_TRUE(found);
      }
      EXPECT_EQ(spurious, 6);
      // round(0.5 x 6) = 3 near ones when the camera sees a beacon (tries that leave the image fall back to a random spot).
      if (!b.visible[static_cast<std::size_t>(k)].empty()) {
        EXPECT_GE(near, 2);
      }
      EXPECT_LE(near, b.visible[static_cast<std::size_t>(k)].empty() ? 0 : 3);
      near_total += near;
    }
  EXPECT_GT(near_total, 200);

  // reflections_per_frame (issue 3's clutter) adds its spots anywhere in the whole image: those
  // within edge_margin_px of the border are drawn but are no blobs.
  const Scenario more = Station("clutter:\n  reflections_per_frame: 5\n  spurious: {count: 6}\n", 50);
  int listed = 0;
  for (const BlobFrameSet& b : BlobRun(more)) {
    int spurious = 0;
    for (std::size_t j = 0; j < b.blobs.size(); ++j) spurious += b.beacon[j] < 0;
    EXPECT_LE(spurious, 3 * 11);
    listed += spurious;
  }
  EXPECT_GT(listed, 50 * 3 * 10);
}

TEST(BlobSim, StaticReflectionsMoveWithTheScene) {
  const Scenario s = Station("clutter:\n  spurious: {static_reflections: 40}\n", 200);
  ASSERT_EQ(s.clutter.reflectors.num_beacons, 40);
  int seen = 0;
  for (const FrameTruth& f : SimulateTrajectory(s)) {
    const BlobFrameSet b = SimulateBlobs(s, f);
    for (std::size_t j = 0; j < b.blobs.size(); ++j) {
      if (b.source[j] != SpotSource::kStaticReflection) continue;
      ++seen;
      EXPECT_EQ(b.beacon[j], -1);
      // Where the unmapped wall point images, like a beacon.
      EXPECT_LT((b.blobs[j].uv_px - b.uv_geom_px[j]).norm(), 1.0);
    }
  }
  EXPECT_GT(seen, 100);
}

TEST(BlobSim, OccludedBeaconsAbsentInTheWindowPresentOutside) {
  const Scenario open = Station("", 60);
  const auto base = BlobRun(open);
  // A few beacons camera z sees during frames 20..39, hidden from every camera then.
  std::set<int> hide;
  for (int f = 20; f < 40 && hide.size() < 3; ++f)
    for (int id : base[static_cast<std::size_t>(f)].visible[2]) hide.insert(id);
  ASSERT_FALSE(hide.empty());
  std::string ids;
  for (int id : hide) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
  const Scenario s = Station("clutter:\n  occlusions:\n    - {frames: [20, 39], beacons: [" + ids +
                                 "]}\n    - {frames: [10, 49], camera: x, rect_px: [0, 0, 640, 1024]}\n", 60);
  const auto run = BlobRun(s);
  int removed = 0, kept_in_rect = 0;
  for (int f = 0; f < 60; ++f)
    for (int k = 0; k < 3; ++k) {
      const auto& b = base[static_cast<std::size_t>(f)];
      const auto& r = run[static_cast<std::size_t>(f)];
      for (std::size_t j = 0; j < b.blobs.size(); ++j) {
        if (b.blobs[j].camera != k || b.beacon[j] < 0) continue;
        const bool by_id = f >= 20 && f <= 39 && hide.count(b.beacon[j]) > 0;
        const bool by_region = f >= 10 && f <= 49 && k == 0 && b.uv_geom_px[j].x() <= 640;
        const auto& seen = r.visible[static_cast<std::size_t>(k)];
        const bool present = std::find(seen.begin(), seen.end(), b.beacon[j]) != seen.end();
        EXPECT_EQ(present, !by_id && !by_region) << "frame " << f << " camera " << k << " beacon " << b.beacon[j];
        removed += !present;
        kept_in_rect += present && k == 0 && b.uv_geom_px[j].x() <= 640;  // the region outside its window
      }
    }
  EXPECT_GT(removed, 10);
  EXPECT_GT(kept_in_rect, 0);
}

TEST(BlobSim, BlindedCameraDeliversNoBlobsInItsWindow) {
  const auto base = BlobRun(Station("", 30));
  const Scenario s = Station("clutter:\n  blinded:\n    - {camera: y, frames: [5, 9], mode: black}\n  stop_camera: z\n  stop_frame: 20\n", 30);
  const auto run = BlobRun(s);
  int blobs_outside = 0;
  for (int f = 0; f < 30; ++f) {
    const auto& r = run[static_cast<std::size_t>(f)];
    const bool blind = f >= 5 && f <= 9;
    EXPECT_TRUE(r.delivered[0]);
    EXPECT_TRUE(r.delivered[1]);  // blinded: a frame with no blobs, still delivered
    EXPECT_EQ(r.delivered[2], f < 20);
    EXPECT_EQ(r.state[1], blind ? CameraState::kBlindedBlack : CameraState::kDelivered);
    int on_y = 0;
    for (const auto& blob : r.blobs) on_y += blob.camera == 1;
    if (blind) {
      EXPECT_EQ(on_y, 0);
    }
    if (!blind) {
      EXPECT_EQ(r.visible[1], base[static_cast<std::size_t>(f)].visible[1]);
      blobs_outside += on_y;
    }
    EXPECT_EQ(r.visible[0], base[static_cast<std::size_t>(f)].visible[0]);  // the others unaffected
    if (f >= 20) {
      EXPECT_TRUE(r.visible[2].empty());
    }
  }
  EXPECT_GT(blobs_outside, 0);
}

// A beacon seen from behind (or outside its beam) is never a blob, and the beams matter: the
// wander run meets beacons in the image but facing away.
TEST(BlobSim, BeaconSeenFromBehindIsNeverABlob) {
  const Scenario s = Station("", 600);
  int blobs = 0, turned_away = 0;
  for (const FrameTruth& f : SimulateTrajectory(s)) {
    const BlobFrameSet b = SimulateBlobs(s, f);
    for (std::size_t j = 0; j < b.blobs.size(); ++j) {
      if (b.beacon[j] < 0) continue;
      const RigCamera& cam = s.rig.cameras[static_cast<std::size_t>(b.blobs[j].camera)];
      EXPECT_TRUE(BeaconFaces(s.rig, b.beacon[j], CameraCentreWorld(cam, f.pose)));
      ++blobs;
    }
    for (int k = 0; k < 3; ++k)
      for (int m = 0; m < s.rig.num_beacons; ++m) {
        const BeaconSight sight = SightBeacon(s.rig, f.pose, k, m, 2.0);
        turned_away += sight.projection.visible && !sight.faces;
      }
  }
  EXPECT_GT(blobs, 1000);
  EXPECT_GT(turned_away, 100);
  std::printf("wander run: %d beacon blobs, %d in-image beacons facing away (not blobs)\n", blobs, turned_away);

  // Without facing data in the map the LEDs keep their beams: the same blobs.
  std::string yaml = std::string(kStation);
  yaml.replace(yaml.find("half_angle_deg"), 0, "facing: false, ");
  const Scenario no_map_facing = ParseScenarioYaml(yaml, "station.yaml", ".");
  const FrameTruth f = SimulateTrajectory(s)[123];
  EXPECT_EQ(SimulateBlobs(no_map_facing, f).visible, SimulateBlobs(s, f).visible);
}

TEST(BlobSim, NormalisedCoordinatesAndFluxFollowTheTrueRig) {
  const Scenario s = Station("", 50);
  int checked = 0;
  for (const FrameTruth& f : SimulateTrajectory(s)) {
    const BlobFrameSet b = SimulateBlobs(s, f);
    for (std::size_t j = 0; j < b.blobs.size(); ++j) {
      const RigCamera& cam = s.rig.cameras[static_cast<std::size_t>(b.blobs[j].camera)];
      Eigen::Vector2d uv;
      ASSERT_EQ(Project(cam.intrinsics, Eigen::Vector3d(b.blobs[j].x_n.x(), b.blobs[j].x_n.y(), 1.0), &uv), ProjectStatus::kOk);
      EXPECT_LT((uv - b.blobs[j].uv_px).norm(), 1e-5);
      if (b.beacon[j] < 0) continue;
      const double d2 = (WorldToCamera(cam, f.pose, s.rig.beacons_w[static_cast<std::size_t>(b.beacon[j])])).squaredNorm();
      const double flux = b.blobs[j].flux;
      EXPECT_NEAR(flux, s.sensor.flux_e_at_1m / d2 / s.sensor.gain_e_per_dn, 1e-5 * flux);
      ++checked;
    }
  }
  EXPECT_GT(checked, 100);
}

TEST(BlobSim, DeterministicPerSeedAndFrame) {
  Scenario s = Station("clutter:\n  spurious: {count: 3}\n", 40);
  const auto truth = SimulateTrajectory(s);
  const BlobFrameSet late = SimulateBlobs(s, truth[30]);
  const BlobFrameSet early = SimulateBlobs(s, truth[3]);
  const BlobFrameSet late_again = SimulateBlobs(s, truth[30]);  // any order of calls
  ASSERT_EQ(late.blobs.size(), late_again.blobs.size());
  for (std::size_t j = 0; j < late.blobs.size(); ++j) EXPECT_EQ(late.blobs[j].uv_px, late_again.blobs[j].uv_px);
  s.seed = 77;  // another noise draw for the same pose
  const BlobFrameSet other = SimulateBlobs(s, truth[3]);
  ASSERT_FALSE(early.blobs.empty());
  EXPECT_NE(other.blobs[0].uv_px, early.blobs[0].uv_px);
}

std::string ErrorOf(const std::string& extra) {
  try {
    ParseScenarioYaml(std::string(kStation) + extra, "s.yaml", ".");
  } catch (const UserError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(BlobSim, ErrorSourceFieldsNameFileLineAndField) {
  EXPECT_EQ(ErrorOf("clutter:\n  spurious: {count: 101}\n"), "s.yaml:11: clutter.spurious.count: must be 0..100");
  EXPECT_EQ(ErrorOf("clutter:\n  spurious: {near_fraction: 2}\n"), "s.yaml:11: clutter.spurious.near_fraction: must be 0..1");
  EXPECT_EQ(ErrorOf("clutter:\n  spurious: {near_radius_px: [40, 5]}\n"),
            "s.yaml:11: clutter.spurious.near_radius_px: expected 0 <= min <= max <= 500");
  EXPECT_EQ(ErrorOf("clutter:\n  spurious: {near: 3}\n"), "s.yaml:11: clutter.spurious: unknown field 'near'");
  EXPECT_EQ(ErrorOf("clutter:\n  occlusions:\n    - {frames: [5, 2]}\n"),
            "s.yaml:12: clutter.occlusions[0].frames: expected 0 <= first <= last");
  EXPECT_EQ(ErrorOf("clutter:\n  occlusions:\n    - {camera: x}\n"), "s.yaml:12: clutter.occlusions[0]: missing field 'frames'");
  EXPECT_EQ(ErrorOf("clutter:\n  occlusions:\n    - {frames: [1, 2], rect_px: [0, 0, 10, 10]}\n"),
            "s.yaml:12: clutter.occlusions[0].rect_px: a region needs its camera (camera: NAME)");
  EXPECT_EQ(ErrorOf("clutter:\n  occlusions:\n    - {frames: [1, 2], beacons: [500]}\n"),
            "s.yaml:12: clutter.occlusions[0].beacons[0]: no beacon 500");
  EXPECT_EQ(ErrorOf("clutter:\n  blinded:\n    - {camera: q, frames: [1, 2]}\n"),
            "s.yaml:12: clutter.blinded[0].camera: no camera named 'q' in the rig");
  EXPECT_EQ(ErrorOf("clutter:\n  blinded:\n    - {camera: x, frames: [1, 2], mode: dim}\n"),
            "s.yaml:12: clutter.blinded[0].mode: expected saturated or black, got 'dim'");
  std::string yaml = kStation;
  yaml.replace(yaml.find("edge_margin_px: 2"), 17, "edge_margin_px: -1");
  try {
    ParseScenarioYaml(yaml, "s.yaml", ".");
    ADD_FAILURE() << "no error";
  } catch (const UserError& e) {
    EXPECT_STREQ(e.what(), "s.yaml:9: sensor.edge_margin_px: must be 0..100");
  }
}

}  // namespace
}  // namespace mfns::host

namespace mfns::host {
namespace {

// The station presets over their 600-frame wander runs (the preset's seed and four more: the
// start, and so the view, changes much from seed to seed): beacons in view per frame set, all
// cameras, printed for the docs.
TEST(StationPresets, SeeSeveralBeaconsPerFrameSet) {
  for (const char* name : {"station-cylinder", "station-box"}) {
    Scenario s = LoadPreset(name);
    ASSERT_EQ(s.frames, 600);
    long total = 0;
    int with_3 = 0, none = 0;
    std::string per_seed;
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      s.seed = seed;  // the trajectory's; the map stays the preset's (map_seed)
      long run = 0;
      for (const FrameTruth& f : SimulateTrajectory(s)) {
        const int n = SimulateBlobs(s, f).NumVisible();
        run += n;
        with_3 += n >= 3;
        none += n == 0;
      }
      char buf[32];
      std::snprintf(buf, sizeof(buf), " %.1f", run / 600.0);
      per_seed += buf;
      total += run;
    }
    const double mean = total / 3000.0;
    std::printf("%s: mean %.2f beacons in view per frame set (seeds 1-5:%s), >= 3 in %.1f%%, none in %.1f%%\n", name,
                mean, per_seed.c_str(), 100.0 * with_3 / 3000, 100.0 * none / 3000);
    EXPECT_GT(mean, 3.0) << name;
    EXPECT_GT(with_3, 3000 / 2) << name;
  }
}

}  // namespace
}  // namespace mfns::host
