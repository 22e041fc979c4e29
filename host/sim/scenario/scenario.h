// Simulation scenarios (issue 3): rig, beacons, trajectory, turntable, error sources, sensor
// and clutter, read from YAML, deterministic for a seed. Built-in presets are YAML text too
// (`mfns-sim preset NAME` prints one to start a custom scenario from).
//
// Truth and belief: the scenario's rig and beacons are the TRUTH the images are rendered from.
// The enabled error sources perturb them (seeded) into the BELIEVED rig: what a navigator
// would load from an imperfect calibration and beacon survey. Turntable angle error acts the
// other way round: the commanded angle is what the user records, the true one moves the body.
// Units: SI inside (m, rad, s); the YAML carries _mm, _deg, _arcsec, _px, _hz.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/rig/rig.h"
#include "host/sim/scenario/module.h"
#include "host/sim/scenario/wander.h"
#include "host/util/user_error.h"

namespace mfns::host {

enum class TrajectoryKind { kStatic, kTurntable, kFreeFlight, kWander };

// Two-axis turntable (paper Section 4, Appendix A): the inner main axis Zt carries the
// platform; the outer auxiliary axis Xt tilts the whole inner assembly (as on inertial test
// tables). Both axes pass through Ot. Platform attitude C_t_p = Rx(aux) * Rz(main) with active
// rotations (frame form: R1(aux)^T R3(main)^T): main alone is eq. A5, aux alone eq. A9. The
// body is mounted on the platform with C_p_b, r_p_pb. The turntable sits in the world with
// C_w_t, r_w_wt.
struct Turntable {
  Eigen::Matrix3d C_w_t = Eigen::Matrix3d::Identity();
  Eigen::Vector3d r_w_wt = Eigen::Vector3d::Zero();
  Eigen::Matrix3d C_p_b = Eigen::Matrix3d::Identity();
  Eigen::Vector3d r_p_pb = Eigen::Vector3d::Zero();
};

// Body pose for turntable angles (rad).
BodyPose TurntablePose(const Turntable& tt, double main_rad, double aux_rad);

struct Trajectory {
  TrajectoryKind kind = TrajectoryKind::kStatic;
  // kStatic: one pose.
  BodyPose static_pose;
  // kTurntable: angle of frame i = start + i * step (steps) or start + rate * t (rate).
  bool turntable_rate_mode = false;
  double main_start = 0.0, main_step = 0.0, main_rate = 0.0;  // rad, rad, rad/s
  double aux_start = 0.0, aux_step = 0.0, aux_rate = 0.0;
  // kFreeFlight: smooth path about centre: per axis a sum of two sinusoids (seeded phases)
  // with the given amplitude; attitude: roll/pitch oscillate within +-tilt, yaw turns at
  // yaw_rate plus an oscillation.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d amplitude = Eigen::Vector3d::Zero();  // m
  double period_s = 20.0;
  double tilt = 0.0;       // rad
  double yaw_rate = 0.0;   // rad/s
  // kWander (needs a module): a free-flyer's smooth random motion (wander.h). Start position
  // uniform in the module shrunk by `margin`, attitude uniform on SO(3); velocity and body
  // rate follow seeded random commands (correlation time `correlation_s`) with bounded
  // accelerations, and the flyer keeps `margin` from every wall.
  WanderLimits wander;
};

// Error sources, each switchable with its magnitude (paper Section 3).
struct ErrorSources {
  // Pixel noise: sensor noise (shot, read) in rendered images, plus a random offset of each
  // rendered spot of centroid_sigma_px per axis (the LED's and optics' irregularities that
  // make real centroids scatter by ~0.1 px, Table 2's pixel error). Observation-level
  // simulations and the Cramér-Rao bound use centroid_sigma_px.
  bool pixel_noise = true;
  double centroid_sigma_px = 0.1;
  bool beacon_map = false;
  double beacon_sigma = 0.4e-3;       // m, per coordinate (Table 4: 0.3963 mm)
  bool intrinsics = false;
  double intrinsics_scale = 1.0;      // draws from the rig's sigma (Table 2 when absent) x scale
  bool extrinsic_rotation = false;
  double extrinsic_rotation_sigma = 0.1 * 3.14159265358979323846 / 180.0;  // rad per axis
  bool extrinsic_translation = false;
  double extrinsic_translation_sigma = 0.6e-3;  // m per axis
  bool turntable_angle = true;
  double turntable_angle_sigma = 8.0 / 3600.0 * 3.14159265358979323846 / 180.0;  // rad
  // The turntable's placement as surveyed (SurveyedTurntable): its centre with the beacons'
  // instrument (beacon_sigma, when beacon_map is on), its axis levelled to this 1-sigma.
  bool turntable_axis = true;
  double turntable_axis_sigma = 5.0 / 3600.0 * 3.14159265358979323846 / 180.0;  // rad
};

// Image formation of LED beacons (host/sim/render).
struct SensorSetup {
  bool mono16 = false;
  double psf_sigma_px = 1.0;     // Gaussian blur of the LED image
  double flux_e_at_1m = 12000;   // electrons from one LED at 1 m (falls off as 1/d^2): ~240 DN peak at 0.45 m
  double background_e = 400;     // electrons per pixel of ambient light
  double gain_e_per_dn = 40;     // electrons per digital number
  double read_noise_e = 10;      // electrons rms
  double full_well_e = 10200;    // saturation (255 DN at the gain above)
  // A spot whose centre is closer than this to the image border is drawn but is no blob (a
  // detector loses truncated spots): blobs.csv, the blob-level simulation and the bound agree.
  double edge_margin_px = 0.0;
};

// Clutter and the error sources of a station (scenario YAML `clutter:`, host/sim/scenario/
// README.md). Frame windows are inclusive [first, last]. Everything here acts on the images and
// the blob lists alike (host/sim/observe decides, the renderer draws what it decides).
struct Clutter {
  int reflections_per_frame = 0;      // random extra spots per camera per frame
  double reflection_flux_scale = 0.5; // relative to a beacon at 1 m (near reflections: to their beacon)
  // Spurious blobs per camera per frame set, beside reflections_per_frame: round(near_fraction
  // x spurious) of them reflections of a visible beacon, near_radius_px from its image (a camera
  // seeing none gets random spots instead), the rest random spots anywhere in the image.
  int spurious = 0;
  double near_fraction = 0.5;
  double near_radius_min_px = 5.0, near_radius_max_px = 40.0;
  // Static reflections: unmapped points on the module's walls (drawn from the map seed), each
  // with the beacons' beam, imaged like a beacon of reflection_flux_scale brightness: they move
  // with the scene. `reflectors` holds them as a rig (the truth rig's cameras, the points as
  // its beacons) so the one visibility decision (SightBeacon) applies.
  int static_reflections = 0;
  Rig reflectors;
  // A crew member in the way: during the window, the beacons listed (all when none are) whose
  // true image in `camera` (any camera when -1) falls in rect_px (anywhere when has_rect is
  // false) are not seen: not drawn, no blob.
  struct Occlusion {
    int first_frame = 0, last_frame = 0;
    int camera = -1;
    bool has_rect = false;
    Eigen::Vector4d rect_px = Eigen::Vector4d::Zero();  // u0, v0, u1, v1
    std::vector<int> beacons;
  };
  std::vector<Occlusion> occlusions;
  // A camera blinded (sun, lamp) during the window: it still delivers frames, with no blobs;
  // the frame is saturated (every pixel at full scale) or black.
  struct Blinding {
    int camera = 0;
    int first_frame = 0, last_frame = 0;
    bool saturated = true;
  };
  std::vector<Blinding> blinded;
  struct Region {
    int camera = 0;
    Eigen::Vector4d rect_px = Eigen::Vector4d::Zero();  // x0, y0, x1, y1
    double level_e = 0;
  };
  std::vector<Region> bright_regions;
  std::vector<int> occluded_beacons;   // never rendered
  int stop_camera = -1;                // this camera delivers blank frames from stop_frame on
  int stop_frame = 0;
};

// A calibration session (paper Section 4.2; `mfns-sim calib-dataset`): a fixed target (the
// world frame w is the target frame, host/sim/render/target.h), the flyer on the turntable at
// recorded angles (turntable_images per camera) plus hand-held views (free_images per camera).
struct CalibrationSetup {
  bool present = false;
  bool aprilgrid = false;
  int cols = 9, rows = 6;            // checkerboard inner corners, or AprilGrid tags
  double square = 0.03;              // m: checkerboard square, or AprilGrid tag size
  double tag_spacing = 0.3;          // AprilGrid gap / tag size
  int turntable_images = 11;         // per camera
  int free_images = 10;              // per camera
  double variation = 15.0 * 3.14159265358979323846 / 180.0;  // turntable offsets, rad
  double free_distance_min = 0.35, free_distance_max = 0.6;    // m
  double free_tilt = 35.0 * 3.14159265358979323846 / 180.0;   // rad, of the view to the normal
  double illumination_e = 9400;      // white paper ~200 DN at the default gain
  double blur_sigma_px = 0.6;
  bool vignetting = true;            // cos^4
};

struct Scenario {
  std::string name;
  std::uint64_t seed = 1;        // trajectory, believed rig, noise and clutter draws
  Rig rig;                       // truth: rig and beacons (with their facing, when known)
  StationModule module;          // ModuleShape::kNone: no module
  BeaconLayout beacon_layout;    // present: rig.beacons_w were generated on the module's walls
  std::uint64_t map_seed = 1;    // the generated map's: beacons.seed, else `seed`
  // The navigator's maps (rig.yaml, believed-rig.yaml) carry the beacons' facing. false: the
  // LEDs still have their beams (the truth renders with them), the maps do not say so.
  bool map_facing = true;
  double frame_rate_hz = 18.6;
  int frames = 1;
  std::int64_t t0_ns = 1'000'000'000;
  Turntable turntable;
  Trajectory trajectory;
  ErrorSources errors;
  SensorSetup sensor;
  Clutter clutter;
  CalibrationSetup calibration;
};

// Names of the built-in presets and their YAML text.
std::vector<std::string> PresetNames();
std::string PresetYaml(const std::string& name);  // throws UserError for an unknown name

// Parses scenario YAML. `base_dir` resolves a relative `rig:` path. Throws UserError naming the
// source, line and field.
Scenario ParseScenarioYaml(const std::string& text, const std::string& source,
                           const std::filesystem::path& base_dir);
Scenario LoadPreset(const std::string& name);
Scenario LoadScenarioFile(const std::filesystem::path& path);

// One frame set of a scenario: sample time, true pose, turntable angles (commanded and true).
struct FrameTruth {
  int frame = 0;
  std::int64_t t_ns = 0;
  BodyPose pose;
  double main_cmd = 0, aux_cmd = 0, main_true = 0, aux_true = 0;  // rad (turntable only)
};

// The whole trajectory; turntable angle errors drawn from the scenario's seed.
std::vector<FrameTruth> SimulateTrajectory(const Scenario& s);

// The believed rig: truth perturbed by the enabled error sources (seeded, independent of the
// trajectory's draws). Its beacon_sigma is the survey error's when beacon_map is enabled, else
// 0 (the believed map is the true one). Facing data only when map_facing.
Rig BelievedRig(const Scenario& s);

// A turntable run's placement as a user surveys it (issue 16; `DIR/turntable-survey.yaml` of a
// rendered turntable run), never the truth: the centre Ot (where the axes meet, r_w_wt) drawn
// about the truth with beacon_sigma per coordinate when beacon_map is on (else exact), and the
// main axis Zt in the world at the run's first auxiliary angle (C_w_t R1(aux)^T e_z) turned by
// turntable_axis_sigma per direction across it when turntable_axis is on. The centre in the body
// is the mount's (-C_p_b^T r_p_pb: the mount defines the body frame, docs/calibration.md), exact.
// Seeded from the scenario's seed, independent of the trajectory's and BelievedRig's draws.
struct SurveyedTurntable {
  Eigen::Vector3d centre_w = Eigen::Vector3d::Zero();  // m
  double centre_sigma = 0.0;                           // m, 0: exact
  Eigen::Vector3d centre_b = Eigen::Vector3d::Zero();  // m: the mount, which defines the body frame
  // How well the body frame the rig calibration realises knows the mount (m): its cameras'
  // positions are held to a few hundredths of a millimetre (the demo's calibration: ~0.02 mm).
  double centre_b_sigma = 0.05e-3;
  Eigen::Vector3d axis_w = Eigen::Vector3d::UnitZ();   // unit
  double axis_sigma = 0.0;                             // rad, 0: exact
};
SurveyedTurntable SurveyTurntable(const Scenario& s);

// The true rig as a navigator would load it (rig.yaml): exact map (beacon_sigma 0), facing
// data only when map_facing.
Rig TruthMapRig(const Scenario& s);

}  // namespace mfns::host
