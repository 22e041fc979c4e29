#include "common/rig/infer_facing.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "common/rotation/rotation.h"

namespace mfns {

bool InferFacingOptions::IsValid(const char** why) const {
  const char* bad = nullptr;
  if (neighbours < 2 || neighbours > 16) bad = "neighbours";
  else if (!(half_angle_rad > 0.0 && half_angle_rad < kPi)) bad = "half_angle_rad";
  else if (!(max_face_spread_rad > 0.0 && max_face_spread_rad < kPi / 2)) bad = "max_face_spread_rad";
  else if (!(min_wall_share >= 0.0 && min_wall_share <= 1.0)) bad = "min_wall_share";
  else if (!(side_tolerance_m >= 0.0) || !std::isfinite(side_tolerance_m)) bad = "side_tolerance_m";
  if (why != nullptr) *why = bad != nullptr ? bad : "ok";
  return bad == nullptr;
}

namespace {

constexpr int kMaxNeighbours = 16;
constexpr int kMaxFaces = kMaxNeighbours * (kMaxNeighbours - 1) / 2;

// Indices of the k beacons nearest to beacon m, nearest first; returns k (<= neighbours).
int Nearest(const Rig& rig, int m, int neighbours, std::array<int, limits::kMaxBeacons>* out) {
  struct Near {
    double d2;
    int index;
  };
  std::array<Near, limits::kMaxBeacons> near{};
  int n = 0;
  const Eigen::Vector3d& p = rig.beacons_w[static_cast<std::size_t>(m)];
  for (int j = 0; j < rig.num_beacons; ++j)
    if (j != m) near[static_cast<std::size_t>(n++)] = Near{(rig.beacons_w[static_cast<std::size_t>(j)] - p).squaredNorm(), j};
  const int k = std::min(neighbours, n);
  std::partial_sort(near.begin(), near.begin() + k, near.begin() + n, [](const Near& a, const Near& b) {
    return a.d2 < b.d2 || (a.d2 == b.d2 && a.index < b.index);
  });
  for (int i = 0; i < k; ++i) (*out)[static_cast<std::size_t>(i)] = near[static_cast<std::size_t>(i)].index;
  return k;
}

// The plane through beacon m with this normal: beacons in front of it, behind it and on it.
struct Sides {
  int front = 0, back = 0, on = 0;
};

Sides CountSides(const Rig& rig, int m, const Eigen::Vector3d& n_w, double tol_m) {
  Sides s;
  const Eigen::Vector3d& p = rig.beacons_w[static_cast<std::size_t>(m)];
  for (int j = 0; j < rig.num_beacons; ++j) {
    const double h = n_w.dot(rig.beacons_w[static_cast<std::size_t>(j)] - p);
    if (h > tol_m) ++s.front;
    else if (h < -tol_m) ++s.back;
    else ++s.on;
  }
  return s;
}

// A plane through beacon m with every other beacon on one side: its inward normal and the
// number of beacons on it.
struct Face {
  Eigen::Vector3d n_w;
  int on;
};

// The hull's faces through beacon m and two of its nearest neighbours; returns their number.
int HullFaces(const Rig& rig, int m, const InferFacingOptions& o, std::array<Face, kMaxFaces>* faces) {
  std::array<int, limits::kMaxBeacons> near{};
  const int k = Nearest(rig, m, std::min(o.neighbours, kMaxNeighbours), &near);
  const Eigen::Vector3d& p = rig.beacons_w[static_cast<std::size_t>(m)];
  int num = 0;
  for (int a = 0; a < k; ++a) {
    const Eigen::Vector3d pa = rig.beacons_w[static_cast<std::size_t>(near[static_cast<std::size_t>(a)])] - p;
    for (int b = a + 1; b < k; ++b) {
      const Eigen::Vector3d pb = rig.beacons_w[static_cast<std::size_t>(near[static_cast<std::size_t>(b)])] - p;
      Eigen::Vector3d n = pa.cross(pb);
      // Nearly collinear: the plane is not defined by the three.
      if (!(n.norm() > 0.05 * pa.norm() * pb.norm())) continue;
      n.normalize();
      Sides s = CountSides(rig, m, n, o.side_tolerance_m);
      if (s.back > s.front) {
        n = -n;
        std::swap(s.back, s.front);
      }
      if (s.back == 0 && s.front > 0) (*faces)[static_cast<std::size_t>(num++)] = Face{n, s.on};
    }
  }
  return num;
}

// The beacon's normal from its hull faces (see the header) and the largest angle between it and
// the faces it averages (*cone_rad: the hull's normal cone at the beacon, within which a smooth
// wall's true normal lies); false when none, or when they disagree (a beacon at an edge of the
// hull, between two walls).
bool HullNormal(const Rig& rig, int m, const InferFacingOptions& o, Eigen::Vector3d* normal_w, double* cone_rad) {
  std::array<Face, kMaxFaces> faces;
  const int num = HullFaces(rig, m, o, &faces);
  if (num == 0) return false;
  // A flat wall: the face with the most beacons on it (>= 4), averaged with the faces near it.
  // A face across an edge with half as many on it is another wall: the beacon is at the edge.
  const Face* wall = &faces[0];
  for (int i = 1; i < num; ++i)
    if (faces[static_cast<std::size_t>(i)].on > wall->on) wall = &faces[static_cast<std::size_t>(i)];
  const bool flat = wall->on >= 4;
  const double cos_near = std::cos(o.max_face_spread_rad);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int i = 0; i < num; ++i) {
    const Face& f = faces[static_cast<std::size_t>(i)];
    const bool near = f.n_w.dot(wall->n_w) >= cos_near;
    if (flat && !near && 2 * f.on >= wall->on) return false;  // two walls: an edge
    if (!flat || near) sum += static_cast<double>(f.on) * f.n_w;
  }
  const Eigen::Vector3d n = sum.normalized();
  // A curved wall: every face around the beacon must agree with their mean.
  double min_cos = 1.0;
  for (int i = 0; i < num; ++i) {
    const Face& f = faces[static_cast<std::size_t>(i)];
    if (!flat && f.n_w.dot(n) < cos_near) return false;
    // On a flat wall the faces with about as many beacons as the wall's (the wall, or the strips
    // of a curved wall between columns of beacons) bound the normal; faces with fewer cross
    // an edge and tilt the mean without widening where the wall can face.
    if (!flat || 2 * f.on >= wall->on) min_cos = std::min(min_cos, f.n_w.dot(n));
  }
  *normal_w = n;
  *cone_rad = std::acos(std::clamp(min_cos, -1.0, 1.0));
  return true;
}

}  // namespace

bool InferFacing(const InferFacingOptions& o, Rig* rig, InferFacingResult* result) {
  if (rig == nullptr || rig->has_facing || !o.IsValid() || rig->num_beacons < 4 ||
      rig->num_beacons > limits::kMaxBeacons)
    return false;
  InferFacingResult r;
  std::array<Eigen::Vector3d, limits::kMaxBeacons> normal_w{};
  std::array<double, limits::kMaxBeacons> cone_rad{};
  std::array<bool, limits::kMaxBeacons> on_wall{};
  for (int m = 0; m < rig->num_beacons; ++m) {
    const auto sm = static_cast<std::size_t>(m);
    normal_w[sm] = Eigen::Vector3d::UnitZ();
    on_wall[sm] = HullNormal(*rig, m, o, &normal_w[sm], &cone_rad[sm]);
    ++(on_wall[sm] ? r.on_planes : r.unknown);
  }
  if (result != nullptr) *result = r;
  // Not a map of walls (beacons around a turntable, a few on stands): no facing at all.
  if (r.on_planes < o.min_wall_share * rig->num_beacons) return false;
  for (int m = 0; m < rig->num_beacons; ++m) {
    const auto sm = static_cast<std::size_t>(m);
    rig->beacon_normal_w[sm] = normal_w[sm];
    rig->beacon_half_angle[sm] = on_wall[sm] ? o.half_angle_rad : kPi;
    rig->beacon_normal_tolerance[sm] = on_wall[sm] ? cone_rad[sm] : 0.0;
  }
  rig->has_facing = true;
  return true;
}

}  // namespace mfns
