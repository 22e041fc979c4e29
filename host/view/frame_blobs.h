// mfns-view's playback with a frames directory: each played frame set's blobs, detected in its
// recorded frames as mfns-navd detects them (firmware/modules/detect, NavLoopConfig's default
// DetectOptions) and matched to the beacons the logged pose predicts (BeaconMatcher::MatchPose,
// MatchOptions' default gate). The match is the view's, from the pose: navd's own identities
// are only in its live blobs datagram. Host only; allocates.
#pragma once

#include <filesystem>
#include <memory>

#include "common/rig/rig.h"
#include "firmware/modules/publish/pose_message.h"
#include "host/view/view_state.h"

namespace mfns::fw {
class BlobDetector;
class BeaconMatcher;
}  // namespace mfns::fw

namespace mfns::host {

class FrameBlobs {
 public:
  // frames_dir: a recording's directory (its frames/<camera>/<frame, 6 digits>.pgm).
  FrameBlobs(const Rig& rig, std::filesystem::path frames_dir);
  ~FrameBlobs();
  FrameBlobs(const FrameBlobs&) = delete;
  FrameBlobs& operator=(const FrameBlobs&) = delete;

  // The blobs of frame set pose.frame_set, matched when the pose has one. A camera whose frame
  // is missing or unreadable (or not the rig's size) contributes none, and is counted.
  fw::BlobsRecord Detect(const ViewPose& pose);
  int unreadable_frames() const { return unreadable_; }

 private:
  const Rig rig_;
  const std::filesystem::path dir_;
  std::unique_ptr<fw::BlobDetector> detector_;
  std::unique_ptr<fw::BeaconMatcher> matcher_;
  int unreadable_ = 0;
};

}  // namespace mfns::host
