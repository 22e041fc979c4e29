// The closed-form hand-eye start of --method ml (and OpenCV's) on noiseless synthetic corners,
// the views' poses from the calibration's own first stage (PrepareViews, host/calib/app).
#include "host/calib/ml/hand_eye.h"

#include <gtest/gtest.h>

#include <vector>

#include "common/rotation/rotation.h"
#include "host/calib/app/calibrate.h"
#include "host/testing/synth_calib.h"

namespace mfns::host {
namespace {

TEST(HandEye, ClosedFormsAreExactWithoutNoise) {
  SynthOptions so;
  so.seed = 2;
  const SynthScene scene = MakeSynthScene(so);
  CalibInput in = SynthCorners(scene, 0.0, 2);
  RigOptions ro;
  const IntrinsicsStage st = PrepareViews(&in, ro);
  std::vector<HandEyeView> all;
  for (std::size_t v = 0; v < in.views.size(); ++v)
    if (in.views[v].kind == ImageKind::kTurntable)
      all.push_back({in.views[v].camera, in.views[v].main_cmd, in.views[v].aux_cmd, st.view_T_w_k[v]});
  // Commanded angles differ from the true ones by 8 arcsec, so "exact" is within a few of those.
  const HandEyeResult he = SolveHandEyeLinear(all, 3, in.C_p_b, in.r_p_pb);
  EXPECT_LT(RotationAngle(he.C_w_t * scene.mount.C_w_t.transpose()), DegToRad(0.003));
  EXPECT_LT((he.r_w_wt - scene.mount.r_w_wt).norm(), 0.05e-3);
  for (int k = 0; k < 3; ++k) {
    const RigCamera& t = scene.rig.cameras[static_cast<std::size_t>(k)];
    EXPECT_LT(RotationAngle(he.C_k_b[static_cast<std::size_t>(k)] * t.C_k_b.transpose()), DegToRad(0.005)) << k;
    EXPECT_LT((he.r_b_bk[static_cast<std::size_t>(k)] - t.r_b_bk).norm(), 0.1e-3) << k;
    // OpenCV's robot-world hand-eye per camera on the same poses.
    std::vector<HandEyeView> one;
    for (const HandEyeView& h : all)
      if (h.camera == k) one.push_back(h);
    const HandEyeResult cv = SolveHandEyeOpenCv(one, 3, in.C_p_b, in.r_p_pb);
    EXPECT_LT(RotationAngle(cv.C_k_b[static_cast<std::size_t>(k)] * t.C_k_b.transpose()), DegToRad(0.02)) << k;
    EXPECT_LT((cv.r_b_bk[static_cast<std::size_t>(k)] - t.r_b_bk).norm(), 0.5e-3) << k;
  }
}

}  // namespace
}  // namespace mfns::host
