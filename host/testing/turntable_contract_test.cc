// The contract between calibration and the simulator's calibration datasets: calibration's
// turntable kinematics (host/calib/core/kinematics.h) are the generator's (host/sim/scenario
// TurntablePose), so `mfns-sim calib-dataset` images are what `mfns-calib rig` models.
#include <gtest/gtest.h>

#include <random>

#include "common/rotation/rotation.h"
#include "host/calib/core/kinematics.h"
#include "host/sim/scenario/scenario.h"

namespace mfns::host {
namespace {

// The calibration's kinematics must be the generator's (host/sim/scenario TurntablePose).
TEST(Kinematics, BodyInWorldMatchesTheSimulatorsTurntable) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    Turntable tt;
    tt.C_w_t = ExpSO3(Eigen::Vector3d(u(rng), u(rng), u(rng)));
    tt.r_w_wt = Eigen::Vector3d(u(rng), u(rng), u(rng));
    tt.C_p_b = ExpSO3(0.1 * Eigen::Vector3d(u(rng), u(rng), u(rng)));
    tt.r_p_pb = 0.2 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    TurntableMount m{tt.C_w_t, tt.r_w_wt, tt.C_p_b, tt.r_p_pb};
    const double main = 3.0 * u(rng), aux = 1.5 * u(rng);
    const BodyPose ref = TurntablePose(tt, main, aux);
    const Transform b = BodyInWorld(m, main, aux);
    EXPECT_LT((b.C - ref.C_w_b).norm(), 1e-14);
    EXPECT_LT((b.r - ref.r_w_wb).norm(), 1e-14);
  }
}

}  // namespace
}  // namespace mfns::host
