#include "common/rig/infer_facing.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "common/rotation/rotation.h"

namespace mfns {

bool InferFacingOptions::IsValid(const char** why) const {
  const char* bad = nullptr;
  if (neighbours < 2 || neighbours > 24) bad = "neighbours";
  else if (!(half_angle_rad > 0.0 && half_angle_rad < kPi)) bad = "half_angle_rad";
  else if (!(max_face_spread_rad > 0.0 && max_face_spread_rad < kPi / 2)) bad = "max_face_spread_rad";
  else if (!(min_wall_share >= 0.0 && min_wall_share <= 1.0)) bad = "min_wall_share";
  else if (!(side_tolerance_m >= 0.0) || !std::isfinite(side_tolerance_m)) bad = "side_tolerance_m";
  else if (!(flat_tolerance_m >= 0.0 && flat_tolerance_m <= side_tolerance_m)) bad = "flat_tolerance_m";
  if (why != nullptr) *why = bad != nullptr ? bad : "ok";
  return bad == nullptr;
}

namespace {

constexpr int kMaxNeighbours = 24;
constexpr int kMaxFaces = kMaxNeighbours * (kMaxNeighbours - 1) / 2;
// Beacons on one plane within flat_tolerance_m that make it a flat wall: at least five and a
// 24th of the map (a module's wall holds a sixth of its beacons or more). Measured on
// generated cylinders: planes through a curved wall's beacons hold 5-11 within 3 mm by chance
// (straight columns, rings of an end cap and the tube's last row), the more the denser the map.
constexpr int kFlatWallBeacons = 5;
constexpr int kFlatWallShare = 24;

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
// The beacons on it within a tolerance: how many, their largest distance off the plane and
// from beacon m.
struct OnPlane {
  int count = 0;
  double off_m = 0.0, span_m = 0.0;

  void Add(double h, double dist) {
    ++count;
    off_m = std::max(off_m, std::abs(h));
    span_m = std::max(span_m, dist);
  }
  // How far a smooth wall through them may face away from the plane at beacon m: a curved wall
  // bulging by off_m over a chord of span_m turns by 4 off_m / span_m between its middle and
  // its ends (a 2.1 m cylinder's beacons lie within 5 cm of one plane over +-12.5 deg of it).
  double TiltRad() const { return span_m > 0.0 ? std::min(kPi / 2, 4.0 * off_m / span_m) : 0.0; }
};

struct Sides {
  int front = 0, back = 0;
  OnPlane on, flat;  // within side_tolerance_m, within flat_tolerance_m
};

Sides CountSides(const Rig& rig, int m, const Eigen::Vector3d& n_w, const InferFacingOptions& o) {
  Sides s;
  const Eigen::Vector3d& p = rig.beacons_w[static_cast<std::size_t>(m)];
  for (int j = 0; j < rig.num_beacons; ++j) {
    const Eigen::Vector3d d = rig.beacons_w[static_cast<std::size_t>(j)] - p;
    const double h = n_w.dot(d);
    if (h > o.side_tolerance_m) {
      ++s.front;
    } else if (h < -o.side_tolerance_m) {
      ++s.back;
    } else {
      s.on.Add(h, d.norm());
      if (std::abs(h) <= o.flat_tolerance_m) s.flat.Add(h, d.norm());
    }
  }
  return s;
}

// A plane through beacon m with every other beacon on one side: its inward normal, the number
// of beacons on it, whether it is a flat wall (>= kFlatWallBeacons within flat_tolerance_m; a
// wall's beacons near an edge lie within side_tolerance_m of the next wall too) and how far the
// wall may face away from it at m (OnPlane::TiltRad, of the flat wall's beacons when it is one).
struct Face {
  Eigen::Vector3d n_w;
  int on, flat;
  double tilt_rad;
};

using Neighbours = std::array<int, limits::kMaxBeacons>;

// The hull's faces through beacon m and two of its k nearest neighbours (near); returns their
// number. A sparse map needs many neighbours: with 12 a beacon by an end cap found only the
// faces leaning towards the cap, and its true normal lay outside their cone.
int HullFaces(const Rig& rig, int m, const Neighbours& near, int k, const InferFacingOptions& o,
              std::array<Face, kMaxFaces>* faces) {
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
      Sides s = CountSides(rig, m, n, o);
      if (s.back > s.front) {
        n = -n;
        std::swap(s.back, s.front);
      }
      if (s.back == 0 && s.front > 0) {
        const bool flat = s.flat.count >= kFlatWallBeacons;
        (*faces)[static_cast<std::size_t>(num++)] = Face{n, s.on.count, s.flat.count, flat ? s.flat.TiltRad() : s.on.TiltRad()};
      }
    }
  }
  return num;
}

// The largest angle between axis_w and a face's normal, plus that face's tilt.
double ConeAbout(const Eigen::Vector3d& axis_w, const Face* const* faces, int num) {
  double cone = 0.0;
  for (int i = 0; i < num; ++i)
    cone = std::max(cone, std::acos(std::clamp(faces[i]->n_w.dot(axis_w), -1.0, 1.0)) + faces[i]->tilt_rad);
  return cone;
}

// The axis of the smallest cone holding the faces' normals (Badoiu-Clarkson: each step moves
// the axis towards the farthest normal, 1/(k+1) of the way; ~1 % of the radius in 64 steps).
void EnclosingCone(const Face* const* faces, int num, Eigen::Vector3d* axis_w) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int i = 0; i < num; ++i) c += faces[i]->n_w;
  c.normalize();
  for (int k = 1; k <= 64 && c.allFinite(); ++k) {
    const Face* far = faces[0];
    for (int i = 1; i < num; ++i)
      if (faces[i]->n_w.dot(c) < far->n_w.dot(c)) far = faces[i];
    c = (c + (far->n_w - c) / (k + 1.0)).normalized();
  }
  *axis_w = c;
}

// The beacon's normal and the angle within which its wall's true normal lies (*cone_rad); false
// when it has no face, or when the faces disagree (a beacon at an edge between two walls).
// - On a flat wall (a face with min_flat beacons within flat_tolerance_m of its plane: a flat
//   panel, surveyed): the axis of that wall's faces, the tolerance also covering the faces near
//   it with half as many beacons within side_tolerance_m (a curved wall's strips between
//   columns of beacons, where two straight columns make an exact plane on one side only). Faces
//   with fewer lean across the wall's edge towards the next wall and are left out (they would
//   widen a box wall's beacons by up to 45 deg); another flat wall through the beacon beyond
//   max_face_spread_rad makes it an edge.
// - Otherwise (a curved wall, or a sparse one): every hull face through the beacon. A convex
//   module's wall at the beacon is a supporting plane of the hull there, so its normal lies in
//   the cone of those faces' normals (the hull's normal cone); wider than max_face_spread_rad:
//   an edge.
bool HullNormal(const Rig& rig, int m, const InferFacingOptions& o, Eigen::Vector3d* normal_w, double* cone_rad) {
  Neighbours near{};
  const int k = Nearest(rig, m, std::min(o.neighbours, kMaxNeighbours), &near);
  std::array<Face, kMaxFaces> faces;
  const int num = HullFaces(rig, m, near, k, o, &faces);
  if (num == 0) return false;
  const int min_flat = std::max(kFlatWallBeacons, (rig.num_beacons + kFlatWallShare - 1) / kFlatWallShare);
  const Face* wall = nullptr;
  for (int i = 0; i < num; ++i) {
    const Face& f = faces[static_cast<std::size_t>(i)];
    if (f.flat >= min_flat && (wall == nullptr || f.flat > wall->flat)) wall = &f;
  }
  // The faces the normal comes from (the flat wall's, or all) and those its tolerance covers.
  std::array<const Face*, kMaxFaces> axis_faces{}, used{};
  int num_axis = 0, num_used = 0;
  const double cos_near = std::cos(o.max_face_spread_rad);
  for (int i = 0; i < num; ++i) {
    const Face& f = faces[static_cast<std::size_t>(i)];
    if (wall != nullptr) {
      const bool same_wall = f.n_w.dot(wall->n_w) >= cos_near;
      if (!same_wall && 2 * f.flat >= wall->flat) return false;  // two flat walls: an edge
      if (!same_wall) continue;
      // Faces with half the wall's beacons or more are the wall (or a curved wall's strips);
      // fewer lean across the wall's edge, a row of each wall.
      if (f.flat >= min_flat) axis_faces[static_cast<std::size_t>(num_axis++)] = &f;
      else if (2 * f.on < wall->flat) continue;
    } else {
      axis_faces[static_cast<std::size_t>(num_axis++)] = &f;
    }
    used[static_cast<std::size_t>(num_used++)] = &f;
  }
  if (num_axis == 0) return false;
  EnclosingCone(axis_faces.data(), num_axis, normal_w);
  const double cone = ConeAbout(*normal_w, used.data(), num_used);
  if (!normal_w->allFinite() || cone > o.max_face_spread_rad) return false;
  *cone_rad = cone;
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
