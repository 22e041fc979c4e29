// Speed of the joint pose solve (SolvePose) beside OpenCV's cv::solvePnP (SOLVEPNP_ITERATIVE)
// on one camera's points of the same scene, in the same program.
//
//   build/<dir>/bin/solve_benchmark --benchmark_min_time=0.5
//
// Scenes: the paper rig (common/rig/paper_rig.h) at a fixed pose, with beacons placed at given
// pixels of given cameras 0.5-0.9 m deep, 0.2 px centroid noise; the solve starts 2 deg / 2 cm
// off the truth.
#include <benchmark/benchmark.h>

#include <array>
#include <random>
#include <vector>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "firmware/modules/solve/calibration_covariance.h"
#include "firmware/modules/solve/solve.h"
#include "firmware/modules/solve/synthetic_scene.h"

#ifdef MFNS_HAVE_OPENCV  // host builds; the aarch64 cross build has no OpenCV
#include <opencv2/calib3d.hpp>
#endif

namespace mfns::fw {
namespace {

struct Bench {
  Rig rig;
  testing::Scene scene;
  std::array<Match, limits::kMaxMatches> matches{};
  int n = 0;
  BodyPose truth, start;
};

// per_camera[k] beacons in camera k, spread over the image.
const Bench& MakeBench(const std::array<int, 3>& per_camera) {
  static Bench b;
  b.rig = PaperRig();
  b.rig.num_beacons = 0;
  b.truth.C_w_b = EulerToMatrix({DegToRad(3.0), DegToRad(-4.0), DegToRad(37.0)}).transpose();
  b.truth.r_w_wb = Eigen::Vector3d(0.02, -0.03, 0.01);
  const Eigen::Vector2d spots[] = {{300, 250}, {1000, 800}, {950, 200}, {250, 850}, {640, 520},
                                   {500, 700}, {150, 500}, {1150, 450}, {700, 100}, {800, 950}};
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < per_camera[static_cast<std::size_t>(k)]; ++j) {
      const RigCamera& cam = b.rig.cameras[static_cast<std::size_t>(k)];
      Eigen::Vector2d x_n;
      Unproject(cam.intrinsics, spots[j], &x_n);
      const Eigen::Vector3d p_b = cam.C_k_b.transpose() * ((0.5 + 0.08 * (j + k)) * Eigen::Vector3d(x_n.x(), x_n.y(), 1.0)) + cam.r_b_bk;
      b.rig.beacons_w[static_cast<std::size_t>(b.rig.num_beacons++)] = b.truth.C_w_b * p_b + b.truth.r_w_wb;
    }
  }
  std::mt19937_64 rng(1);
  testing::Observe(b.rig, b.truth, 0.2, &rng, &b.scene);
  b.n = 0;
  for (int i = 0; i < b.scene.num_blobs; ++i)
    b.matches[static_cast<std::size_t>(b.n++)] =
        Match{i, b.scene.truth_beacon[static_cast<std::size_t>(i)], b.scene.blobs[static_cast<std::size_t>(i)].camera};
  Eigen::Matrix<double, 6, 1> d;
  d << 0.02, -0.01, 0.01, DegToRad(1.5), DegToRad(-1.0), DegToRad(1.0);
  b.start = Retract(b.truth, d);
  return b;
}

void SolveJoint(benchmark::State& state, std::array<int, 3> split) {
  const Bench& b = MakeBench(split);
  static SolveResult r;
  for (auto _ : state) {
    SolvePose(b.rig, b.scene.blobs.data(), b.scene.num_blobs, b.matches.data(), b.n, b.start, SolveOptions{}, &r);
    benchmark::DoNotOptimize(r.pose.r_w_wb.data());
  }
  state.counters["observations"] = b.n;
  state.counters["solver_iterations"] = r.iterations;  // ("iterations" is Google Benchmark's own field)
  state.counters["error_mm"] = (r.pose.r_w_wb - b.truth.r_w_wb).norm() * 1e3;
}
BENCHMARK_CAPTURE(SolveJoint, 3obs_1_1_1, std::array<int, 3>{1, 1, 1});
BENCHMARK_CAPTURE(SolveJoint, 3obs_2_1_0, std::array<int, 3>{2, 1, 0});
BENCHMARK_CAPTURE(SolveJoint, 6obs_2_2_2, std::array<int, 3>{2, 2, 2});
BENCHMARK_CAPTURE(SolveJoint, 10obs_4_3_3, std::array<int, 3>{4, 3, 3});
BENCHMARK_CAPTURE(SolveJoint, 4obs_one_camera, std::array<int, 3>{4, 0, 0});
BENCHMARK_CAPTURE(SolveJoint, 6obs_one_camera, std::array<int, 3>{6, 0, 0});
BENCHMARK_CAPTURE(SolveJoint, 10obs_one_camera, std::array<int, 3>{10, 0, 0});

// The calibration's covariance navd adds to a published pose (calibration_covariance.h), at the
// solved pose of the same scene: the paper rig carries Table 2's 1-sigma for every camera.
void CalibrationCovarianceAtFix(benchmark::State& state, std::array<int, 3> split) {
  const Bench& b = MakeBench(split);
  SolveResult r;
  SolvePose(b.rig, b.scene.blobs.data(), b.scene.num_blobs, b.matches.data(), b.n, b.start, SolveOptions{}, &r);
  Eigen::Matrix<double, 6, 6> cov;
  for (auto _ : state) {
    CalibrationCovariance(b.rig, b.scene.blobs.data(), b.scene.num_blobs, b.matches.data(), b.n, r.pose, SolveOptions{}, &cov);
    benchmark::DoNotOptimize(cov.data());
  }
  state.counters["observations"] = b.n;
}
BENCHMARK_CAPTURE(CalibrationCovarianceAtFix, 6obs_2_2_2, std::array<int, 3>{2, 2, 2});
BENCHMARK_CAPTURE(CalibrationCovarianceAtFix, 10obs_4_3_3, std::array<int, 3>{4, 3, 3});

#ifdef MFNS_HAVE_OPENCV
// OpenCV on camera x's points alone: its pose is the camera's (world -> camera x).
void OpenCvSolvePnP(benchmark::State& state, int n_points, bool use_guess) {
  const Bench& b = MakeBench({n_points, 0, 0});
  const RigCamera& cam = b.rig.cameras[0];
  const CameraIntrinsics& in = cam.intrinsics;
  const cv::Matx33d K(in.alpha_x, in.skew, in.u0, 0, in.alpha_y, in.v0, 0, 0, 1);
  const cv::Mat dist = (cv::Mat_<double>(1, 5) << in.kc[0], in.kc[1], in.kc[2], in.kc[3], in.kc[4]);
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  for (int i = 0; i < b.scene.num_blobs; ++i) {
    const Eigen::Vector3d& P = b.rig.beacons_w[static_cast<std::size_t>(b.scene.truth_beacon[static_cast<std::size_t>(i)])];
    obj.emplace_back(P.x(), P.y(), P.z());
    img.emplace_back(b.scene.blobs[static_cast<std::size_t>(i)].uv_px.x(), b.scene.blobs[static_cast<std::size_t>(i)].uv_px.y());
  }
  // The initial guess: the start pose as camera x's extrinsics.
  const Eigen::Matrix3d C_k_w = cam.C_k_b * b.start.C_w_b.transpose();
  const Eigen::Vector3d t_k = -C_k_w * b.start.r_w_wb - cam.C_k_b * cam.r_b_bk;
  const Eigen::AngleAxisd aa(C_k_w);
  const cv::Vec3d rvec0(aa.axis().x() * aa.angle(), aa.axis().y() * aa.angle(), aa.axis().z() * aa.angle());
  const cv::Vec3d tvec0(t_k.x(), t_k.y(), t_k.z());
  cv::Vec3d rvec, tvec;
  for (auto _ : state) {
    rvec = rvec0;
    tvec = tvec0;
    cv::solvePnP(obj, img, K, dist, rvec, tvec, use_guess, cv::SOLVEPNP_ITERATIVE);
    benchmark::DoNotOptimize(tvec[0]);
  }
  state.counters["observations"] = static_cast<double>(obj.size());
}
// (SOLVEPNP_ITERATIVE needs >= 4 points; 3 observations have no OpenCV counterpart here.)
BENCHMARK_CAPTURE(OpenCvSolvePnP, 4obs_guess, 4, true);
BENCHMARK_CAPTURE(OpenCvSolvePnP, 6obs_guess, 6, true);
BENCHMARK_CAPTURE(OpenCvSolvePnP, 6obs_no_guess, 6, false);
BENCHMARK_CAPTURE(OpenCvSolvePnP, 10obs_guess, 10, true);
BENCHMARK_CAPTURE(OpenCvSolvePnP, 10obs_no_guess, 10, false);
#endif  // MFNS_HAVE_OPENCV

}  // namespace
}  // namespace mfns::fw

BENCHMARK_MAIN();
