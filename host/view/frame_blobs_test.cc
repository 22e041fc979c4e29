#include "host/view/frame_blobs.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <set>

#include "common/camera/camera.h"
#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "host/core/image.h"

namespace mfns::host {
namespace {

namespace fs = std::filesystem;

// Frames drawn here: a Gaussian spot at each beacon's projection (common/camera) through a known
// pose. FrameBlobs finds them and names each its beacon; a missing frame is counted.
TEST(FrameBlobs, SpotsAtTheBeaconsProjectionsAreFoundAndMatched) {
  std::string tmpl = (fs::temp_directory_path() / "mfns-frame-blobs-XXXXXX").string();
  ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
  const fs::path dir = tmpl;
  const Rig rig = PaperRig();
  ViewPose pose;
  pose.frame_set = 7;
  pose.has_pose = true;
  // Where a beacon images well inside camera k for this pose (false: not seen).
  const auto image_of = [&](int k, int m, Eigen::Vector2d* uv) {
    const RigCamera& cam = rig.cameras[static_cast<std::size_t>(k)];
    const Eigen::Vector3d p_k = WorldToCamera(cam, BodyPose{pose.C_w_b, pose.r_w_wb}, rig.beacons_w[static_cast<std::size_t>(m)]);
    return p_k.z() > 0.0 && Project(cam.intrinsics, p_k, uv) == ProjectStatus::kOk && uv->x() > 20 && uv->y() > 20 &&
           uv->x() < cam.intrinsics.width - 20 && uv->y() < cam.intrinsics.height - 20;
  };
  // A yaw (the paper's turntable axis) at which the first two cameras see at least 3 beacons.
  for (int yaw_deg = -180; yaw_deg < 180; yaw_deg += 5) {
    pose.C_w_b = EulerToMatrix(EulerAngles{0.0, 0.0, DegToRad(yaw_deg)}).transpose();
    int seen = 0;
    Eigen::Vector2d uv;
    for (int k = 0; k < 2; ++k)
      for (int m = 0; m < rig.num_beacons; ++m) seen += image_of(k, m, &uv) ? 1 : 0;
    if (seen >= 3) break;
  }
  std::set<std::pair<int, int>> drawn;  // (camera, beacon)
  for (int k = 0; k < rig.num_cameras - 1; ++k) {  // the last camera's frame is left out
    const RigCamera& cam = rig.cameras[static_cast<std::size_t>(k)];
    cv::Mat image(cam.intrinsics.height, cam.intrinsics.width, CV_8U, cv::Scalar(10));
    for (int m = 0; m < rig.num_beacons; ++m) {
      Eigen::Vector2d uv;
      if (!image_of(k, m, &uv)) continue;
      for (int v = -6; v <= 6; ++v)
        for (int u = -6; u <= 6; ++u) {
          const int x = static_cast<int>(std::lround(uv.x())) + u, y = static_cast<int>(std::lround(uv.y())) + v;
          const double d2 = (x - uv.x()) * (x - uv.x()) + (y - uv.y()) * (y - uv.y());
          image.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(std::min(250.0, 10.0 + 200.0 * std::exp(-d2 / 4.0)));
        }
      drawn.insert({k, m});
    }
    fs::create_directories(dir / "frames" / cam.name.data());
    WritePgm((dir / "frames" / cam.name.data() / "000007.pgm").string(), image);
  }
  ASSERT_GE(drawn.size(), 3u) << "the pose should see beacons";
  FrameBlobs blobs(rig, dir);
  const fw::BlobsRecord r = blobs.Detect(pose);
  std::set<std::pair<int, int>> found;
  for (int i = 0; i < r.num_blobs; ++i) found.insert({r.blobs[static_cast<std::size_t>(i)].camera, r.blobs[static_cast<std::size_t>(i)].beacon});
  EXPECT_EQ(found, drawn);
  EXPECT_EQ(r.frame_set, 7u);
  EXPECT_EQ(blobs.unreadable_frames(), 1);  // the last camera's
  // Lost: the same blobs, none matched.
  pose.has_pose = false;
  const fw::BlobsRecord lost = blobs.Detect(pose);
  EXPECT_EQ(lost.num_blobs, static_cast<int>(drawn.size()));
  for (int i = 0; i < lost.num_blobs; ++i) EXPECT_EQ(lost.blobs[static_cast<std::size_t>(i)].beacon, -1);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mfns::host
