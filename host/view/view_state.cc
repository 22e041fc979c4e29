#include "host/view/view_state.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "common/camera/camera.h"
#include "common/rotation/rotation.h"

namespace mfns::host {
namespace {

using nlohmann::json;

json Vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

// The corner rays of camera k's image in k (common/camera's Unproject, so with its distortion;
// the pinhole ray where that does not converge), unit length.
std::array<Eigen::Vector3d, 4> CornerRays_k(const CameraIntrinsics& in) {
  const double w = in.width, h = in.height;
  const std::array<Eigen::Vector2d, 4> corners{Eigen::Vector2d(0, 0), Eigen::Vector2d(w, 0), Eigen::Vector2d(w, h),
                                               Eigen::Vector2d(0, h)};
  std::array<Eigen::Vector3d, 4> rays;
  for (std::size_t i = 0; i < 4; ++i) {
    Eigen::Vector2d x_n;
    if (Unproject(in, corners[i], &x_n) != UnprojectStatus::kOk) {
      x_n.y() = (corners[i].y() - in.v0) / in.alpha_y;
      x_n.x() = (corners[i].x() - in.u0 - in.skew * x_n.y()) / in.alpha_x;
    }
    rays[i] = Eigen::Vector3d(x_n.x(), x_n.y(), 1.0).normalized();
  }
  return rays;
}

}  // namespace

ViewPose ViewPoseFromRecord(const fw::PoseRecord& r) {
  ViewPose p;
  p.frame_set = r.frame_set;
  p.t_ns = r.t_capture_ns;
  p.status = fw::ToString(r.status);
  p.reason = fw::ToString(r.reason);
  p.has_pose = r.status != fw::NavStatus::kLost && r.r_w_wb.allFinite() && r.q_w_b.coeffs().allFinite();
  p.num_beacons = r.num_beacons;
  for (int k = 0; k < limits::kMaxCameras; ++k)
    p.beacons_per_camera[k] = k < r.num_cameras ? r.beacons_per_camera[static_cast<std::size_t>(k)] : -1;
  if (!p.has_pose) return p;
  p.r_w_wb = r.r_w_wb;
  p.C_w_b = r.q_w_b.normalized().toRotationMatrix();
  p.euler_deg = r.euler_deg.cast<double>();
  p.rms_px = r.residual_rms_px;
  const Eigen::Vector3d var = r.covariance.diagonal().head<3>();
  p.sigma_mm = var.allFinite() && var.minCoeff() >= 0.0 ? 1000.0 * std::sqrt(var.maxCoeff()) : -1.0;
  return p;
}

ViewState::ViewState(const Rig& rig, std::string source, ViewOptions options)
    : rig_(rig), source_(std::move(source)), options_(options) {}

void ViewState::AddPose(const ViewPose& p) {
  const std::lock_guard<std::mutex> lock(mutex_);
  ++poses_;
  if (p.status == "fix") ++fixes_;
  else if (p.status == "degraded") ++degraded_;
  else ++lost_;
  if (p.has_pose) {
    trail_.push_back(p.r_w_wb);
    while (trail_.size() > options_.max_trail) trail_.pop_front();
  }
  pose_ = p;
}

void ViewState::SetHealth(const fw::HealthRecord& h) {
  const std::lock_guard<std::mutex> lock(mutex_);
  health_ = h;
}

void ViewState::SetTruthTrail(std::vector<Eigen::Vector3d> r_w_wb) {
  const std::lock_guard<std::mutex> lock(mutex_);
  truth_trail_ = std::move(r_w_wb);
}

void ViewState::SetBlobs(const fw::BlobsRecord& b) {
  const std::lock_guard<std::mutex> lock(mutex_);
  blobs_ = b;
}

void ViewState::CountBadDatagram(fw::MessageStatus why) {
  const std::lock_guard<std::mutex> lock(mutex_);
  ++bad_datagrams_;
  last_bad_ = fw::ToString(why);
}

void ViewState::SetFinished() {
  const std::lock_guard<std::mutex> lock(mutex_);
  finished_ = true;
}

std::uint64_t ViewState::poses_received() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return poses_;
}

json ViewState::Json() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  json j;
  j["source"] = source_;
  j["finished"] = finished_;
  j["counts"] = {{"poses", poses_}, {"fix", fixes_}, {"degraded", degraded_}, {"lost", lost_},
                 {"bad_datagrams", bad_datagrams_}, {"last_bad", last_bad_}};
  j["pose"] = pose_ ? PoseJson(*pose_) : json(nullptr);
  j["health"] = health_ ? HealthJson(*health_) : json(nullptr);
  j["blobs"] = blobs_ ? BlobsJson(*blobs_) : json(nullptr);
  json trail = json::array();
  for (const Eigen::Vector3d& r : trail_) trail.push_back(Vec(r));
  j["trail"] = std::move(trail);
  json truth = json::array();
  for (const Eigen::Vector3d& r : truth_trail_) truth.push_back(Vec(r));
  j["truth_trail"] = std::move(truth);
  return j;
}

// The pose, and per camera its centre and view cone in w (only with a pose).
json ViewState::PoseJson(const ViewPose& p) const {
  json j = {{"frame_set", p.frame_set}, {"t_s", static_cast<double>(p.t_ns) * 1e-9}, {"status", p.status},
            {"reason", p.reason},       {"has_pose", p.has_pose},                      {"num_beacons", p.num_beacons}};
  json per_camera = json::array();
  for (int k = 0; k < rig_.num_cameras; ++k) per_camera.push_back(p.beacons_per_camera[k]);
  j["beacons_per_camera"] = std::move(per_camera);
  if (!p.has_pose) return j;
  j["r_w_wb"] = Vec(p.r_w_wb);
  j["euler_deg"] = Vec(p.euler_deg);
  j["sigma_mm"] = p.sigma_mm;
  j["rms_px"] = p.rms_px;
  json body_axes = json::array();
  for (int a = 0; a < 3; ++a) body_axes.push_back(Vec(p.C_w_b.col(a)));
  j["body_axes_w"] = std::move(body_axes);
  json cameras = json::array();
  for (int k = 0; k < rig_.num_cameras; ++k) {
    const RigCamera& cam = rig_.cameras[static_cast<std::size_t>(k)];
    const Eigen::Vector3d centre_w = p.r_w_wb + p.C_w_b * cam.r_b_bk;
    json cone = json::array();
    for (const Eigen::Vector3d& ray_k : CornerRays_k(cam.intrinsics))
      cone.push_back(Vec(centre_w + options_.cone_depth_m * (p.C_w_b * cam.C_k_b.transpose() * ray_k)));
    cameras.push_back({{"name", cam.name.data()}, {"centre_w", Vec(centre_w)}, {"cone_w", std::move(cone)}});
  }
  j["cameras"] = std::move(cameras);
  return j;
}

json ViewState::HealthJson(const fw::HealthRecord& h) const {
  json j = {{"frame_sets", h.frame_sets},         {"fixes", h.fixes},
            {"degraded", h.degraded},             {"lost", h.lost},
            {"deadline_slips", h.deadline_slips}, {"worst_frame_set_ms", h.worst_frame_set_us * 1e-3},
            {"clock_faults", h.clock_faults},     {"log_errors", h.log_errors},
            {"trigger_errors", h.trigger_errors}, {"param_generation", h.param_generation}};
  static constexpr const char* kStates[] = {"ok", "set aside", "failed"};
  json cameras = json::array();
  for (int k = 0; k < std::min<int>(h.num_cameras, limits::kMaxCameras); ++k) {
    const fw::CameraHealth& c = h.cameras[static_cast<std::size_t>(k)];
    cameras.push_back({{"state", c.state < 3 ? kStates[c.state] : "unknown"},
                       {"frames", c.frames},
                       {"drops", c.drops},
                       {"timeouts", c.timeouts},
                       {"errors", c.errors},
                       {"bad_frames", c.bad_frames},
                       {"detect_errors", c.detect_errors},
                       {"blobs_last", c.blobs_last}});
  }
  j["cameras"] = std::move(cameras);
  return j;
}

// Per camera of the rig its blobs ({u, v, beacon}; beacon -1: unmatched), and the beacons used.
json ViewState::BlobsJson(const fw::BlobsRecord& b) const {
  json cameras = json::array();
  for (int k = 0; k < rig_.num_cameras; ++k) cameras.push_back(json::array());
  json used = json::array();
  for (int i = 0; i < std::clamp(b.num_blobs, 0, limits::kMaxBlobsInMessage); ++i) {
    const fw::BlobEntry& e = b.blobs[static_cast<std::size_t>(i)];
    if (e.camera >= rig_.num_cameras) continue;  // a blob message of another rig
    cameras[e.camera].push_back({{"u", e.u_px}, {"v", e.v_px}, {"beacon", e.beacon}});
    if (e.beacon >= 0) used.push_back(e.beacon);
  }
  return {{"frame_set", b.frame_set}, {"truncated", b.truncated}, {"cameras", std::move(cameras)}, {"used_beacons", std::move(used)}};
}

json ViewState::RigJson() const {
  json beacons = json::array();
  for (int m = 0; m < rig_.num_beacons; ++m) beacons.push_back(Vec(rig_.beacons_w[static_cast<std::size_t>(m)]));
  json cameras = json::array();
  for (int k = 0; k < rig_.num_cameras; ++k) {
    const RigCamera& cam = rig_.cameras[static_cast<std::size_t>(k)];
    cameras.push_back({{"name", cam.name.data()}, {"width", cam.intrinsics.width}, {"height", cam.intrinsics.height}});
  }
  return {{"rig_id", rig_.rig_id.data()}, {"beacons_w", std::move(beacons)}, {"cameras", std::move(cameras)}};
}

}  // namespace mfns::host
