#include "firmware/modules/identify/map_repeats.h"

#include <algorithm>
#include <cstdio>

#include "common/rotation/rotation.h"

namespace mfns::fw {

namespace {

constexpr int kMaxPatchNeighbours = 24;

// The beacon m and its k nearest beacons (ties by index), m first.
int Patch(const Rig& rig, int m, int k, std::array<int, kMaxPatchNeighbours + 1>* patch) {
  std::array<double, kMaxPatchNeighbours + 1> d2{};
  int n = 0;
  const Eigen::Vector3d& p = rig.beacons_w[static_cast<std::size_t>(m)];
  for (int i = 0; i < rig.num_beacons; ++i) {
    if (i == m) continue;
    const double e = (rig.beacons_w[static_cast<std::size_t>(i)] - p).squaredNorm();
    if (n == k && e >= d2[static_cast<std::size_t>(n - 1)]) continue;
    int at = n < k ? n++ : n - 1;  // insertion into the sorted list, the farthest dropped
    for (; at > 0 && d2[static_cast<std::size_t>(at - 1)] > e; --at) {
      d2[static_cast<std::size_t>(at)] = d2[static_cast<std::size_t>(at - 1)];
      (*patch)[static_cast<std::size_t>(at + 1)] = (*patch)[static_cast<std::size_t>(at)];
    }
    d2[static_cast<std::size_t>(at)] = e;
    (*patch)[static_cast<std::size_t>(at + 1)] = i;
  }
  (*patch)[0] = m;
  return n + 1;
}

// Whether the copy turns every beacon's known normal to within tolerance of its image's.
bool FacingAgrees(const Rig& rig, const int* set, int n, const MapCopy& copy, double tol_rad) {
  if (!rig.has_facing) return true;
  for (int s = 0; s < n; ++s) {
    const auto m = static_cast<std::size_t>(set[s]);
    const auto q = static_cast<std::size_t>(copy.image[static_cast<std::size_t>(s)]);
    if (rig.beacon_half_angle[m] >= kPi || rig.beacon_half_angle[q] >= kPi) continue;  // seen from everywhere
    const double allowed = tol_rad + rig.beacon_normal_tolerance[m] + rig.beacon_normal_tolerance[q];
    const double c = std::clamp((copy.C * rig.beacon_normal_w[m]).dot(rig.beacon_normal_w[q]), -1.0, 1.0);
    if (std::acos(c) > allowed) return false;
  }
  return true;
}

}  // namespace

bool MapRepeatsOptions::IsValid(const char** why) const {
  const char* bad = nullptr;
  if (neighbours < 2 || neighbours > kMaxPatchNeighbours) bad = "neighbours";
  else if (!(tolerance_m > 0.0) || !std::isfinite(tolerance_m)) bad = "tolerance_m";
  else if (!(facing_tolerance_rad >= 0.0 && facing_tolerance_rad <= kPi)) bad = "facing_tolerance_rad";
  if (why != nullptr) *why = bad != nullptr ? bad : "ok";
  return bad == nullptr;
}

bool FindMapRepeats(const Rig& rig, const MapRepeatsOptions& o, MapRepeatsResult* result) {
  *result = MapRepeatsResult{};
  if (!o.IsValid() || rig.num_beacons < 3 || rig.num_beacons > limits::kMaxBeacons) return false;
  const auto dist = [&rig](int i, int j) {
    return (rig.beacons_w[static_cast<std::size_t>(i)] - rig.beacons_w[static_cast<std::size_t>(j)]).norm();
  };
  const int k = std::min(kMaxPatchNeighbours, rig.num_beacons - 1);
  std::array<int, kMaxPatchNeighbours + 1> patch{};
  result->beacons = rig.num_beacons;
  result->tolerance_m = o.tolerance_m;
  for (int m = 0; m < rig.num_beacons; ++m) {
    // The nearest neighbours, more while they lie on one line (a dense row along a wall).
    const int available = Patch(rig, m, k, &patch);
    int n = std::min(available, o.neighbours + 1);
    int a = 0, b = 0, t = 0;
    while (n < available && !SpreadTriangle(rig, patch.data(), n, o.tolerance_m, dist, &a, &b, &t)) ++n;
    // (A copy onto another beacon is the better example than a symmetry about the beacon.)
    int onto = -1;
    FindMapCopies(rig, patch.data(), n, o.tolerance_m, dist, [&](const MapCopy& copy) {
      if (!FacingAgrees(rig, patch.data(), n, copy, o.facing_tolerance_rad)) return false;
      if (onto < 0 || onto == m) onto = copy.image[0];
      return onto != m;
    });
    const bool any = onto >= 0;
    if (!any) continue;
    ++result->repeated;
    result->repeated_beacons.Set(m);
    if (result->example < 0) result->example = m, result->example_copy = onto;
  }
  return true;
}

bool DescribeMapRepeats(const MapRepeatsResult& r, char* out, std::size_t size) {
  if (size > 0) out[0] = '\0';
  if (r.repeated == 0 || size == 0) return false;
  std::snprintf(out, size,
                "the beacon map repeats itself: %d of %d beacons lie in a patch that a rigid motion takes onto other "
                "beacons within %.0f mm (beacon %d onto beacon %d, 0-based); a view of them cannot be told from its "
                "copy, and the pose is found only from views with other beacons (reason \"map repeats this view\"; "
                "moving a few of them by some centimetres breaks the pattern)",
                r.repeated, r.beacons, 1e3 * r.tolerance_m, r.example, r.example_copy);
  return true;
}

}  // namespace mfns::fw
