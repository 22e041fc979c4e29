#include "firmware/app/navd/nav_loop.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <vector>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "firmware/lib/in_process_source.h"
#include "firmware/modules/detect/detect_testing.h"
#include "firmware/modules/solve/testing_alloc.h"

namespace mfns::fw {
namespace {

// The paper rig shrunk to 320x256 cameras (same field of view) so that thousands of frame
// sets stay fast, also under qemu.
Rig SmallRig() {
  Rig rig = PaperRig();
  for (int k = 0; k < rig.num_cameras; ++k) {
    CameraIntrinsics& c = rig.cameras[static_cast<std::size_t>(k)].intrinsics;
    c.width = 320;
    c.height = 256;
    c.alpha_x /= 4;
    c.alpha_y /= 4;
    c.u0 = (c.u0 + 0.5) / 4 - 0.5;
    c.v0 = (c.v0 + 0.5) / 4 - 0.5;
  }
  return rig;
}

// Pre-rendered mono8 frames of a yaw sweep: frames[set][camera].
struct Sweep {
  std::vector<std::vector<std::vector<std::uint8_t>>> frames;
  std::vector<int> visible;
};

Sweep RenderSweep(const Rig& rig, int sets, double step_deg) {
  Sweep s;
  for (int i = 0; i < sets; ++i) {
    BodyPose pose;
    pose.C_w_b = R3(DegToRad(i * step_deg)).transpose();
    std::vector<std::vector<std::uint8_t>> cams;
    int visible = 0;
    for (int k = 0; k < rig.num_cameras; ++k) {
      const RigCamera& cam = rig.cameras[static_cast<std::size_t>(k)];
      testing::SyntheticImage img(cam.intrinsics.width, cam.intrinsics.height);
      img.AddBackground(10.0);
      for (int b = 0; b < rig.num_beacons; ++b) {
        Eigen::Vector2d uv;
        if (ProjectBeacon(cam, pose, rig.beacons_w[static_cast<std::size_t>(b)], &uv) != ProjectStatus::kOk ||
            !InImage(cam.intrinsics, uv, 3.0))
          continue;
        ++visible;
        img.AddSpot({uv.x(), uv.y(), 1.0, 1.0, 1200.0});
      }
      std::vector<std::uint8_t> bytes(img.value.size());
      for (std::size_t p = 0; p < bytes.size(); ++p)
        bytes[p] = static_cast<std::uint8_t>(std::clamp(std::lround(img.value[p]), 0L, 255L));
      cams.push_back(std::move(bytes));
    }
    s.frames.push_back(std::move(cams));
    s.visible.push_back(visible);
  }
  return s;
}

FrameView View(const Rig& rig, int k, const std::vector<std::uint8_t>& bytes, std::uint64_t t_ns, std::uint32_t seq) {
  FrameView v;
  v.data = bytes.data();
  v.width = rig.cameras[static_cast<std::size_t>(k)].intrinsics.width;
  v.height = rig.cameras[static_cast<std::size_t>(k)].intrinsics.height;
  v.stride_bytes = v.width;
  v.format = PixelFormat::kMono8;
  v.t_capture_ns = t_ns;
  v.sequence = seq;
  v.camera = k;
  return v;
}

NavLoopConfig Config() {
  NavLoopConfig c;
  c.sigma_px = 0.05;
  c.health_every = 5;
  c.camera_retry_every = 4;
  return c;
}

long FrameSetsForAllocationTest() {
  const char* fast = std::getenv("MFNS_FAST_TESTS");
#ifdef MFNS_FAST_TESTS_DEFAULT
  const bool fast_default = true;
#else
  const bool fast_default = false;
#endif
  const bool is_fast = fast != nullptr ? std::string(fast) != "0" : fast_default;
  return is_fast ? 1000 : 10000;
}

// Issue 4: no heap after start, counted over 10,000 frame sets (1,000 in fast mode: qemu).
TEST(NavLoop, NoAllocationAfterStartAndFixesFromImages) {
  const Rig rig = SmallRig();
  const Sweep sweep = RenderSweep(rig, 36, 10.0);
  InProcessSource source(rig.num_cameras);
  ASSERT_EQ(source.Start(), SourceStatus::kOk);
  auto loop = std::make_unique<NavLoop>(rig, &source, nullptr, nullptr, nullptr);
  const char* why = nullptr;
  ASSERT_TRUE(loop->Configure(Config(), &why)) << why;

  const long sets = FrameSetsForAllocationTest();
  const long before = testing_alloc::Count();
  int fixes_3plus = 0, sets_3plus = 0, fix_errors = 0;
  PoseRecord rec;
  for (long n = 0; n < sets; ++n) {
    const std::size_t i = static_cast<std::size_t>(n % 36);
    for (int k = 0; k < rig.num_cameras; ++k)
      ASSERT_TRUE(source.Push(k, View(rig, k, sweep.frames[i][static_cast<std::size_t>(k)],
                                      1'000'000'000ull + static_cast<std::uint64_t>(n) * 53763441ull,
                                      static_cast<std::uint32_t>(n))));
    ASSERT_EQ(loop->Step(&rec), StepStatus::kOk);
    if (sweep.visible[i] >= 3) {
      ++sets_3plus;
      if (rec.status == NavStatus::kFix) {
        ++fixes_3plus;
        const EulerAngles e = MatrixToEuler(rec.q_w_b.toRotationMatrix().transpose());
        if (rec.r_w_wb.norm() > 0.02 || std::abs(std::remainder(RadToDeg(e.psi) - 10.0 * static_cast<double>(i), 360.0)) > 1.0)
          ++fix_errors;
      }
    }
  }
  EXPECT_EQ(testing_alloc::Count() - before, 0) << "heap allocations after start";
  EXPECT_EQ(fixes_3plus, sets_3plus);
  EXPECT_EQ(fix_errors, 0);
  EXPECT_EQ(loop->counters().frame_sets, static_cast<std::uint64_t>(sets));
}

TEST(NavLoop, ACameraThatStopsIsSetAsideRetriedAndTheOthersGoOn) {
  const Rig rig = SmallRig();
  const Sweep sweep = RenderSweep(rig, 36, 10.0);
  InProcessSource source(rig.num_cameras);
  ASSERT_EQ(source.Start(), SourceStatus::kOk);
  auto loop = std::make_unique<NavLoop>(rig, &source, nullptr, nullptr, nullptr);
  ASSERT_TRUE(loop->Configure(Config(), nullptr));
  PoseRecord rec;
  int degraded_camera_down = 0;
  for (int n = 0; n < 36; ++n) {
    const std::size_t i = static_cast<std::size_t>(n);
    for (int k = 0; k < rig.num_cameras; ++k) {
      if (k == 1 && n >= 5 && n < 20) {
        source.PushStatus(k, SourceStatus::kTimeout);  // camera y stops delivering
        continue;
      }
      source.Push(k, View(rig, k, sweep.frames[i][static_cast<std::size_t>(k)], 1000 + static_cast<std::uint64_t>(n), static_cast<std::uint32_t>(n)));
    }
    ASSERT_EQ(loop->Step(&rec), StepStatus::kOk);
    if (n == 7) {
      EXPECT_TRUE(loop->supervision(1).set_aside);  // 3 timeouts in a row
      EXPECT_FALSE(loop->supervision(0).set_aside);
    }
    degraded_camera_down += rec.status == NavStatus::kDegraded && rec.reason == NavReason::kCameraDown;
  }
  EXPECT_GT(degraded_camera_down, 0);  // the others still navigate
  EXPECT_GE(loop->supervision(1).set_asides, 1u);  // retried, set aside again while it stays silent
  EXPECT_GT(loop->supervision(1).resets, 0u);
  EXPECT_FALSE(loop->supervision(1).set_aside);  // back after frames came again
}

TEST(NavLoop, EndOfStreamAndNoFrames) {
  const Rig rig = SmallRig();
  InProcessSource source(rig.num_cameras);
  ASSERT_EQ(source.Start(), SourceStatus::kOk);
  NavLoop loop(rig, &source, nullptr, nullptr, nullptr);
  ASSERT_TRUE(loop.Configure(Config(), nullptr));
  for (int k = 0; k < rig.num_cameras; ++k) source.PushStatus(k, SourceStatus::kTimeout);
  PoseRecord rec;
  ASSERT_EQ(loop.Step(&rec), StepStatus::kOk);
  EXPECT_EQ(rec.status, NavStatus::kLost);
  EXPECT_EQ(rec.reason, NavReason::kNoFrames);
  source.Close();
  EXPECT_EQ(loop.Step(&rec), StepStatus::kEndOfStream);
  // A configuration that does not fit is refused with a reason.
  NavLoopConfig bad = Config();
  bad.deadline_ms = 0;
  const char* why = nullptr;
  EXPECT_FALSE(loop.Configure(bad, &why));
  EXPECT_NE(why, nullptr);
}

}  // namespace
}  // namespace mfns::fw
