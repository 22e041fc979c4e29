#include "host/sim/observe/observe.h"

#include <algorithm>
#include <cmath>

#include "common/camera/camera.h"
#include "common/rotation/rotation.h"
#include "host/sim/render/visibility.h"
#include "host/sim/scenario/sampling.h"

namespace mfns::host {
namespace {

constexpr std::uint32_t kImageStreamTag = 0x5eedu;  // the renderer's, unchanged since issue 3
constexpr std::uint32_t kClutterStream = 0xc1077e45u;
constexpr int kNearTries = 20;

bool InWindow(int frame, int first, int last) { return frame >= first && frame <= last; }

const Clutter::Blinding* Blinding(const Scenario& s, int frame, int camera) {
  for (const Clutter::Blinding& b : s.clutter.blinded)
    if (b.camera == camera && InWindow(frame, b.first_frame, b.last_frame)) return &b;
  return nullptr;
}

CameraState StateOf(const Scenario& s, int frame, int camera) {
  if (camera == s.clutter.stop_camera && frame >= s.clutter.stop_frame) return CameraState::kStopped;
  const Clutter::Blinding* b = Blinding(s, frame, camera);
  if (b == nullptr) return CameraState::kDelivered;
  return b->saturated ? CameraState::kBlindedSaturated : CameraState::kBlindedBlack;
}

// The emitter moved along the ray of uv_px at the depth of p_k: drawn through the camera
// model, its spot centres on uv_px. False when uv_px does not unproject.
bool OnRay(const CameraIntrinsics& cam, const Eigen::Vector2d& uv_px, const Eigen::Vector3d& p_k, Eigen::Vector3d* out) {
  Eigen::Vector2d x_n;
  if (Unproject(cam, uv_px, &x_n) != UnprojectStatus::kOk) return false;
  *out = Eigen::Vector3d(x_n.x(), x_n.y(), 1.0) * p_k.z();
  return true;
}

// The map's beacons: the image stream's centroid noise (two draws per beacon, seen or not, in
// beacon order: the streams do not depend on visibility), facing, occlusion.
void AddBeacons(const Scenario& s, const FrameTruth& f, int camera, std::mt19937_64* rng, CameraView* view) {
  const CameraIntrinsics& cam = s.rig.cameras[static_cast<std::size_t>(camera)].intrinsics;
  std::normal_distribution<double> jitter(0.0, s.errors.pixel_noise ? s.errors.centroid_sigma_px : 0.0);
  for (int b = 0; b < s.rig.num_beacons; ++b) {
    const Eigen::Vector2d offset(jitter(*rng), jitter(*rng));
    const BeaconSight sight = SightBeacon(s.rig, f.pose, camera, b, s.sensor.edge_margin_px);
    if (!sight.Drawn() || Occluded(s, f.frame, camera, b, sight.projection.uv_px)) continue;
    Spot spot;
    spot.id = b;
    spot.uv_geom_px = sight.projection.uv_px;
    spot.uv_px = sight.projection.uv_px + offset;
    if (!OnRay(cam, spot.uv_px, sight.p_k, &spot.p_k)) continue;
    spot.flux_e = s.sensor.flux_e_at_1m / sight.p_k.squaredNorm();
    spot.listed = sight.visible;
    view->spots.push_back(spot);
  }
}

// clutter.reflections_per_frame: uniform in the image, from the image stream (as since issue 3).
void AddReflections(const Scenario& s, int camera, std::mt19937_64* rng, CameraView* view) {
  const CameraIntrinsics& cam = s.rig.cameras[static_cast<std::size_t>(camera)].intrinsics;
  std::uniform_real_distribution<double> u(0.0, cam.width - 1.0), v(0.0, cam.height - 1.0);
  for (int i = 0; i < s.clutter.reflections_per_frame; ++i) {
    Spot spot;
    spot.source = SpotSource::kRandomSpot;
    spot.uv_px = Eigen::Vector2d(u(*rng), v(*rng));  // this expression's draw order is the renderer's since issue 3
    spot.uv_geom_px = spot.uv_px;
    spot.flux_e = s.clutter.reflection_flux_scale * s.sensor.flux_e_at_1m;
    spot.listed = InImage(cam, spot.uv_px, s.sensor.edge_margin_px);
    view->spots.push_back(spot);
  }
}

Spot RandomSpot(const Scenario& s, const CameraIntrinsics& cam, std::mt19937_64& rng) {
  const double m = s.sensor.edge_margin_px;
  Spot spot;
  spot.source = SpotSource::kRandomSpot;
  const double u = UniformIn(m, cam.width - 1.0 - m, rng);
  spot.uv_px = Eigen::Vector2d(u, UniformIn(m, cam.height - 1.0 - m, rng));
  spot.uv_geom_px = spot.uv_px;
  spot.flux_e = s.clutter.reflection_flux_scale * s.sensor.flux_e_at_1m;
  spot.listed = true;
  return spot;
}

// A reflection of one of the camera's listed beacons, near_radius_px from its drawn centre
// and inside the image; a random spot when there is none or no try lands inside.
Spot NearSpot(const Scenario& s, const CameraIntrinsics& cam, const std::vector<Spot>& beacons, std::mt19937_64& rng) {
  const Clutter& c = s.clutter;
  for (int t = 0; !beacons.empty() && t < kNearTries; ++t) {
    const Spot& parent = beacons[std::min(beacons.size() - 1, static_cast<std::size_t>(Uniform01(rng) * beacons.size()))];
    const double r = UniformIn(c.near_radius_min_px, c.near_radius_max_px, rng);
    const double angle = 2.0 * kPi * Uniform01(rng);
    const Eigen::Vector2d uv = parent.uv_px + r * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    if (!InImage(cam, uv, s.sensor.edge_margin_px)) continue;
    Spot spot;
    spot.source = SpotSource::kNearReflection;
    spot.parent = parent.id;
    spot.uv_px = spot.uv_geom_px = uv;
    spot.flux_e = c.reflection_flux_scale * parent.flux_e;
    spot.listed = true;
    return spot;
  }
  return RandomSpot(s, cam, rng);
}

// clutter.spurious: near reflections first, then random spots (the clutter stream).
void AddSpurious(const Scenario& s, int camera, std::mt19937_64& rng, CameraView* view) {
  const CameraIntrinsics& cam = s.rig.cameras[static_cast<std::size_t>(camera)].intrinsics;
  std::vector<Spot> beacons;
  for (const Spot& spot : view->spots)
    if (spot.source == SpotSource::kBeacon && spot.listed) beacons.push_back(spot);
  const int near = static_cast<int>(std::lround(s.clutter.near_fraction * s.clutter.spurious));
  for (int i = 0; i < s.clutter.spurious; ++i)
    view->spots.push_back(i < near ? NearSpot(s, cam, beacons, rng) : RandomSpot(s, cam, rng));
}

// clutter.static_reflections: the reflector points through the same visibility decision.
void AddStaticReflections(const Scenario& s, const FrameTruth& f, int camera, std::mt19937_64& rng, CameraView* view) {
  const Rig& reflectors = s.clutter.reflectors;
  const CameraIntrinsics& cam = s.rig.cameras[static_cast<std::size_t>(camera)].intrinsics;
  const double sigma = s.errors.pixel_noise ? s.errors.centroid_sigma_px : 0.0;
  for (int r = 0; r < reflectors.num_beacons; ++r) {
    const double du = sigma * StandardNormal(rng), dv = sigma * StandardNormal(rng);
    const BeaconSight sight = SightBeacon(reflectors, f.pose, camera, r, s.sensor.edge_margin_px);
    if (!sight.Drawn()) continue;
    Spot spot;
    spot.source = SpotSource::kStaticReflection;
    spot.id = r;
    spot.uv_geom_px = sight.projection.uv_px;
    spot.uv_px = sight.projection.uv_px + Eigen::Vector2d(du, dv);
    if (!OnRay(cam, spot.uv_px, sight.p_k, &spot.p_k)) continue;
    spot.flux_e = s.clutter.reflection_flux_scale * s.sensor.flux_e_at_1m / sight.p_k.squaredNorm();
    spot.listed = sight.visible;
    view->spots.push_back(spot);
  }
}

bool InRect(const Eigen::Vector4d& r, const Eigen::Vector2d& uv) {
  return uv.x() >= r[0] && uv.x() <= r[2] && uv.y() >= r[1] && uv.y() <= r[3];
}

}  // namespace

std::mt19937_64 ImageStream(const Scenario& s, int frame, int camera) {
  std::seed_seq seq{static_cast<std::uint32_t>(s.seed), static_cast<std::uint32_t>(s.seed >> 32),
                    static_cast<std::uint32_t>(frame), static_cast<std::uint32_t>(camera), kImageStreamTag};
  return std::mt19937_64(seq);
}

bool Occluded(const Scenario& s, int frame, int camera, int beacon, const Eigen::Vector2d& uv_geom_px) {
  const auto listed = [beacon](const std::vector<int>& ids) {
    return std::find(ids.begin(), ids.end(), beacon) != ids.end();
  };
  if (listed(s.clutter.occluded_beacons)) return true;
  for (const Clutter::Occlusion& o : s.clutter.occlusions) {
    if (!InWindow(frame, o.first_frame, o.last_frame) || (o.camera >= 0 && o.camera != camera)) continue;
    if ((o.beacons.empty() || listed(o.beacons)) && (!o.has_rect || InRect(o.rect_px, uv_geom_px))) return true;
  }
  return false;
}

CameraView ObserveCamera(const Scenario& s, const FrameTruth& f, int camera, std::mt19937_64* image_rng) {
  CameraView view;
  // The image stream's draws come first, whatever the camera's state, so the sensor noise after
  // them is the same for a given (seed, frame, camera).
  AddBeacons(s, f, camera, image_rng, &view);
  AddReflections(s, camera, image_rng, &view);
  view.state = StateOf(s, f.frame, camera);
  if (view.state != CameraState::kDelivered) {
    view.spots.clear();
    return view;
  }
  std::mt19937_64 clutter = SeededStream(s.seed, kClutterStream, static_cast<std::uint32_t>(f.frame),
                                         static_cast<std::uint32_t>(camera));
  AddSpurious(s, camera, clutter, &view);
  AddStaticReflections(s, f, camera, clutter, &view);
  return view;
}

int BlobFrameSet::NumVisible() const {
  int n = 0;
  for (const auto& v : visible) n += static_cast<int>(v.size());
  return n;
}

BlobFrameSet SimulateBlobs(const Scenario& s, const FrameTruth& f) {
  BlobFrameSet out;
  out.frame = f.frame;
  const double dn_per_e = (s.sensor.mono16 ? 257.0 : 1.0) / s.sensor.gain_e_per_dn;
  for (int k = 0; k < s.rig.num_cameras; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    std::mt19937_64 rng = ImageStream(s, f.frame, k);
    const CameraView view = ObserveCamera(s, f, k, &rng);
    out.state[kk] = view.state;
    out.delivered[kk] = view.state != CameraState::kStopped;
    for (const Spot& spot : view.spots) {
      if (!spot.listed) continue;
      fw::BlobObs blob;
      blob.camera = k;
      blob.uv_px = spot.uv_px;
      if (Unproject(s.rig.cameras[kk].intrinsics, spot.uv_px, &blob.x_n) != UnprojectStatus::kOk) continue;
      blob.flux = static_cast<float>(spot.flux_e * dn_per_e);
      out.blobs.push_back(blob);
      const bool is_beacon = spot.source == SpotSource::kBeacon;
      out.beacon.push_back(is_beacon ? spot.id : -1);
      out.source.push_back(spot.source);
      out.parent.push_back(spot.parent);
      out.uv_geom_px.push_back(spot.uv_geom_px);
      if (is_beacon) out.visible[kk].push_back(spot.id);
    }
  }
  return out;
}

}  // namespace mfns::host
