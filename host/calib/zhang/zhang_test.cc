// Zhang's intrinsics (cv::calibrateCamera) against the truth, and the joint solver run on
// free views only (Zhang's maximum-likelihood problem) against cv::calibrateCamera on the
// same corners: the two must agree.
#include "host/calib/zhang/zhang.h"

#include <gtest/gtest.h>

#include <cmath>

#include "host/calib/ml/joint.h"
#include "host/testing/synth_calib.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

std::vector<std::vector<CornerObs>> CameraViews(const CalibInput& in, int camera) {
  std::vector<std::vector<CornerObs>> views;
  for (const ViewObservation& v : in.views)
    if (v.camera == camera) views.push_back(v.corners);
  return views;
}

TEST(Zhang, IntrinsicsWithinFourSigmaOfTheTruth) {
  SynthOptions so;
  so.seed = 4;
  const SynthScene scene = MakeSynthScene(so);
  const CalibInput in = SynthCorners(scene, 0.1, 4);
  for (int k = 0; k < 3; ++k) {
    const CameraIntrinsics& truth = scene.rig.cameras[static_cast<std::size_t>(k)].intrinsics;
    const ZhangResult z = CalibrateZhang(CameraViews(in, k), in.target_points, truth.width, truth.height);
    EXPECT_NEAR(z.rms_px, 0.1 * std::sqrt(2.0), 0.02);
    EXPECT_EQ(z.views.size(), 21u);
    const CameraParamVector e = z.camera.ToVector() - truth.ToVector();
    for (int i : {kAlphaX, kAlphaY, kU0, kV0, kKc1, kKc2, kKc3, kKc4}) {
      ASSERT_GT(z.sigma[i], 0.0);
      EXPECT_LT(std::abs(e[i]), 4.0 * z.sigma[i]) << "camera " << k << " parameter " << i;
    }
    EXPECT_EQ(z.sigma[kSkew], 0.0);
    EXPECT_EQ(z.sigma[kKc5], 0.0);
    EXPECT_EQ(z.camera.kc[4], 0.0);
  }
}

TEST(Zhang, FreeK3IsEstimated) {
  SynthOptions so;
  so.seed = 5;
  const SynthScene scene = MakeSynthScene(so);
  const CalibInput in = SynthCorners(scene, 0.05, 5);
  const CameraIntrinsics& truth = scene.rig.cameras[0].intrinsics;
  ZhangOptions zo;
  zo.fix_k3 = false;
  const ZhangResult z = CalibrateZhang(CameraViews(in, 0), in.target_points, truth.width, truth.height, zo);
  EXPECT_GT(z.sigma[kKc5], 0.0);
  EXPECT_LT(std::abs(z.camera.kc[4]), 4.0 * z.sigma[kKc5]);
}

TEST(Zhang, TooFewViewsIsAUserError) {
  const CalibInput in = SynthCorners(MakeSynthScene(SynthOptions{}), 0.1, 1);
  std::vector<std::vector<CornerObs>> views = CameraViews(in, 0);
  views.resize(2);
  EXPECT_THROW(CalibrateZhang(views, in.target_points, 1280, 1024), UserError);
}

// Item 6: intrinsics-only results agree with cv::calibrateCamera on the same corners.
TEST(Zhang, JointSolverOnFreeViewsAgreesWithCalibrateCamera) {
  SynthOptions so;
  so.seed = 6;
  const SynthScene scene = MakeSynthScene(so);
  CalibInput all = SynthCorners(scene, 0.1, 6);
  for (int k = 0; k < 3; ++k) {
    CalibInput in = all;
    in.cameras = {all.cameras[static_cast<std::size_t>(k)]};
    in.views.clear();
    for (ViewObservation v : all.views)
      if (v.camera == k) {
        v.camera = 0;
        v.kind = ImageKind::kFree;
        in.views.push_back(v);
      }
    const ZhangResult z = CalibrateZhang(CameraViews(in, 0), in.target_points, in.cameras[0].width, in.cameras[0].height);
    MlStart start;
    CameraIntrinsics perturbed = z.camera;
    perturbed.alpha_x *= 1.01;  // start away from OpenCV's answer
    perturbed.u0 += 3.0;
    start.intrinsics = {perturbed};
    start.C_k_b = {Eigen::Matrix3d::Identity()};
    start.r_b_bk = {Eigen::Vector3d::Zero()};
    for (const ZhangView& zv : z.views) start.view_T_w_k.push_back({zv.C_k_w.transpose(), zv.r_w_wk});
    start.sigma_px = {0.1};
    MlOptions mo;
    mo.huber_px = 0.0;  // plain least squares, as OpenCV
    const RigCalibration ml = SolveJointMl(in, start, mo);
    const CameraParamVector a = ml.cameras[0].intrinsics.ToVector(), b = z.camera.ToVector();
    for (int i : {kAlphaX, kAlphaY, kU0, kV0, kKc1, kKc2, kKc3, kKc4}) {
      EXPECT_LT(std::abs(a[i] - b[i]), 0.01 * z.sigma[i]) << "camera " << k << " parameter " << i;
      EXPECT_NEAR(ml.cameras[0].sigma_intrinsics[i] / z.sigma[i], 1.0, 0.02) << "camera " << k << " parameter " << i;
    }
    EXPECT_NEAR(ml.rms_px, z.rms_px, 1e-4);
  }
}

}  // namespace
}  // namespace mfns::host
