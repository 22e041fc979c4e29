// What each camera sees in one frame set of a scenario, decided once for the LED renderer
// (host/sim/frames) and the fast blob-level simulation (SimulateBlobs) alike:
//   - every beacon the camera sees (host/sim/render/visibility.h SightBeacon on the TRUE rig:
//     beam facing, in front, inside the image shrunk by sensor.edge_margin_px, not a distortion
//     ghost), minus the scenario's occlusions, at its projection plus the centroid noise
//     (errors.pixel_noise: centroid_sigma_px per axis);
//   - spurious spots: clutter.reflections_per_frame and clutter.spurious random spots, near
//     reflections of visible beacons, static reflections (unmapped wall points);
//   - blinded cameras (a frame with no blobs) and the stopped camera (clutter.stop_camera).
// Random streams, per (scenario seed, frame, camera), so nothing depends on the thread count:
// the image stream (the renderer's, seed_seq {seed, frame, camera, 0x5eed}) gives the beacons'
// centroid noise and reflections_per_frame's spots, then the renderer's sensor noise; the
// clutter stream gives everything the error sources add. Scenarios without the new error
// sources render the same bytes as before them.
#pragma once

#include <Eigen/Core>
#include <array>
#include <random>
#include <vector>

#include "common/limits.h"
#include "firmware/modules/solve/observation.h"
#include "host/sim/scenario/scenario.h"

namespace mfns::host {

enum class SpotSource {
  kBeacon,            // a beacon of the map
  kNearReflection,    // a reflection of a visible beacon within clutter.near_radius_px of it
  kRandomSpot,        // reflections_per_frame and spurious spots anywhere in the image
  kStaticReflection,  // an unmapped point on a wall (clutter.static_reflections)
};

// One spot of light in a camera's image.
struct Spot {
  SpotSource source = SpotSource::kBeacon;
  int id = -1;       // beacon (kBeacon) or reflector (kStaticReflection) index, else -1
  int parent = -1;   // kNearReflection: the beacon it reflects
  Eigen::Vector2d uv_px = Eigen::Vector2d::Zero();       // centre as drawn: what a perfect detector finds
  Eigen::Vector2d uv_geom_px = Eigen::Vector2d::Zero();  // beacons, reflectors: projection without noise; else uv_px
  // Beacons and reflectors: the emitter moved along its ray so that it images at uv_px (the
  // renderer draws it through the camera model); zero for the others.
  Eigen::Vector3d p_k = Eigen::Vector3d::Zero();
  double flux_e = 0.0;  // electrons: flux_e_at_1m / d^2, reflections scaled by reflection_flux_scale
  // A blob: its centre in the image shrunk by sensor.edge_margin_px (beacons: SightBeacon's
  // `visible`). Unlisted spots straddle the border: drawn, not detected.
  bool listed = false;
};

enum class CameraState {
  kDelivered,          // a normal frame
  kBlindedSaturated,   // clutter.blinded, mode saturated: every pixel at full scale, no blobs
  kBlindedBlack,       // clutter.blinded, mode black: an all-zero frame, no blobs
  kStopped,            // clutter.stop_camera from stop_frame on: an all-zero frame, no frame delivered
};

struct CameraView {
  CameraState state = CameraState::kDelivered;
  std::vector<Spot> spots;  // beacons (by id) then spurious spots; empty unless kDelivered
};

// The renderer's image stream for (frame, camera): ObserveCamera draws from it first, the sensor
// noise after.
std::mt19937_64 ImageStream(const Scenario& s, int frame, int camera);

// What camera `camera` sees in frame set f. image_rng: ImageStream(s, f.frame, camera), left
// where the sensor noise starts.
CameraView ObserveCamera(const Scenario& s, const FrameTruth& f, int camera, std::mt19937_64* image_rng);

// Whether beacon b is hidden from camera k in frame `frame` whose true image is uv_geom_px
// (clutter.occluded_beacons and clutter.occlusions).
bool Occluded(const Scenario& s, int frame, int camera, int beacon, const Eigen::Vector2d& uv_geom_px);

// One frame set as a perfect blob detector would report it, with its truth.
struct BlobFrameSet {
  int frame = 0;
  std::vector<fw::BlobObs> blobs;  // camera by camera, each camera's beacons (by id) then its spurious blobs
  // Per blob: the beacon it images, -1 for a spurious blob; its source and, for beacons, the
  // projection without centroid noise.
  std::vector<int> beacon;
  std::vector<SpotSource> source;
  std::vector<int> parent;  // kNearReflection: the beacon reflected, else -1
  std::vector<Eigen::Vector2d> uv_geom_px;
  // Per camera: the beacons it sees (ids, ascending; exactly the blobs with beacon >= 0), and
  // whether it delivered a frame. A blinded camera delivers (true) a frame with no blobs; only
  // a stopped camera delivers nothing (false).
  std::array<std::vector<int>, limits::kMaxCameras> visible{};
  std::array<bool, limits::kMaxCameras> delivered{};
  std::array<CameraState, limits::kMaxCameras> state{};
  int NumVisible() const;  // beacons seen, counted once per camera
};

// The blob-level simulation of frame set f: the spots ObserveCamera lists, as BlobObs on the
// true rig (uv_px with centroid noise; x_n = mfns::Unproject of it with the true intrinsics;
// flux the spot's electrons in DN: / gain_e_per_dn, x 257 for mono16). Deterministic per
// (s.seed, f.frame): the same centres the renderer draws and lists in blobs.csv. A camera may
// list more than limits::kMaxBlobsPerFrame blobs (a detector would cap them).
BlobFrameSet SimulateBlobs(const Scenario& s, const FrameTruth& f);

}  // namespace mfns::host
