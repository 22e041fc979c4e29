// The 180-degree ambiguity of symmetric boards settled by the turntable kinematics, through
// the calibration's first stage (PrepareViews, host/calib/app, which calls ResolveOrientation).
#include "host/calib/ml/orientation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>

#include "common/rotation/rotation.h"
#include "host/calib/app/calibrate.h"
#include "host/testing/synth_calib.h"

namespace mfns::host {
namespace {

// Half the turntable views relabelled by the board's half turn and every view flagged
// ambiguous (a 9x7 board): the orientation step restores the true labels.
TEST(Orientation, SymmetricBoardLabelsAgreeWithTheKinematics) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    SynthOptions so;
    so.seed = seed;
    const SynthScene scene = MakeSynthScene(so);
    const CalibInput truth = SynthCorners(scene, 0.1, seed);
    CalibInput in = truth;
    std::mt19937_64 rng(seed);
    const int n = static_cast<int>(in.target_points.size());
    for (ViewObservation& v : in.views) {
      v.orientation_ambiguous = true;
      if (rng() % 2) {
        for (CornerObs& c : v.corners) c.id = n - 1 - c.id;
        std::sort(v.corners.begin(), v.corners.end(), [](const CornerObs& a, const CornerObs& b) { return a.id < b.id; });
      }
    }
    PrepareViews(&in, RigOptions{});
    for (std::size_t v = 0; v < in.views.size(); ++v) {
      if (in.views[v].kind != ImageKind::kTurntable) continue;
      EXPECT_FALSE(in.views[v].orientation_ambiguous);
      ASSERT_EQ(in.views[v].corners.size(), truth.views[v].corners.size());
      EXPECT_EQ(in.views[v].corners.front().id, truth.views[v].corners.front().id) << "seed " << seed << " view " << v;
      EXPECT_LT((in.views[v].corners.front().uv - truth.views[v].corners.front().uv).norm(), 1e-12);
    }
  }
}

}  // namespace
}  // namespace mfns::host
