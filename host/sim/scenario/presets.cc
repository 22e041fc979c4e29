#include <map>

#include "host/sim/scenario/scenario.h"
#include "host/util/user_error.h"

// Built-in scenarios (DESIGN.md, "Simulator"). Each is plain scenario YAML, so
// `mfns-sim preset NAME > my.yaml` is the way to start a custom one.
namespace mfns::host {
namespace {

// Section 5 of the paper: the flyer on the turntable at the world origin (platform centre),
// Table 4 beacons, Table 2/3 rig, the turntable turning about Zt in 1 deg steps. Centroid noise
// only by default (the other error sources are here, switched off, to turn on).
constexpr char kPaperTurntable[] = R"(name: paper-turntable
seed: 1
rig: paper                # Tables 2 and 3, with Table 4 beacons
frame_rate_hz: 18.6
frames: 360
turntable:
  C_w_t_euler_deg: [0, 0, 0]
  r_w_wt_mm: [0, 0, 0]
  mount_euler_deg: [0, 0, 0]
  mount_r_p_pb_mm: [0, 0, 0]
trajectory:
  kind: turntable
  mode: steps
  main_start_deg: 0
  main_step_deg: 1
errors:
  pixel_noise: {enabled: true, centroid_sigma_px: 0.1}
  beacon_map: {enabled: false, sigma_mm: 0.4}
  intrinsics: {enabled: false, scale: 1.0}
  extrinsic_rotation: {enabled: false, sigma_deg: 0.1}
  extrinsic_translation: {enabled: false, sigma_mm: 0.6}
  turntable_angle: {enabled: false, sigma_arcsec: 8}
  turntable_axis: {enabled: true, sigma_arcsec: 5}   # the surveyed axis (turntable-survey.yaml)
sensor:
  psf_sigma_px: 1.0
  flux_e_at_1m: 12000
  background_e: 400
  gain_e_per_dn: 40
  read_noise_e: 10
  full_well_e: 10200
)";

// A free flight through a 2 x 2 x 2 m module (walls at +-1 m) with 10 LEDs on each wall.
constexpr char kFreeFlight[] = R"(name: free-flight
seed: 1
rig: paper
frame_rate_hz: 18.6
frames: 600
beacon_sigma_mm: 0.4
trajectory:
  kind: free-flight
  centre_mm: [0, 0, 0]
  amplitude_mm: [350, 350, 300]
  period_s: 30
  tilt_deg: 20
  yaw_rate_deg_s: 12
errors:
  pixel_noise: {enabled: true, centroid_sigma_px: 0.1}
sensor:
  psf_sigma_px: 1.0
  flux_e_at_1m: 12000
  background_e: 400
  gain_e_per_dn: 40
  read_noise_e: 10
  full_well_e: 10200
beacons_mm:
  - [-1000.0, -563.8, -702.6]
  - [-1000.0, -591.4, -32.2]
  - [-1000.0, -706.1, 601.8]
  - [-1000.0, -111.0, -615.9]
  - [-1000.0, -103.2, -98.2]
  - [-1000.0, -18.1, 678.4]
  - [-1000.0, 509.7, -666.4]
  - [-1000.0, 630.6, 107.5]
  - [-1000.0, 618.5, 575.2]
  - [-1000.0, 8.6, -318.3]
  - [1000.0, -685.4, -691.7]
  - [1000.0, -646.0, 75.9]
  - [1000.0, -676.6, 619.6]
  - [1000.0, 33.3, -630.6]
  - [1000.0, 11.5, -104.9]
  - [1000.0, -105.7, 529.4]
  - [1000.0, 643.3, -617.4]
  - [1000.0, 555.4, 20.5]
  - [1000.0, 588.8, 551.9]
  - [1000.0, 285.7, -78.5]
  - [-594.0, -1000.0, -510.0]
  - [-544.9, -1000.0, -50.9]
  - [-484.8, -1000.0, 508.3]
  - [-19.7, -1000.0, -538.3]
  - [-83.5, -1000.0, -2.6]
  - [-110.6, -1000.0, 640.4]
  - [663.5, -1000.0, -582.5]
  - [690.1, -1000.0, -44.7]
  - [646.9, -1000.0, 622.6]
  - [-134.4, -1000.0, 34.1]
  - [-606.2, 1000.0, -560.6]
  - [-705.4, 1000.0, 48.4]
  - [-564.7, 1000.0, 718.3]
  - [77.3, 1000.0, -651.7]
  - [-27.4, 1000.0, 40.5]
  - [-114.6, 1000.0, 590.8]
  - [520.3, 1000.0, -691.9]
  - [494.1, 1000.0, 64.4]
  - [511.0, 1000.0, 539.4]
  - [177.8, 1000.0, 355.9]
  - [-588.1, -508.0, -1000.0]
  - [-523.4, 87.4, -1000.0]
  - [-653.2, 579.7, -1000.0]
  - [-33.9, -507.8, -1000.0]
  - [109.9, -83.8, -1000.0]
  - [-77.7, 535.7, -1000.0]
  - [536.0, -603.6, -1000.0]
  - [621.4, -56.9, -1000.0]
  - [481.0, 580.5, -1000.0]
  - [-283.0, -14.6, -1000.0]
  - [-596.3, -571.8, 1000.0]
  - [-557.7, -107.0, 1000.0]
  - [-504.1, 667.2, 1000.0]
  - [89.9, -528.5, 1000.0]
  - [-25.8, -24.2, 1000.0]
  - [-95.2, 632.2, 1000.0]
  - [494.9, -703.8, 1000.0]
  - [530.1, -81.0, 1000.0]
  - [561.6, 492.6, 1000.0]
  - [151.9, 30.6, 1000.0]
)";

// Station modules (host/sim/scenario/README.md): the paper rig wandering from a random start
// (uniform position 0.3 m from the walls, uniform attitude) through a module whose walls carry
// LEDs facing inward with a 60 deg beam. Brighter LEDs than the lab's turntable (~50 DN peak at
// 3 m). The error sources are here, switched off (count 0), to turn on.
constexpr char kStationCylinder[] = R"(name: station-cylinder
seed: 1
rig: paper
frame_rate_hz: 18.6
frames: 600
module: {shape: cylinder, diameter_mm: 4200, length_mm: 6000}   # axis along world x, centred at the origin
beacons: {layout: jittered-grid, count: 128, jitter: 0.25, end_caps: true, half_angle_deg: 60, facing: true}
beacon_sigma_mm: 0.4
trajectory:
  kind: wander
  margin_mm: 300
  max_speed_mm_s: 300
  max_accel_mm_s2: 100
  max_rate_deg_s: 28.6
  max_angular_accel_deg_s2: 28.6
  correlation_s: 5
errors:
  pixel_noise: {enabled: true, centroid_sigma_px: 0.1}
  beacon_map: {enabled: false, sigma_mm: 0.4}
sensor:
  psf_sigma_px: 1.0
  flux_e_at_1m: 120000
  background_e: 400
  gain_e_per_dn: 40
  read_noise_e: 10
  full_well_e: 10200
  edge_margin_px: 2
clutter:
  reflection_flux_scale: 0.3
  spurious: {count: 0, near_fraction: 0.5, near_radius_px: [5, 40], static_reflections: 0}
  # occlusions: [{frames: [100, 199], camera: x, rect_px: [0, 0, 640, 1024]}]
  # blinded: [{camera: y, frames: [300, 340], mode: saturated}]
)";

constexpr char kStationBox[] = R"(name: station-box
seed: 1
rig: paper
frame_rate_hz: 18.6
frames: 600
module: {shape: box, size_mm: [5000, 2200, 2200]}   # long axis along world x, centred at the origin
beacons: {layout: jittered-grid, count: 96, jitter: 0.25, end_caps: true, half_angle_deg: 60, facing: true}
beacon_sigma_mm: 0.4
trajectory:
  kind: wander
  margin_mm: 300
  max_speed_mm_s: 300
  max_accel_mm_s2: 100
  max_rate_deg_s: 28.6
  max_angular_accel_deg_s2: 28.6
  correlation_s: 5
errors:
  pixel_noise: {enabled: true, centroid_sigma_px: 0.1}
  beacon_map: {enabled: false, sigma_mm: 0.4}
sensor:
  psf_sigma_px: 1.0
  flux_e_at_1m: 120000
  background_e: 400
  gain_e_per_dn: 40
  read_noise_e: 10
  full_well_e: 10200
  edge_margin_px: 2
clutter:
  reflection_flux_scale: 0.3
  spurious: {count: 0, near_fraction: 0.5, near_radius_px: [5, 40], static_reflections: 0}
)";

// Section 4.2 of the paper: the target fixed overhead (printed face down, towards the rig, so
// z_w points down and C_w_t = R1(180 deg) times Table 3's small alignment residual), the flyer
// on the turntable 577 mm below it (Table 3's measured height), 11 turntable images per camera
// plus 10 hand-held views per camera, 8 arcsec turntable angle error.
constexpr char kPaperCalibration[] = R"(name: paper-calibration
seed: 1
rig: paper
turntable:
  C_w_t_euler_deg: [179.989, 0.1263, -0.0861]
  r_w_wt_mm: [46.0, 81.0, 577.0]
  mount_euler_deg: [0, 0, 0]
  mount_r_p_pb_mm: [0, 0, 0]
errors:
  pixel_noise: {enabled: true}
  turntable_angle: {enabled: true, sigma_arcsec: 8}
sensor:
  gain_e_per_dn: 40
  read_noise_e: 10
  full_well_e: 10200
target: {type: checkerboard, cols: 9, rows: 6, square_mm: 20}
calibration:
  turntable_images: 11
  free_images: 10
  variation_deg: 8
  free_distance_mm: [350, 600]
  free_tilt_deg: 35
  illumination_e: 9400
  blur_sigma_px: 0.6
  vignetting: true
)";

const std::map<std::string, std::string>& Presets() {
  static const std::map<std::string, std::string> presets = {
      {"paper-turntable", kPaperTurntable},
      {"free-flight", kFreeFlight},
      {"paper-calibration", kPaperCalibration},
      {"station-cylinder", kStationCylinder},
      {"station-box", kStationBox},
  };
  return presets;
}

}  // namespace

std::vector<std::string> PresetNames() {
  std::vector<std::string> names;
  for (const auto& [name, text] : Presets()) names.push_back(name);
  return names;
}

std::string PresetYaml(const std::string& name) {
  const auto it = Presets().find(name);
  if (it == Presets().end()) {
    std::string known;
    for (const auto& n : PresetNames()) known += (known.empty() ? "" : ", ") + n;
    throw UserError("unknown preset '" + OneLine(name) + "' (known: " + known + ")");
  }
  return it->second;
}

}  // namespace mfns::host
