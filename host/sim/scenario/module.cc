#include "host/sim/scenario/module.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "host/sim/scenario/sampling.h"

namespace mfns::host {
namespace {

constexpr double kTwoPi = 2.0 * 3.14159265358979323846;
constexpr std::uint32_t kMapStream = 0x3a9b1e55u;

// A wall as a 2-D patch: a rectangle (box face), the cylinder's curved wall unrolled (a along
// x, b the arc length) or an end disc (a the radius, b the angle). Point(a, b) is on the wall.
struct Patch {
  enum class Kind { kRect, kTube, kDisc } kind = Kind::kRect;
  double extent_a = 0.0, extent_b = 0.0;  // rect: sides; tube: length, circumference; disc: radius, -
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // rect: corner; disc: centre
  Eigen::Vector3d axis_a = Eigen::Vector3d::UnitY(), axis_b = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();  // inward (rect, disc)

  double Area() const {
    return kind == Kind::kDisc ? 0.5 * kTwoPi * extent_a * extent_a : extent_a * extent_b;
  }
  WallBeacon At(double a, double b) const {
    WallBeacon w;
    switch (kind) {
      case Kind::kRect:
        w.p_w = origin + a * axis_a + b * axis_b;
        w.normal_w = normal;
        break;
      case Kind::kTube: {
        const double radius = extent_b / kTwoPi, angle = b / radius;
        w.p_w = Eigen::Vector3d(a - 0.5 * extent_a, radius * std::cos(angle), radius * std::sin(angle));
        w.normal_w = Eigen::Vector3d(0.0, -std::cos(angle), -std::sin(angle));
        break;
      }
      case Kind::kDisc:
        w.p_w = origin + a * (std::cos(b) * axis_a + std::sin(b) * axis_b);
        w.normal_w = normal;
        break;
    }
    return w;
  }
};

std::vector<Patch> Walls(const StationModule& m, bool end_caps) {
  std::vector<Patch> walls;
  if (m.shape == ModuleShape::kBox) {
    const Eigen::Vector3d h = 0.5 * m.size;
    for (int i = end_caps ? 0 : 1; i < 3; ++i)
      for (const double s : {1.0, -1.0}) {
        const int j = (i + 1) % 3, k = (i + 2) % 3;
        Patch p;
        p.extent_a = m.size[j];
        p.extent_b = m.size[k];
        p.axis_a = Eigen::Vector3d::Unit(j);
        p.axis_b = Eigen::Vector3d::Unit(k);
        p.origin = s * h[i] * Eigen::Vector3d::Unit(i) - h[j] * p.axis_a - h[k] * p.axis_b;
        p.normal = -s * Eigen::Vector3d::Unit(i);
        walls.push_back(p);
      }
  } else if (m.shape == ModuleShape::kCylinder) {
    Patch tube;
    tube.kind = Patch::Kind::kTube;
    tube.extent_a = m.length;
    tube.extent_b = kTwoPi * 0.5 * m.diameter;
    walls.push_back(tube);
    for (int e = 0; end_caps && e < 2; ++e) {
      const double s = e == 0 ? 1.0 : -1.0;
      Patch disc;
      disc.kind = Patch::Kind::kDisc;
      disc.extent_a = 0.5 * m.diameter;
      disc.origin = Eigen::Vector3d(s * 0.5 * m.length, 0.0, 0.0);
      disc.normal = Eigen::Vector3d(-s, 0.0, 0.0);
      walls.push_back(disc);
    }
  }
  return walls;
}

// n split by weights, largest remainder (exact total; ties to the earlier entry).
std::vector<int> Apportion(int n, const std::vector<double>& weights) {
  const double total = std::accumulate(weights.begin(), weights.end(), 0.0);
  std::vector<int> out(weights.size());
  std::vector<std::pair<double, std::size_t>> rest;
  int given = 0;
  for (std::size_t i = 0; i < weights.size(); ++i) {
    const double share = n * weights[i] / total;
    out[i] = static_cast<int>(std::floor(share));
    given += out[i];
    rest.emplace_back(-(share - out[i]), i);
  }
  std::stable_sort(rest.begin(), rest.end());
  for (int i = 0; i < n - given; ++i) ++out[rest[static_cast<std::size_t>(i)].second];
  return out;
}

// Offset within +-jitter of a cell, uniformly.
double Jitter(double jitter, std::mt19937_64& rng) { return jitter * UniformIn(-1.0, 1.0, rng); }

// A rectangle (or the unrolled tube): rows of equal count (+-1) along b, about square cells.
void GridOnRect(const Patch& p, int n, double jitter, std::mt19937_64& rng, std::vector<WallBeacon>* out) {
  const double h = std::sqrt(p.Area() / n);
  const int rows = std::clamp(static_cast<int>(std::lround(p.extent_b / h)), 1, n);
  for (int i = 0; i < rows; ++i) {
    const int m = n * (i + 1) / rows - n * i / rows;
    const double cell_a = p.extent_a / m, cell_b = p.extent_b / rows;
    for (int j = 0; j < m; ++j) {
      const double a = (j + 0.5 + Jitter(jitter, rng)) * cell_a;
      const double b = (i + 0.5 + Jitter(jitter, rng)) * cell_b;
      WallBeacon w = p.At(a, b);
      w.cell_m = Eigen::Vector2d(cell_a, cell_b);
      out->push_back(w);
    }
  }
}

// A disc: rings of equal radial step, counts by circumference, staggered from ring to ring.
void GridOnDisc(const Patch& p, int n, double jitter, std::mt19937_64& rng, std::vector<WallBeacon>* out) {
  const double radius = p.extent_a, h = std::sqrt(p.Area() / n);
  const int rings = std::clamp(static_cast<int>(std::lround(radius / h)), 1, n);
  const double step = radius / rings;
  std::vector<double> circumference(static_cast<std::size_t>(rings));
  for (int i = 0; i < rings; ++i) circumference[static_cast<std::size_t>(i)] = (i + 0.5) * step;
  const std::vector<int> counts = Apportion(n, circumference);
  for (int i = 0; i < rings; ++i) {
    const int m = counts[static_cast<std::size_t>(i)];
    const double cell_angle = kTwoPi / std::max(m, 1);
    for (int j = 0; j < m; ++j) {
      const double r = (i + 0.5 + Jitter(jitter, rng)) * step;
      const double angle = (j + 0.5 * (i % 2) + Jitter(jitter, rng)) * cell_angle;
      WallBeacon w = p.At(r, angle);
      w.cell_m = Eigen::Vector2d(step, (i + 1) * step * cell_angle);  // arc at the cell's outer radius
      out->push_back(w);
    }
  }
}

WallBeacon RandomOn(const Patch& p, std::mt19937_64& rng) {
  if (p.kind == Patch::Kind::kDisc) {
    const double r = p.extent_a * std::sqrt(Uniform01(rng));  // area-uniform
    return p.At(r, kTwoPi * Uniform01(rng));
  }
  const double a = p.extent_a * Uniform01(rng);
  return p.At(a, p.extent_b * Uniform01(rng));
}

}  // namespace

int WallConstraints(const StationModule& m, const Eigen::Vector3d& p_w, std::array<WallConstraint, 6>* out) {
  int n = 0;
  const auto add = [&](const Eigen::Vector3d& n_out, double clearance) { (*out)[static_cast<std::size_t>(n++)] = {n_out, clearance}; };
  if (m.shape == ModuleShape::kBox) {
    for (int i = 0; i < 3; ++i) {
      add(Eigen::Vector3d::Unit(i), 0.5 * m.size[i] - p_w[i]);
      add(-Eigen::Vector3d::Unit(i), 0.5 * m.size[i] + p_w[i]);
    }
  } else if (m.shape == ModuleShape::kCylinder) {
    const Eigen::Vector3d radial(0.0, p_w.y(), p_w.z());
    const double rho = radial.norm();
    add(rho > 0.0 ? Eigen::Vector3d(radial / rho) : Eigen::Vector3d::UnitY(), 0.5 * m.diameter - rho);
    add(Eigen::Vector3d::UnitX(), 0.5 * m.length - p_w.x());
    add(-Eigen::Vector3d::UnitX(), 0.5 * m.length + p_w.x());
  }
  return n;
}

double WallClearance(const StationModule& m, const Eigen::Vector3d& p_w) {
  std::array<WallConstraint, 6> walls;
  const int n = WallConstraints(m, p_w, &walls);
  double clearance = std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i) clearance = std::min(clearance, walls[static_cast<std::size_t>(i)].clearance);
  return clearance;
}

Eigen::Vector3d UniformInside(const StationModule& m, double margin, std::mt19937_64* rng) {
  if (m.shape == ModuleShape::kBox) {
    Eigen::Vector3d p;
    for (int i = 0; i < 3; ++i) {
      const double h = 0.5 * m.size[i] - margin;
      p[i] = UniformIn(-h, h, *rng);
    }
    return p;
  }
  if (m.shape == ModuleShape::kCylinder) {
    const double h = 0.5 * m.length - margin, r_max = 0.5 * m.diameter - margin;
    const double x = UniformIn(-h, h, *rng);
    const double r = r_max * std::sqrt(Uniform01(*rng)), angle = kTwoPi * Uniform01(*rng);
    return {x, r * std::cos(angle), r * std::sin(angle)};
  }
  return Eigen::Vector3d::Zero();
}

std::vector<WallBeacon> GenerateWallBeacons(const StationModule& module, const BeaconLayout& layout,
                                            std::uint64_t seed) {
  std::mt19937_64 rng = SeededStream(seed, kMapStream);
  const std::vector<Patch> walls = Walls(module, layout.end_caps);
  std::vector<double> areas;
  for (const Patch& p : walls) areas.push_back(p.Area());
  std::vector<WallBeacon> out;
  if (walls.empty() || layout.count <= 0) return out;
  if (layout.layout == BeaconLayoutKind::kRandom) {
    const double total = std::accumulate(areas.begin(), areas.end(), 0.0);
    for (int i = 0; i < layout.count; ++i) {
      double pick = total * Uniform01(rng);
      std::size_t w = 0;
      while (w + 1 < walls.size() && pick >= areas[w]) pick -= areas[w++];
      out.push_back(RandomOn(walls[w], rng));
    }
    return out;
  }
  const std::vector<int> counts = Apportion(layout.count, areas);
  for (std::size_t w = 0; w < walls.size(); ++w) {
    if (counts[w] == 0) continue;
    if (walls[w].kind == Patch::Kind::kDisc) {
      GridOnDisc(walls[w], counts[w], layout.jitter, rng, &out);
    } else {
      GridOnRect(walls[w], counts[w], layout.jitter, rng, &out);
    }
  }
  return out;
}

}  // namespace mfns::host
