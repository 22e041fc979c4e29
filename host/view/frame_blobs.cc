#include "host/view/frame_blobs.h"

#include <cstdio>
#include <exception>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "firmware/app/navd/nav_loop.h"
#include "firmware/modules/detect/detect.h"
#include "firmware/modules/identify/match.h"
#include "host/core/image.h"

namespace mfns::host {

FrameBlobs::FrameBlobs(const Rig& rig, std::filesystem::path frames_dir)
    : rig_(rig),
      dir_(std::move(frames_dir)),
      detector_(std::make_unique<fw::BlobDetector>(fw::NavLoopConfig{}.detect)),
      matcher_(std::make_unique<fw::BeaconMatcher>()) {
  matcher_->Reset(rig_);
}

FrameBlobs::~FrameBlobs() = default;

fw::BlobsRecord FrameBlobs::Detect(const ViewPose& pose) {
  std::vector<fw::BlobObs> obs;
  char name[16];
  std::snprintf(name, sizeof(name), "%06u.pgm", pose.frame_set);
  for (int k = 0; k < rig_.num_cameras; ++k) {
    const RigCamera& cam = rig_.cameras[static_cast<std::size_t>(k)];
    cv::Mat image;
    try {
      image = ReadPgm((dir_ / "frames" / cam.name.data() / name).string());
    } catch (const std::exception&) {  // ReadPgm: missing or malformed; counted below
    }
    if (image.empty() || image.cols != cam.intrinsics.width || image.rows != cam.intrinsics.height) {
      ++unreadable_;
      continue;
    }
    fw::FrameView view;
    view.data = image.data;
    view.width = image.cols;
    view.height = image.rows;
    view.stride_bytes = static_cast<int>(image.step[0]);
    view.format = image.depth() == CV_16U ? fw::PixelFormat::kMono16 : fw::PixelFormat::kMono8;
    view.camera = k;
    fw::BlobList list;
    const fw::DetectStatus s = detector_->Detect(view, &cam.intrinsics, &list);
    if (s != fw::DetectStatus::kOk && s != fw::DetectStatus::kBlobLimit && s != fw::DetectStatus::kTruncatedFrame) continue;
    for (int i = 0; i < list.count; ++i) {
      const fw::Blob& b = list.blobs[static_cast<std::size_t>(i)];
      if (b.normalised_ok) obs.push_back(fw::BlobObs{k, b.uv_px, b.x_n, static_cast<float>(b.flux_dn)});
    }
  }
  fw::MatchSet set;
  set.num_matches = 0;
  const int n = matcher_->SetBlobs(obs.data(), static_cast<int>(obs.size()));
  if (pose.has_pose && n > 0) matcher_->MatchPose(BodyPose{pose.C_w_b, pose.r_w_wb}, fw::MatchOptions{}, &set);
  fw::BlobsRecord r;
  r.frame_set = pose.frame_set;
  r.t_capture_ns = pose.t_ns;
  r.num_cameras = static_cast<std::uint8_t>(rig_.num_cameras);
  std::vector<std::int16_t> beacon_of_blob(obs.size());
  for (std::size_t i = 0; i < obs.size(); ++i)
    beacon_of_blob[i] = static_cast<std::int16_t>(set.BeaconOfBlob(static_cast<int>(i)));
  fw::FillBlobs(obs.data(), static_cast<int>(obs.size()), beacon_of_blob.data(), &r);
  return r;
}

}  // namespace mfns::host
