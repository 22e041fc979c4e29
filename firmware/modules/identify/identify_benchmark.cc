// Speed of beacon identification (lost-in-space, tracking) beside OpenCV baselines measured in
// the same program: cv::solvePnP (SOLVEPNP_ITERATIVE, from the previous pose) on one camera's
// points for tracking, and cv::solveP3P (SOLVEPNP_P3P) for the P3P that lost-in-space repeats
// for every hypothesis (OpenCV has no identification: a brute-force lost-in-space with OpenCV
// would cost about p3p_solves x one cv::solveP3P).
//
//   build/<dir>/bin/identify_benchmark --benchmark_min_time=0.5
//
// Scenes: the paper rig and its 10 beacons (common/rig/paper_rig.h), body at the origin yawed
// in 1 deg steps at 30 Hz, 0.2 px centroid noise, optional spurious blobs as bright as beacons.
#include <benchmark/benchmark.h>

#include <array>
#include <memory>
#include <random>
#include <vector>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "firmware/modules/identify/lost_in_space.h"
#include "firmware/modules/identify/map_repeats.h"
#include "firmware/modules/identify/p3p.h"
#include "firmware/modules/identify/p3p_scan_reference.h"
#include "firmware/modules/identify/tracker.h"
#include "firmware/modules/solve/synthetic_scene.h"

#ifdef MFNS_HAVE_OPENCV  // host builds; the aarch64 cross build has no OpenCV
#include <opencv2/calib3d.hpp>
#endif

namespace mfns::fw {
namespace {

constexpr std::uint64_t kFrameNs = 33333333;

const Rig& PaperRigOnce() {
  static const Rig rig = PaperRig();
  return rig;
}

// The 360 frame sets of the yaw sweep (with `spurious` extra blobs each).
const std::vector<testing::Scene>& Sweep(int spurious) {
  static std::vector<testing::Scene> sweeps[4];
  auto& v = sweeps[spurious];
  if (v.empty()) {
    v.resize(360);
    std::mt19937_64 rng(42 + static_cast<std::uint64_t>(spurious));
    for (int step = 0; step < 360; ++step) {
      testing::Observe(PaperRigOnce(), testing::YawPose(DegToRad(step)), 0.2, &rng, &v[static_cast<std::size_t>(step)]);
      testing::AddSpurious(PaperRigOnce(), spurious, &rng, &v[static_cast<std::size_t>(step)]);
    }
  }
  return v;
}

// The first step of the sweep with exactly `beacons` in view.
int StepWith(int beacons) {
  const auto& v = Sweep(0);
  for (int s = 0; s < 360; ++s)
    if (v[static_cast<std::size_t>(s)].NumVisibleBeacons() == beacons) return s;
  return 0;
}

void LostInSpaceFrame(benchmark::State& state, int beacons, int spurious) {
  static auto lis = std::make_unique<LostInSpace>();
  static auto res = std::make_unique<LisResult>();
  lis->Reset(PaperRigOnce());
  const int step = StepWith(beacons);
  // The same true blobs with `spurious` extra ones.
  testing::Scene s = Sweep(0)[static_cast<std::size_t>(step)];
  std::mt19937_64 rng(7);
  testing::AddSpurious(PaperRigOnce(), spurious, &rng, &s);
  for (auto _ : state) {
    lis->Identify(s.blobs.data(), s.num_blobs, LisOptions{}, res.get());
    benchmark::DoNotOptimize(res->status);
  }
  state.counters["blobs"] = s.num_blobs;
  state.counters["p3p_solves"] = res->hypotheses;
  state.counters["consistent_poses"] = res->num_consistent;
  state.counters["fix"] = res->status == LisStatus::kFix;
}
BENCHMARK_CAPTURE(LostInSpaceFrame, 3beacons, 3, 0)->Unit(benchmark::kMillisecond);

// Lost-in-space against the map's size: a cylindrical module (4.2 m x 6 m, beacons facing
// inward, 60 deg beams) with range(0) beacons, 16 random poses with >= 4 beacons in view, 0.2
// px noise and range(1) spurious blobs per camera; each Identify gets one frame set's budget
// (TrackOptions::lis_budget_per_frame hypotheses), over range(2) nested near depth ranges
// (LisOptions::near_bands; 2 is the default, 1 the search before session 32). Counters:
// hypotheses and blobs per frame set, the share that fixed within it, and the CPU time per
// hypothesis (P3P solve and scoring).
void LostInSpaceStation(benchmark::State& state) {
  const int num_beacons = static_cast<int>(state.range(0));
  const int spurious = static_cast<int>(state.range(1));
  const int near_bands = static_cast<int>(state.range(2));
  static Rig rig;
  static auto lis = std::make_unique<LostInSpace>();
  static auto res = std::make_unique<LisResult>();
  static std::vector<testing::Scene> scenes;
  std::mt19937_64 rng(900 + static_cast<std::uint64_t>(num_beacons));
  rig = testing::RandomCylinderRig(num_beacons, true, &rng);
  lis->Reset(rig);
  scenes.assign(16, testing::Scene{});
  for (auto& sc : scenes) {
    do testing::Observe(rig, testing::RandomCylinderPose(&rng), 0.2, &rng, &sc);
    while (sc.NumVisibleBeacons() < 4);
    testing::AddSpurious(rig, spurious * rig.num_cameras, &rng, &sc);
  }
  LisOptions o;
  o.max_hypotheses = TrackOptions{}.lis_budget_per_frame;
  o.near_bands = near_bands;
  std::size_t i = 0;
  double hypotheses = 0.0, fixes = 0.0, blobs = 0.0, frames = 0.0;
  for (auto _ : state) {
    const testing::Scene& sc = scenes[i++ % scenes.size()];
    lis->Identify(sc.blobs.data(), sc.num_blobs, o, res.get());
    hypotheses += res->hypotheses;
    fixes += res->status == LisStatus::kFix;
    blobs += sc.num_blobs;
    frames += 1.0;
  }
  state.counters["hypotheses"] = hypotheses / frames;
  state.counters["blobs"] = blobs / frames;
  state.counters["fixed"] = fixes / frames;
  state.counters["per_hypothesis"] =
      benchmark::Counter(hypotheses, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(LostInSpaceStation)
    ->ArgsProduct({{10, 64, 256}, {2}, {1, 2}})
    ->Args({64, 0, 2})
    ->Unit(benchmark::kMillisecond);

// Lost-in-space near many followed poses (the acquisition's chain, up to limits::
// kMaxLisCandidates): a cylindrical module with range(0) beacons, 8 random poses with >= 3
// beacons in view and 2 spurious blobs per camera; the prior holds the truth, the poses a cold
// search lists, then random poses in the module, range(1) in all, each within 0.1 m / 0.1 rad
// (a chain's bounds a few frame sets on). Its time should grow with the poses' own views, not
// with their union (which was the whole map). Counters: the search's cost units
// (LisResult::cost) and hypotheses, and the time per cost unit (the model's ~0.6 us).
void LostInSpaceFollowing(benchmark::State& state) {
  const int num_beacons = static_cast<int>(state.range(0));
  const int num_poses = static_cast<int>(state.range(1));
  static Rig rig;
  static auto lis = std::make_unique<LostInSpace>();
  static auto res = std::make_unique<LisResult>();
  static std::vector<testing::Scene> scenes;
  static std::vector<std::vector<BodyPose>> priors;
  std::mt19937_64 rng(950 + static_cast<std::uint64_t>(num_beacons));
  rig = testing::RandomCylinderRig(num_beacons, true, &rng);
  lis->Reset(rig);
  scenes.assign(8, testing::Scene{});
  priors.assign(scenes.size(), {});
  for (std::size_t k = 0; k < scenes.size(); ++k) {
    testing::Scene& sc = scenes[k];
    do testing::Observe(rig, testing::RandomCylinderPose(&rng), 0.2, &rng, &sc);
    while (sc.NumVisibleBeacons() < 3);
    testing::AddSpurious(rig, 2 * rig.num_cameras, &rng, &sc);
    lis->Identify(sc.blobs.data(), sc.num_blobs, LisOptions{}, res.get());
    std::vector<BodyPose>& p = priors[k];
    p.push_back(sc.pose);
    for (int i = 0; i < res->num_consistent && static_cast<int>(p.size()) < num_poses; ++i)
      p.push_back(res->consistent_poses[static_cast<std::size_t>(i)]);
    while (static_cast<int>(p.size()) < num_poses) p.push_back(testing::RandomCylinderPose(&rng));
    for (BodyPose& q : p) q.r_w_wb += Eigen::Vector3d(0.01, -0.01, 0.005);
  }
  std::size_t i = 0;
  double cost = 0.0, hypotheses = 0.0, frames = 0.0;
  for (auto _ : state) {
    const std::size_t k = i++ % scenes.size();
    const LisPrior prior{priors[k].data(), num_poses, 0.1, 0.1};
    lis->Identify(scenes[k].blobs.data(), scenes[k].num_blobs, LisOptions{}, res.get(), &prior);
    cost += res->cost;
    hypotheses += res->hypotheses;
    frames += 1.0;
  }
  state.counters["cost"] = cost / frames;
  state.counters["hypotheses"] = hypotheses / frames;
  state.counters["per_cost_unit"] = benchmark::Counter(cost, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(LostInSpaceFollowing)->ArgsProduct({{16, 64}, {1, 16, 64, 256}})->Unit(benchmark::kMillisecond);

// Start-up work on a map: FindMapRepeats (mfns-navd's check whether the map repeats itself) beside
// LostInSpace::Reset (the co-visibility table, the start-up work it joins) on the same maps: the
// random cylinder of LostInSpaceStation with range(0) beacons (range(1) = 0), or the same
// cylinder with its beacons on a regular grid of rings of 8 (range(1) = 1: every patch repeats,
// each beacon's scan ends at its first copy). Counter: beacons found in repeated patches.
Rig StartMap(int num_beacons, bool regular) {
  std::mt19937_64 rng(900 + static_cast<std::uint64_t>(num_beacons));
  Rig rig = testing::RandomCylinderRig(num_beacons, true, &rng);
  if (!regular) return rig;
  const int rings = num_beacons / 8;
  for (int m = 0; m < rings * 8; ++m) {
    const double angle = 2.0 * kPi * (m % 8) / 8.0, x = -3.0 + 6.0 * (m / 8) / (rings - 1);
    rig.beacons_w[static_cast<std::size_t>(m)] = Eigen::Vector3d(x, 2.1 * std::cos(angle), 2.1 * std::sin(angle));
    rig.beacon_normal_w[static_cast<std::size_t>(m)] = -Eigen::Vector3d(0.0, std::cos(angle), std::sin(angle));
  }
  rig.num_beacons = rings * 8;
  return rig;
}

void MapRepeatsAtStart(benchmark::State& state) {
  static Rig rig;
  rig = StartMap(static_cast<int>(state.range(0)), state.range(1) != 0);
  MapRepeatsResult r;
  for (auto _ : state) {
    FindMapRepeats(rig, MapRepeatsOptions{}, &r);
    benchmark::DoNotOptimize(r.repeated);
  }
  state.counters["repeated"] = r.repeated;
}
BENCHMARK(MapRepeatsAtStart)->ArgsProduct({{64, 256}, {0, 1}})->Unit(benchmark::kMillisecond);

void LostInSpaceReset(benchmark::State& state) {
  static Rig rig;
  rig = StartMap(static_cast<int>(state.range(0)), state.range(1) != 0);
  static auto lis = std::make_unique<LostInSpace>();
  for (auto _ : state) benchmark::DoNotOptimize(lis->Reset(rig));
}
BENCHMARK(LostInSpaceReset)->ArgsProduct({{64, 256}, {0, 1}})->Unit(benchmark::kMillisecond);

BENCHMARK_CAPTURE(LostInSpaceFrame, 4beacons, 4, 0)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(LostInSpaceFrame, 5beacons, 5, 0)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(LostInSpaceFrame, 3beacons_2spurious, 3, 2)->Unit(benchmark::kMillisecond);

// Tracking alone: from a known pose, frame sets 44-140 of the sweep (3-4 beacons each).
void TrackFrame(benchmark::State& state, int spurious) {
  static auto tracker = std::make_unique<Tracker>();
  static auto res = std::make_unique<TrackResult>();
  tracker->Reset(PaperRigOnce());
  const auto& v = Sweep(spurious);
  int f = 44, tracked = 0, frames = 0;
  tracker->SetPose(v[43].pose, 43 * kFrameNs);
  for (auto _ : state) {
    tracker->Track(v[static_cast<std::size_t>(f)].blobs.data(), v[static_cast<std::size_t>(f)].num_blobs,
                   static_cast<std::uint64_t>(f) * kFrameNs, TrackOptions{}, res.get());
    tracked += res->source == TrackSource::kTracked;
    ++frames;
    if (++f > 140) {
      state.PauseTiming();
      f = 44;
      tracker->SetPose(v[43].pose, 43 * kFrameNs);
      state.ResumeTiming();
    }
  }
  state.counters["tracked_fraction"] = frames > 0 ? static_cast<double>(tracked) / frames : 0.0;
}
BENCHMARK_CAPTURE(TrackFrame, clean, 0)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(TrackFrame, 2spurious, 2)->Unit(benchmark::kMicrosecond);

// The whole sweep as the flyer would see it, from a cold start: acquisition, tracking, gaps,
// re-identification; the mean per frame set.
void TrackSweep(benchmark::State& state, int spurious) {
  static auto tracker = std::make_unique<Tracker>();
  static auto res = std::make_unique<TrackResult>();
  tracker->Reset(PaperRigOnce());
  const auto& v = Sweep(spurious);
  std::uint64_t frame = 0;
  int accepted = 0, frames = 0;
  for (auto _ : state) {
    const auto& s = v[static_cast<std::size_t>(frame % 360)];
    tracker->Track(s.blobs.data(), s.num_blobs, frame * kFrameNs, TrackOptions{}, res.get());
    accepted += res->status != TrackStatus::kLost;
    ++frames;
    ++frame;
  }
  state.counters["accepted_fraction"] = frames > 0 ? static_cast<double>(accepted) / frames : 0.0;
}
BENCHMARK_CAPTURE(TrackSweep, clean, 0)->Unit(benchmark::kMicrosecond)->Iterations(1080);
BENCHMARK_CAPTURE(TrackSweep, 2spurious, 2)->Unit(benchmark::kMicrosecond)->Iterations(1080);

#ifdef MFNS_HAVE_OPENCV
// Baseline: OpenCV's iterative PnP on camera y's 4 points of one frame (the tracked case:
// an initial guess 1 deg off).
void OpenCvSolvePnP(benchmark::State& state) {
  const Rig& rig = PaperRigOnce();
  // Four beacons in camera y at the truth, at known pixels (the sweep rarely has 4 in one camera).
  const BodyPose truth = testing::YawPose(DegToRad(20.0));
  const RigCamera& cam = rig.cameras[1];
  const CameraIntrinsics& in = cam.intrinsics;
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  const Eigen::Vector2d spots[] = {{300, 250}, {1000, 800}, {950, 200}, {250, 850}};
  for (const auto& uv : spots) {
    Eigen::Vector2d x_n;
    Unproject(in, uv, &x_n);
    const Eigen::Vector3d P = truth.C_w_b * (cam.C_k_b.transpose() * (0.7 * Eigen::Vector3d(x_n.x(), x_n.y(), 1.0)) + cam.r_b_bk) + truth.r_w_wb;
    obj.emplace_back(P.x(), P.y(), P.z());
    img.emplace_back(uv.x(), uv.y());
  }
  const cv::Matx33d K(in.alpha_x, in.skew, in.u0, 0, in.alpha_y, in.v0, 0, 0, 1);
  const cv::Mat dist = (cv::Mat_<double>(1, 5) << in.kc[0], in.kc[1], in.kc[2], in.kc[3], in.kc[4]);
  const BodyPose start = testing::YawPose(DegToRad(21.0));
  const Eigen::Matrix3d C_k_w = cam.C_k_b * start.C_w_b.transpose();
  const Eigen::Vector3d t_k = -C_k_w * start.r_w_wb - cam.C_k_b * cam.r_b_bk;
  const Eigen::AngleAxisd aa(C_k_w);
  const cv::Vec3d rvec0(aa.axis().x() * aa.angle(), aa.axis().y() * aa.angle(), aa.axis().z() * aa.angle());
  const cv::Vec3d tvec0(t_k.x(), t_k.y(), t_k.z());
  cv::Vec3d rvec, tvec;
  for (auto _ : state) {
    rvec = rvec0;
    tvec = tvec0;
    cv::solvePnP(obj, img, K, dist, rvec, tvec, true, cv::SOLVEPNP_ITERATIVE);
    benchmark::DoNotOptimize(tvec[0]);
  }
}
BENCHMARK(OpenCvSolvePnP)->Unit(benchmark::kMicrosecond);
#endif  // MFNS_HAVE_OPENCV

// One P3P hypothesis, the unit of lost-in-space's work: three beacons along three blob rays.
// Ours is the generalised (multi-camera) P3P; OpenCV's is central, so the comparison uses three
// blobs of one camera (camera y, the same pixels and depths for both).
struct P3pCase {
  std::array<BlobObs, 3> blobs{};
  std::array<Eigen::Vector3d, 3> P_w{};
#ifdef MFNS_HAVE_OPENCV
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  cv::Matx33d K;
  cv::Mat dist;
#endif
};

P3pCase OneCameraP3pCase() {
  const Rig& rig = PaperRigOnce();
  const BodyPose truth = testing::YawPose(DegToRad(20.0));
  const RigCamera& cam = rig.cameras[1];
  const CameraIntrinsics& in = cam.intrinsics;
  P3pCase c;
  const Eigen::Vector2d spots[] = {{300, 250}, {1000, 800}, {950, 200}};
  const double depth[] = {0.6, 0.75, 0.9};
  for (int i = 0; i < 3; ++i) {
    const auto is = static_cast<std::size_t>(i);
    Eigen::Vector2d x_n;
    Unproject(in, spots[i], &x_n);
    c.blobs[is].camera = 1;
    c.blobs[is].uv_px = spots[i];
    c.blobs[is].x_n = x_n;
    c.P_w[is] = truth.C_w_b * (cam.C_k_b.transpose() * (depth[i] * Eigen::Vector3d(x_n.x(), x_n.y(), 1.0)) + cam.r_b_bk) + truth.r_w_wb;
#ifdef MFNS_HAVE_OPENCV
    c.obj.emplace_back(c.P_w[is].x(), c.P_w[is].y(), c.P_w[is].z());
    c.img.emplace_back(spots[i].x(), spots[i].y());
#endif
  }
#ifdef MFNS_HAVE_OPENCV
  c.K = cv::Matx33d(in.alpha_x, in.skew, in.u0, 0, in.alpha_y, in.v0, 0, 0, 1);
  c.dist = (cv::Mat_<double>(1, 5) << in.kc[0], in.kc[1], in.kc[2], in.kc[3], in.kc[4]);
#endif
  return c;
}

void P3pOneHypothesis(benchmark::State& state) {
  const Rig& rig = PaperRigOnce();
  const P3pCase c = OneCameraP3pCase();
  static P3pRayTriple triple;
  static std::array<BodyPose, limits::kMaxP3pSolutions> poses;
  int n = 0;
  for (auto _ : state) {
    const std::array<BodyRay, 3> rays = {RayOfBlob(rig, c.blobs[0]), RayOfBlob(rig, c.blobs[1]), RayOfBlob(rig, c.blobs[2])};
    triple.Set(rays, P3pOptions{});
    n = triple.Solve(c.P_w, &poses);
    benchmark::DoNotOptimize(poses[0].r_w_wb.data());
  }
  state.counters["solutions"] = n;
}
BENCHMARK(P3pOneHypothesis)->Unit(benchmark::kMicrosecond);

// Lost-in-space sets the ray triple once per blob triple and solves it for many beacon triples.
// separate_m > 0 moves rays 2 and 3's origins that far apart: the generalized (multi-camera)
// solve instead of the central one on the same rays and points (until 2026-12-03 the 1-D scan,
// benchmark name general_scan).
template <class Solver>
void SolveRays(benchmark::State& state, const std::array<BodyRay, 3>& rays, const std::array<Eigen::Vector3d, 3>& P_w) {
  static Solver triple;
  static std::array<BodyPose, limits::kMaxP3pSolutions> poses;
  triple.Set(rays, P3pOptions{});
  int n = 0;
  for (auto _ : state) {
    n = triple.Solve(P_w, &poses);
    benchmark::DoNotOptimize(poses[0].r_w_wb.data());
  }
  state.counters["solutions"] = n;
}

template <class Solver>
void P3pSolveOnlyWith(benchmark::State& state, double separate_m) {
  const Rig& rig = PaperRigOnce();
  const P3pCase c = OneCameraP3pCase();
  std::array<BodyRay, 3> rays = {RayOfBlob(rig, c.blobs[0]), RayOfBlob(rig, c.blobs[1]), RayOfBlob(rig, c.blobs[2])};
  rays[1].o_b.x() += separate_m;
  rays[2].o_b.y() += separate_m;
  SolveRays<Solver>(state, rays, c.P_w);
}

// One blob in each of the rig's three cameras (the same pixels as the one-camera case, the
// same depths along the rays): a cross-camera hypothesis proper. No OpenCV equivalent.
template <class Solver>
void P3pThreeCamerasWith(benchmark::State& state) {
  const Rig& rig = PaperRigOnce();
  const BodyPose truth = testing::YawPose(DegToRad(20.0));
  const Eigen::Vector2d spots[] = {{300, 250}, {1000, 800}, {950, 200}};
  const double depth[] = {0.6, 0.75, 0.9};
  std::array<BodyRay, 3> rays;
  std::array<Eigen::Vector3d, 3> P_w;
  for (std::size_t i = 0; i < 3; ++i) {
    BlobObs blob;
    blob.camera = static_cast<int>(i);
    blob.uv_px = spots[i];
    Unproject(rig.cameras[i].intrinsics, spots[i], &blob.x_n);
    rays[i] = RayOfBlob(rig, blob);
    P_w[i] = truth.C_w_b * (rays[i].o_b + depth[i] * rays[i].d_b) + truth.r_w_wb;
  }
  SolveRays<Solver>(state, rays, P_w);
}

void P3pSolveOnly(benchmark::State& state, double separate_m) { P3pSolveOnlyWith<P3pRayTriple>(state, separate_m); }
BENCHMARK_CAPTURE(P3pSolveOnly, central, 0.0)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(P3pSolveOnly, general, 1e-9)->Unit(benchmark::kMicrosecond);
void P3pThreeCameras(benchmark::State& state) { P3pThreeCamerasWith<P3pRayTriple>(state); }
BENCHMARK(P3pThreeCameras)->Unit(benchmark::kMicrosecond);

// The solver before 2026-12-03 (Grunert's quartic, the 128-step scan; p3p_scan_reference.h,
// test and benchmark only), in the same run.
void P3pScanReference(benchmark::State& state, double separate_m) {
  P3pSolveOnlyWith<scan_reference::ScanP3p>(state, separate_m);
}
BENCHMARK_CAPTURE(P3pScanReference, central, 0.0)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(P3pScanReference, general, 1e-9)->Unit(benchmark::kMicrosecond);
void P3pScanReferenceThreeCameras(benchmark::State& state) { P3pThreeCamerasWith<scan_reference::ScanP3p>(state); }
BENCHMARK(P3pScanReferenceThreeCameras)->Unit(benchmark::kMicrosecond);

#ifdef MFNS_HAVE_OPENCV
// Baseline: OpenCV's P3P (Gao et al., with undistortion of the three pixels) on the same case.
void OpenCvSolveP3P(benchmark::State& state) {
  const P3pCase c = OneCameraP3pCase();
  std::vector<cv::Mat> rvecs, tvecs;
  int n = 0;
  for (auto _ : state) {
    n = cv::solveP3P(c.obj, c.img, c.K, c.dist, rvecs, tvecs, cv::SOLVEPNP_P3P);
    benchmark::DoNotOptimize(n);
  }
  state.counters["solutions"] = n;
}
BENCHMARK(OpenCvSolveP3P)->Unit(benchmark::kMicrosecond);
#endif  // MFNS_HAVE_OPENCV

}  // namespace
}  // namespace mfns::fw

BENCHMARK_MAIN();
