// mfns-view's model (issue 17 item 3): what the page shows of the flyer, built from mfns-navd's
// datagrams (live) or from a poses CSV (playback), and rendered as the JSON the page polls.
//
// Frames and units: world frame w (the station's), body frame b, camera frames k as in
// DESIGN.md; positions in the JSON are metres in w, angles degrees, sigmas millimetres. The
// view cones are the image's four corner rays of each camera (pinhole, distortion ignored: a
// picture, not a measurement), cone_depth_m long, carried into w by the shown pose.
// Thread safety: every public method locks; the UDP thread and the HTTP threads share it.
// Host only; allocates.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/rig/rig.h"
#include "firmware/modules/publish/pose_message.h"

namespace mfns::host {

// One frame set as the view shows it.
struct ViewPose {
  std::uint32_t frame_set = 0;
  std::uint64_t t_ns = 0;              // sample time (capture), ns
  std::string status = "lost";          // fix | degraded | lost (the poses CSV words)
  std::string reason = "none";          // NavReason's text
  bool has_pose = false;                // false when lost: the fields below are not shown
  Eigen::Vector3d r_w_wb = Eigen::Vector3d::Zero();     // m
  Eigen::Matrix3d C_w_b = Eigen::Matrix3d::Identity();  // body -> world
  Eigen::Vector3d euler_deg = Eigen::Vector3d::Zero();  // roll, pitch, yaw of C_b_w (2-1-3)
  double sigma_mm = -1.0;               // largest per-axis position 1-sigma; < 0: unknown (CSV)
  int num_beacons = 0;
  int beacons_per_camera[limits::kMaxCameras] = {-1, -1, -1, -1};  // -1: unknown (CSV)
  double rms_px = 0.0;
};

// A pose datagram as the view shows it (covariance -> sigma_mm, quaternion -> C_w_b).
ViewPose ViewPoseFromRecord(const fw::PoseRecord& r);

struct ViewOptions {
  std::size_t max_trail = 4000;  // positions kept for the trail (oldest dropped)
  double cone_depth_m = 0.4;     // length of the drawn view cones
};

class ViewState {
 public:
  // rig: the cameras (cones) and the beacon map drawn; source: what feeds it, for the page.
  ViewState(const Rig& rig, std::string source, ViewOptions options = {});

  void AddPose(const ViewPose& p);
  void SetHealth(const fw::HealthRecord& h);
  // The ground truth's trail (playback with a frames directory's truth.csv), drawn beside.
  void SetTruthTrail(std::vector<Eigen::Vector3d> r_w_wb);
  // The blobs of a frame set and the beacons they were matched to (BlobsMessage).
  void SetBlobs(const fw::BlobsRecord& b);
  // A datagram that did not decode (shown on the page with its reason).
  void CountBadDatagram(fw::MessageStatus why);
  // The playback ended (the page says so).
  void SetFinished();

  // The page's state (README.md lists the fields); Json().dump() is what /state.json serves.
  nlohmann::json Json() const;
  // The beacon map and the cameras' names (/rig.json): fixed for the view's life.
  nlohmann::json RigJson() const;
  std::uint64_t poses_received() const;

 private:
  nlohmann::json PoseJson(const ViewPose& p) const;
  nlohmann::json HealthJson(const fw::HealthRecord& h) const;
  nlohmann::json BlobsJson(const fw::BlobsRecord& b) const;

  const Rig rig_;
  const std::string source_;
  const ViewOptions options_;
  mutable std::mutex mutex_;
  std::optional<ViewPose> pose_;
  std::optional<fw::HealthRecord> health_;
  std::optional<fw::BlobsRecord> blobs_;
  std::deque<Eigen::Vector3d> trail_;
  std::vector<Eigen::Vector3d> truth_trail_;
  std::uint64_t poses_ = 0, fixes_ = 0, degraded_ = 0, lost_ = 0;
  std::uint64_t bad_datagrams_ = 0;
  std::string last_bad_;
  bool finished_ = false;
};

}  // namespace mfns::host
