// Blob tracks in the image (issue 13): which blobs of a frame set continue a blob of the
// previous ones smoothly. A beacon's image moves smoothly from frame set to frame set (the
// body's rate and accelerations are bounded); a noise spot, a glint off a moving part or a
// flickering reflection does not. Lost-in-space searches blob triples of steady blobs first
// (lost_in_space.h): with few beacons among many blobs, most triples hold a spurious blob, and
// a search that meets the true triple early fixes early. Nothing is refused for being new or
// unsteady: a steady reflection (a point on a wall) is searched like a beacon, and a beacon
// that just came into view is searched after the steady blobs, as every blob was before.
//
// Per camera, each blob of a frame set is associated with at most one blob of the previous
// frame set (mutual nearest within a gate; positions in undistorted normalised coordinates
// times px_per_rad, so that every camera's pixel gates mean the same angle):
//   - a previous blob with a velocity (age >= 2): within tight_gate_px plus
//     tight_gate_fraction of the predicted displacement of its constant-velocity prediction
//     (age + 1); failing that, within the wide gate of its position (age 2: a new velocity);
//   - a previous blob without one (age 1): within the wide gate of its position (age 2).
// Unassociated: age 1. Steady: age >= steady_age (3: two steps of which the second kept the
// first's image velocity). A camera that did not deliver, or a gap of more than max_gap_s,
// starts its tracks over.
// Units: px (of px_per_rad), s, ns timestamps. Memory: fixed (limits::kMaxObservations blobs,
// twice); O(n^2) per camera in the blobs of one camera, no heap.
#pragma once

#include <array>
#include <cstdint>

#include "common/limits.h"
#include "firmware/modules/solve/observation.h"

namespace mfns::fw {

struct BlobTrackOptions {
  // The largest angular speed of a beacon's image (no velocity known yet): the wide gate is
  // this times the time between the frame sets, in px, plus tight_gate_px. The tracker sets
  // it from its bounds: the body's rate plus its speed over a near beacon's range (Tracker::
  // BlobTrackOptionsOf).
  double max_image_rate_rad_s = 2.0;
  // Error of the constant image velocity prediction: the body's accelerations over a frame
  // set (~0.5 px at 1000 px/rad and 18.6 Hz), the centroid noise of three centroids, and the
  // curvature of image paths under rotation (~r * theta^2: ~2 px at the edge of an image
  // turning 0.05 rad per frame set), which the fraction of the displacement covers.
  double tight_gate_px = 3.0;
  double tight_gate_fraction = 0.2;
  double max_gap_s = 0.5;
  int steady_age = 3;

  bool IsValid() const;
};

class BlobTracks {
 public:
  void Reset();
  // Associates blobs[0..n) (a frame set; cameras: the delivered mask) with the previous
  // frame set's. n <= limits::kMaxObservations, blob cameras < limits::kMaxCameras (others:
  // age 1). Never allocates.
  void Update(const BlobObs* blobs, int n, std::uint64_t t_ns, std::uint32_t cameras, double px_per_rad,
              const BlobTrackOptions& o);
  // Of blob i of the last Update: frame sets its track has lasted (1: new), whether steady.
  int age(int i) const { return ages_[static_cast<std::size_t>(i)]; }
  bool steady(int i) const { return ages_[static_cast<std::size_t>(i)] >= steady_age_; }
  const std::uint8_t* steady_flags() const { return steady_.data(); }  // 1 per steady blob
  // Of blob i of the last Update: its track's id, kept while the track continues; a new track
  // gets an id no earlier track had (never 0; unique over 2^32 - 1 tracks).
  std::uint32_t id(int i) const { return ids_[static_cast<std::size_t>(i)]; }
  int num_steady() const { return num_steady_; }

 private:
  struct Point {
    double u = 0.0, v = 0.0;    // px (x_n * px_per_rad)
    double du = 0.0, dv = 0.0;  // image velocity, px/s (age >= 2)
    std::uint8_t age = 0;
    std::int8_t camera = -1;
    std::uint32_t id = 0;  // 0: not yet given
  };
  void AssociateCamera(int camera, double dt_s, double wide_gate_px, const BlobTrackOptions& o);
  float Cost(const Point& prev, const Point& cur, double dt_s, double wide_gate_px, const BlobTrackOptions& o) const;

  int num_prev_ = 0, num_cur_ = 0;
  std::uint64_t prev_t_ns_ = 0;
  bool has_prev_ = false;
  std::uint32_t prev_cameras_ = 0;
  int steady_age_ = 3;
  int num_steady_ = 0;
  std::uint32_t last_id_ = 0;
  std::array<std::uint32_t, limits::kMaxObservations> ids_{};
  std::array<Point, limits::kMaxObservations> prev_{}, cur_{};
  std::array<std::uint8_t, limits::kMaxObservations> ages_{}, steady_{};
  std::array<std::int16_t, limits::kMaxObservations> best_prev_{}, best_cur_{};
  std::array<float, limits::kMaxObservations> best_prev_cost_{}, best_cur_cost_{};
};

}  // namespace mfns::fw
