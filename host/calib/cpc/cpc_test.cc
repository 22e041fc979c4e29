#include "host/calib/cpc/cpc.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/rotation/rotation.h"
#include "host/calib/app/calibrate.h"
#include "host/calib/report/compare.h"
#include "host/testing/synth_calib.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

// Element (r, c), 1-based as in the paper, of the row-major design.
Eigen::Matrix<double, 1, 6> Row(const Eigen::Matrix<double, 9, 6>& D, int r, int c) { return D.row(3 * (r - 1) + (c - 1)); }

// The design matrix reproduces eq. A10 as printed: its rows for an image turned by Omega about
// Zt (A8) and by omega about Xt (A9), unknowns (alpha, beta, gamma, phi, theta, psi).
TEST(Cpc, DesignMatchesTheRowsOfA10) {
  for (double a : {0.0, 0.2, -0.7, 1.3}) {
    const double s = std::sin(a), c = std::cos(a);
    const Eigen::Matrix<double, 9, 6> Dm = SmallAngleDesign(PlatformRotation(a, 0.0));
    Eigen::Matrix<double, 4, 6> A10m;
    A10m << -s, c, 0, 0, 1, 0,   // C_z'31
        -c, -s, 0, -1, 0, 0,     // C_z'32
        0, -1, 0, -s, -c, 0,     // C_z'13
        1, 0, 0, c, -s, 0;       // C_z'23
    EXPECT_LT((Row(Dm, 3, 1) - A10m.row(0)).norm(), 1e-15);
    EXPECT_LT((Row(Dm, 3, 2) - A10m.row(1)).norm(), 1e-15);
    EXPECT_LT((Row(Dm, 1, 3) - A10m.row(2)).norm(), 1e-15);
    EXPECT_LT((Row(Dm, 2, 3) - A10m.row(3)).norm(), 1e-15);
    const Eigen::Matrix<double, 9, 6> Da = SmallAngleDesign(PlatformRotation(0.0, a));
    Eigen::Matrix<double, 4, 6> A10a;
    A10a << 0, -s, c, 0, 0, 1,   // C_z''12
        0, -c, -s, 0, -1, 0,     // C_z''13
        0, 0, -1, 0, -s, -c,     // C_z''21
        0, 1, 0, 0, c, -s;       // C_z''31
    EXPECT_LT((Row(Da, 1, 2) - A10a.row(0)).norm(), 1e-15);
    EXPECT_LT((Row(Da, 1, 3) - A10a.row(1)).norm(), 1e-15);
    EXPECT_LT((Row(Da, 2, 1) - A10a.row(2)).norm(), 1e-15);
    EXPECT_LT((Row(Da, 3, 1) - A10a.row(3)).norm(), 1e-15);
  }
}

// A7 -> A8: the linear model is the first-order part of (I - [a]x) N (I - [c]x) with the Euler
// matrices of eqs. A2, A3: the remainder is second order in the small angles.
TEST(Cpc, LinearModelIsFirstOrder) {
  const Eigen::Matrix3d N = PlatformRotation(0.3, -0.2);
  for (double scale : {1e-2, 1e-3}) {
    Eigen::Matrix<double, 6, 1> x;
    x << 0.3, -0.5, 0.8, -0.4, 0.6, 0.9;
    x *= scale;
    const Eigen::Matrix3d M = EulerToMatrix({x[0], x[1], x[2]}) * N * EulerToMatrix({x[3], x[4], x[5]});
    const Eigen::Matrix<double, 9, 1> lin = SmallAngleDesign(N) * x;
    Eigen::Matrix<double, 9, 1> exact;
    for (int e = 0; e < 9; ++e) exact[e] = M(e / 3, e % 3) - N(e / 3, e % 3);
    EXPECT_LT((exact - lin).norm(), 2.0 * x.squaredNorm()) << scale;
    EXPECT_GT((exact - lin).norm(), 1e-3 * x.squaredNorm()) << scale;  // and not exact: A8 drops terms
  }
}

// Without pixel noise the paper's method is off only by its small-angle model and the
// commanded angles' 8 arcsec: within a few hundredths of a degree and tenths of a mm. With
// the paper's single-axis images (A8, A9) and with two-axis images.
TEST(Cpc, NoiselessDataWithinTheSmallAngleError) {
  for (bool single_axis : {true, false}) {
    SynthOptions so;
    so.seed = 8;
    so.single_axis = single_axis;
    const SynthScene scene = MakeSynthScene(so);
    CalibInput in = SynthCorners(scene, 0.0, 8);
    RigOptions ro;
    ro.method = RigMethod::kPaper;
    const RigCalibration rig = CalibrateRig(&in, ro);
    const RigErrors e = CompareRig(rig, scene.rig, &scene.mount);
    for (const CameraError& c : e.cameras) {
      EXPECT_LT(c.rotation_deg, 0.03) << c.name << " single_axis " << single_axis;
      EXPECT_LT(c.position_mm, 0.5) << c.name << " single_axis " << single_axis;
    }
    EXPECT_LT(e.C_w_t_deg, 0.03);
    bool used_paper_rows = false;
    for (const std::string& n : rig.notes) used_paper_rows = used_paper_rows || n.find(" 0 single-axis") == std::string::npos;
    EXPECT_EQ(used_paper_rows, single_axis);
  }
}

TEST(Cpc, NeedsTheReferenceCamera) {
  const SynthScene scene = MakeSynthScene(SynthOptions{});
  CalibInput in = SynthCorners(scene, 0.1, 1);
  RigOptions ro;
  ro.method = RigMethod::kPaper;
  ro.reference_camera = "w";
  EXPECT_THROW(CalibrateRig(&in, ro), UserError);
}

}  // namespace
}  // namespace mfns::host
