// Issue 18 item 5 through the navigator mfns-navd runs (fw::Navigator): the rig it gets is off
// by a calibration error drawn from the 1-sigma that rig carries (Rig::has_sigma, as the
// parameter blob carries it), on blob-level simulated flights of three scenarios. The published
// covariance with the calibration's part (NavigatorOptions::fold_calibration_sigma) is honest
// over the flights (mean NEES of the fixes near 6, the chi-square's mean); without it the same
// fixes claim several times too small an error.
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <random>
#include <vector>

#include "common/rotation/rotation.h"
#include "firmware/app/navd/navigator.h"
#include "host/sim/navmatrix/matrix.h"
#include "host/sim/navmatrix/navmatrix.h"
#include "host/sim/observe/observe.h"
#include "host/sim/scenario/scenario.h"

namespace mfns::host {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// Every camera's calibration 1-sigma (as mfns-calib writes it into rig.yaml), large enough to
// dominate the scenarios' map error, and the believed rig off by a draw of it.
Rig Miscalibrated(Rig rig, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  rig.has_sigma = true;
  for (int k = 0; k < rig.num_cameras; ++k) {
    const auto sk = static_cast<std::size_t>(k);
    RigCameraSigma& s = rig.sigma[sk];
    s.euler = Eigen::Vector3d::Constant(DegToRad(0.02));
    s.r_b_bk = Eigen::Vector3d::Constant(0.3e-3);
    s.intrinsics = {0.5, 0.5, 0.0, 0.3, 0.3};
    s.distortion = {1e-3, 1e-3, 1e-5, 1e-5, 0.0};
    RigCamera& cam = rig.cameras[sk];
    EulerAngles e = MatrixToEuler(cam.C_k_b);
    e.phi += s.euler[0] * n(rng);
    e.theta += s.euler[1] * n(rng);
    e.psi += s.euler[2] * n(rng);
    cam.C_k_b = EulerToMatrix(e);
    for (int j = 0; j < 3; ++j) cam.r_b_bk[j] += s.r_b_bk[j] * n(rng);
    CameraParamVector v = cam.intrinsics.ToVector();
    for (int j = 0; j < 5; ++j) v[j] += s.intrinsics[static_cast<std::size_t>(j)] * n(rng);
    for (int j = 0; j < 5; ++j) v[5 + j] += s.distortion[static_cast<std::size_t>(j)] * n(rng);
    cam.intrinsics.SetFromVector(v);
  }
  return rig;
}

struct Nees {
  double sum = 0.0;
  int fixes = 0;
  double Mean() const { return fixes > 0 ? sum / fixes : 0.0; }
};

// Mean NEES of the fixes of one flight, the navigator started at the first true pose.
Nees Fly(const Scenario& scenario, const std::vector<FrameTruth>& truth, const std::vector<BlobFrameSet>& blobs,
         const Rig& rig, bool fold) {
  auto nav = std::make_unique<fw::Navigator>();
  NavMatrixOptions o;
  o.navigator.fold_calibration_sigma = fold;
  const char* why = nullptr;
  EXPECT_TRUE(nav->Init(rig, o.navigator, &why)) << why;
  nav->SetInitialPose(truth.front().pose, 0.01, 0.01);
  auto out = std::make_unique<fw::NavOutput>();
  Nees r;
  for (std::size_t i = 0; i < blobs.size(); ++i) {
    const BlobFrameSet& b = blobs[i];
    std::uint32_t delivered = 0;
    for (int k = 0; k < rig.num_cameras; ++k) delivered |= b.delivered[static_cast<std::size_t>(k)] ? 1U << k : 0U;
    nav->Step(b.blobs.data(), static_cast<int>(b.blobs.size()), static_cast<std::uint64_t>(truth[i].t_ns), delivered,
              false, out.get());
    if (out->status != fw::NavStatus::kFix) continue;
    Vector6d e;
    e << out->pose.r_w_wb - truth[i].pose.r_w_wb, LogSO3(truth[i].pose.C_w_b.transpose() * out->pose.C_w_b);
    r.sum += e.dot(out->covariance.ldlt().solve(e));
    ++r.fixes;
  }
  (void)scenario;
  return r;
}

TEST(CalibrationSigmaNavTest, PublishedCovarianceCountsTheCalibrationError) {
  const char* presets[] = {"paper-turntable", "free-flight", "station-box"};
  for (const char* preset : presets) {
    double with = 0.0, without = 0.0;
    int flights = 0;
    for (std::uint64_t seed = 1; seed <= 4; ++seed) {
      RunSpec spec{.preset = preset, .count = std::string(preset) == "station-box" ? 64 : 0, .seed = seed, .frames = 200};
      const Scenario scenario = MatrixScenario(spec);
      const std::vector<FrameTruth> truth = SimulateTrajectory(scenario);
      std::vector<BlobFrameSet> blobs;
      for (const FrameTruth& t : truth) blobs.push_back(SimulateBlobs(scenario, t));
      const Rig rig = Miscalibrated(BelievedRig(scenario), 100 + seed);
      const Nees a = Fly(scenario, truth, blobs, rig, true), b = Fly(scenario, truth, blobs, rig, false);
      std::printf("%s seed %d: %d fixes, mean NEES %.2f with the calibration's covariance, %.2f without (%d fixes)\n",
                  preset, static_cast<int>(seed), a.fixes, a.Mean(), b.Mean(), b.fixes);
      if (a.fixes < 10) continue;
      with += a.Mean();
      without += b.Mean();
      ++flights;
    }
    EXPECT_GE(flights, 3) << preset;
    if (flights == 0) continue;
    with /= flights;
    without /= flights;
    std::printf("%s: mean NEES over %d flights %.2f with, %.2f without\n", preset, flights, with, without);
    // Each flight is one calibration draw (its fixes' errors are correlated): the mean over a
    // few flights is near 6 but loosely.
    EXPECT_GT(with, 2.0) << preset;
    EXPECT_LT(with, 12.0) << preset;
    EXPECT_GT(without, 3.0 * with) << preset;
  }
}

}  // namespace
}  // namespace mfns::host
