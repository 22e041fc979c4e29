// Test-only: synthetic observations for the solve and identify tests and benchmarks (no
// images): beacons projected through ProjectBeacon, Gaussian centroid noise, spurious blobs.
// Header-only, fixed storage, never allocates (the allocation checks run through it).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <random>

#include "common/camera/camera.h"
#include "common/rig/paper_rig.h"
#include "common/rig/rig.h"
#include "common/rotation/rotation.h"
#include "firmware/modules/solve/observation.h"

namespace mfns::fw::testing {

// Trial counts: MFNS_FAST_TESTS (set for qemu and sanitizer runs) asks for fewer trials of the
// same assertions.
inline int Trials(int full, int fast) {
  const char* env = std::getenv("MFNS_FAST_TESTS");
#ifdef MFNS_FAST_TESTS_DEFAULT
  const bool fast_mode = env == nullptr || env[0] != '0';
#else
  const bool fast_mode = env != nullptr && env[0] != '\0' && env[0] != '0';
#endif
  return fast_mode ? fast : full;
}

// One frame set: the blobs every camera sees and, per blob, the beacon it images (-1 for a
// spurious blob).
struct Scene {
  BodyPose pose;
  int num_blobs = 0;
  std::array<BlobObs, limits::kMaxObservations> blobs{};
  std::array<int, limits::kMaxObservations> truth_beacon{};
  std::array<int, limits::kMaxCameras> per_camera{};

  int NumVisibleBeacons() const {
    BeaconSet set;
    for (int i = 0; i < num_blobs; ++i) set.Set(truth_beacon[static_cast<std::size_t>(i)]);
    return set.Count();
  }
};

// Appends a blob at uv (noisy) of camera k; x_n through Unproject as the detector does.
inline bool AddBlob(const Rig& rig, int k, const Eigen::Vector2d& uv, int beacon, float flux, Scene* s) {
  if (s->num_blobs >= limits::kMaxObservations) return false;
  const auto sk = static_cast<std::size_t>(k);
  if (s->per_camera[sk] >= limits::kMaxBlobsPerFrame) return false;
  BlobObs& b = s->blobs[static_cast<std::size_t>(s->num_blobs)];
  b.camera = k;
  b.uv_px = uv;
  if (Unproject(rig.cameras[sk].intrinsics, uv, &b.x_n) != UnprojectStatus::kOk) return false;
  b.flux = flux;
  s->truth_beacon[static_cast<std::size_t>(s->num_blobs)] = beacon;
  ++s->num_blobs;
  ++s->per_camera[sk];
  return true;
}

// Every beacon in front of a camera whose image falls inside the image (shrunk by margin_px),
// with isotropic Gaussian noise sigma_px per axis. Blobs come camera by camera.
inline void Observe(const Rig& rig, const BodyPose& pose, double sigma_px, std::mt19937_64* rng,
                    Scene* s, double margin_px = 2.0) {
  s->pose = pose;
  s->num_blobs = 0;
  s->per_camera.fill(0);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int k = 0; k < rig.num_cameras; ++k) {
    const RigCamera& cam = rig.cameras[static_cast<std::size_t>(k)];
    for (int m = 0; m < rig.num_beacons; ++m) {
      const Eigen::Vector3d& P = rig.beacons_w[static_cast<std::size_t>(m)];
      if (!BeaconFaces(rig, m, pose.C_w_b * cam.r_b_bk + pose.r_w_wb)) continue;  // seen from behind
      const Eigen::Vector3d p_k = WorldToCamera(cam, pose, P);
      // Within 60 deg of the optic axis: the distortion model is not used beyond the lens.
      if (p_k.z() <= 0.0 || p_k.head<2>().norm() > std::tan(DegToRad(60.0)) * p_k.z()) continue;
      Eigen::Vector2d uv;
      if (ProjectBeacon(cam, pose, P, &uv) != ProjectStatus::kOk) continue;
      if (!InImage(cam.intrinsics, uv, margin_px)) continue;
      const Eigen::Vector2d n(noise(*rng), noise(*rng));
      const float flux = static_cast<float>(1000.0 / p_k.squaredNorm());
      AddBlob(rig, k, uv + sigma_px * n, m, flux, s);
    }
  }
}

// n spurious blobs (reflections) at random places of random cameras, as bright as beacons.
inline void AddSpurious(const Rig& rig, int n, std::mt19937_64* rng, Scene* s) {
  std::uniform_int_distribution<int> cam(0, rig.num_cameras - 1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int i = 0; i < n; ++i) {
    const int k = cam(*rng);
    const CameraIntrinsics& in = rig.cameras[static_cast<std::size_t>(k)].intrinsics;
    const Eigen::Vector2d uv(5.0 + unit(*rng) * (in.width - 10.0), 5.0 + unit(*rng) * (in.height - 10.0));
    AddBlob(rig, k, uv, -1, static_cast<float>(500.0 + 3000.0 * unit(*rng)), s);
  }
}

// n reflections: each a blob min_px..max_px from a randomly chosen beacon blob, in a random
// direction, in that blob's camera (truth -1); none when the scene has no beacon blob.
inline void AddReflections(const Rig& rig, int n, double min_px, double max_px, std::mt19937_64* rng, Scene* s) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int beacon_blobs = s->num_blobs;
  for (int i = 0; i < n && beacon_blobs > 0; ++i) {
    const auto j = static_cast<std::size_t>(std::min(beacon_blobs - 1, static_cast<int>(unit(*rng) * beacon_blobs)));
    if (s->truth_beacon[j] < 0) continue;
    const double r = min_px + (max_px - min_px) * unit(*rng), a = 2.0 * 3.14159265358979 * unit(*rng);
    const Eigen::Vector2d uv = s->blobs[j].uv_px + r * Eigen::Vector2d(std::cos(a), std::sin(a));
    const CameraIntrinsics& in = rig.cameras[static_cast<std::size_t>(s->blobs[j].camera)].intrinsics;
    if (uv.x() < 1.0 || uv.y() < 1.0 || uv.x() > in.width - 2.0 || uv.y() > in.height - 2.0) continue;
    AddBlob(rig, s->blobs[j].camera, uv, -1, s->blobs[j].flux, s);
  }
}

// The paper's yaw sweep: body at the world origin, yawed by psi about z (C_b_w = R3(psi)).
inline BodyPose YawPose(double psi_rad) {
  BodyPose p;
  p.C_w_b = R3(psi_rad).transpose();
  return p;
}

inline Eigen::Matrix3d RandomRotation(std::mt19937_64* rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(*rng), n(*rng), n(*rng), n(*rng));
  q.normalize();
  return q.toRotationMatrix();
}

// A 2 x 2 x 2 m module centred on the world origin with num_beacons beacons on its walls (at
// least 0.1 m from the edges) and the paper's three cameras.
inline Rig RandomBoxRig(int num_beacons, std::mt19937_64* rng) {
  Rig rig = PaperRig();
  rig.num_beacons = num_beacons;
  std::uniform_real_distribution<double> u(-0.9, 0.9);
  std::uniform_int_distribution<int> wall(0, 5);
  for (int i = 0; i < num_beacons; ++i) {
    const int w = wall(*rng);
    Eigen::Vector3d p(u(*rng), u(*rng), u(*rng));
    p[w / 2] = (w % 2 == 0) ? -1.0 : 1.0;
    rig.beacons_w[static_cast<std::size_t>(i)] = p;
  }
  return rig;
}

// A cube of side 2 m centred on the origin with a 4 x 4 grid of beacons 0.5 m apart on each of
// its six walls (wall w = beacons 16 w .. 16 w + 15), facing in with a 60 deg beam, and the
// paper's three cameras. Each beacon is moved along its wall by up to jitter_m (uniform, from
// rng), except on the walls set in exact_walls (bit w). A regular layout: every view of the
// exact grid has congruent copies (map_repeats.h).
inline Rig CubeGridRig(double jitter_m = 0.0, unsigned exact_walls = 0x3F, std::mt19937_64* rng = nullptr) {
  Rig rig = PaperRig();
  rig.num_beacons = 0;
  rig.has_facing = true;
  std::uniform_real_distribution<double> u(-jitter_m, jitter_m);
  const auto offset = [&](bool exact) { return exact || rng == nullptr ? 0.0 : u(*rng); };
  for (int w = 0; w < 6; ++w)
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) {
        const auto i = static_cast<std::size_t>(rig.num_beacons++);
        const int axis = w / 2;
        const double side = w % 2 == 0 ? -1.0 : 1.0;
        const bool exact = ((exact_walls >> w) & 1U) != 0;
        Eigen::Vector3d p;
        p[axis] = side;
        p[(axis + 1) % 3] = -0.75 + 0.5 * a + offset(exact);
        p[(axis + 2) % 3] = -0.75 + 0.5 * b + offset(exact);
        rig.beacons_w[i] = p;
        rig.beacon_normal_w[i] = -side * Eigen::Vector3d::Unit(axis);
        rig.beacon_half_angle[i] = DegToRad(60.0);
      }
  return rig;
}

// A cylindrical station module (axis along x, diameter 2 radius_m, length length_m, centred on
// the origin) with num_beacons beacons uniformly on its wall and end caps, each facing inward
// with a 60 deg beam half-angle (has_facing as given), and the paper's three cameras.
inline Rig RandomCylinderRig(int num_beacons, bool facing, std::mt19937_64* rng, double radius_m = 2.1,
                             double length_m = 6.0) {
  Rig rig = PaperRig();
  rig.beacon_sigma = 0.0;
  rig.num_beacons = num_beacons;
  rig.has_facing = facing;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double cap = kPi * radius_m * radius_m, wall = 2.0 * kPi * radius_m * length_m;
  for (int i = 0; i < num_beacons; ++i) {
    const auto si = static_cast<std::size_t>(i);
    const double s = u(*rng) * (wall + 2.0 * cap), th = 2.0 * kPi * u(*rng);
    if (s < wall) {
      rig.beacons_w[si] = Eigen::Vector3d((u(*rng) - 0.5) * length_m, radius_m * std::cos(th), radius_m * std::sin(th));
      rig.beacon_normal_w[si] = Eigen::Vector3d(0.0, -std::cos(th), -std::sin(th));
    } else {
      const double r = radius_m * std::sqrt(u(*rng)), side = s < wall + cap ? -1.0 : 1.0;
      rig.beacons_w[si] = Eigen::Vector3d(side * length_m / 2, r * std::cos(th), r * std::sin(th));
      rig.beacon_normal_w[si] = Eigen::Vector3d(-side, 0.0, 0.0);
    }
    rig.beacon_half_angle[si] = DegToRad(60.0);
  }
  return rig;
}

// A random pose in that cylinder, the body at least margin_m from its walls.
inline BodyPose RandomCylinderPose(std::mt19937_64* rng, double radius_m = 2.1, double length_m = 6.0,
                                   double margin_m = 0.3) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  BodyPose p;
  p.C_w_b = RandomRotation(rng);
  do {
    p.r_w_wb = Eigen::Vector3d(u(*rng) * (length_m / 2 - margin_m), u(*rng) * (radius_m - margin_m),
                               u(*rng) * (radius_m - margin_m));
  } while (p.r_w_wb.tail<2>().norm() > radius_m - margin_m);
  return p;
}

// A random pose inside the module, the body at least 0.4 m from every wall.
inline BodyPose RandomBoxPose(std::mt19937_64* rng) {
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  BodyPose p;
  p.C_w_b = RandomRotation(rng);
  p.r_w_wb = Eigen::Vector3d(u(*rng), u(*rng), u(*rng));
  return p;
}

// Rotation angle between two attitudes, rad.
inline double AngleBetween(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  return LogSO3(A.transpose() * B).norm();
}

}  // namespace mfns::fw::testing
