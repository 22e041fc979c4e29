// Synthetic calibration scenes for the calibration tests, mirroring the geometry of
// `mfns-sim calib-dataset --preset paper-calibration` (docs/calib-dataset.md): the paper's rig
// (Tables 2, 3), a 9x7 checkerboard of 30 mm squares overhead, the body ~577 mm below it on
// the platform 108 mm above Ot; camera z looks up at aux ~ 0, camera y at (main, aux) ~
// (0, -90) deg, camera x at (90, -90) deg; 11 turntable images per camera, each at random
// within +-variation_deg of that pose keeping every corner in view, and 10 free
// hand-held views per camera. True angles = commanded + N(0, 8 arcsec).
//
// The target frame is host/core/target.h's (printed face towards +z_w): with the board
// overhead its face looks down, so z_w points down and C_w_t ~ Rx(180 deg) times the small
// misalignment of Table 3.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/rig/rig.h"
#include "host/calib/core/calib_types.h"
#include "host/calib/core/kinematics.h"
#include "host/core/target.h"

namespace mfns::host {

struct SynthOptions {
  std::uint64_t seed = 1;
  double image_scale = 1.0;  // 0.5: 640x512 cameras (alpha, u0, v0 halved), same geometry
  int turntable_images = 11;
  int free_images = 10;
  double variation_deg = 15.0;
  CheckerboardSpec board{9, 7, 0.03, 0.03};
  double margin_px = 12.0;
  double free_max_tilt_deg = 40.0;  // free views: angle of the optic axis to the board normal
  bool single_axis = false;  // turntable images turn about one axis at a time (the paper's A8/A9 images)
  double angle_sigma = 8.0 / 3600.0 * 3.14159265358979323846 / 180.0;  // rad
};

struct SynthImage {
  int camera = 0;
  std::string image;
  ImageKind kind = ImageKind::kTurntable;
  double main_cmd = 0, aux_cmd = 0, main_true = 0, aux_true = 0;  // rad
  Transform T_w_k;  // true camera pose (C_w_k, r_w_wk)
};

struct SynthScene {
  Rig rig;  // truth
  TurntableMount mount;
  CalibrationTarget target = CalibrationTarget::Checkerboard(CheckerboardSpec{});
  std::vector<SynthImage> images;
  double angle_sigma = 0;
};

SynthScene MakeSynthScene(const SynthOptions& options);

// Corner observations: every visible corner's true projection plus N(0, pixel_sigma^2) per
// axis (seeded), the commanded angles, and the true mount as the gauge.
CalibInput SynthCorners(const SynthScene& scene, double pixel_sigma, std::uint64_t seed);

// How rendered images look (host/sim/render). The defaults give findChessboardCornersSB
// corners with about 0.09 px error per axis, near Table 2's 0.1 px (measured: 0.033 px per axis
// at 400 e, read noise 4 e, blur 0.8 px; 0.13 px at 60 e, 8 e, 1.0 px).
struct SynthRender {
  double illumination_e = 80.0;
  double read_noise_e = 6.0;
  double blur_sigma_px = 1.0;
  bool noise = true;
};

// Writes the scene as a dataset directory in the documented format (target.yaml, images.csv,
// images/<camera>/<image>.pgm, truth-rig.yaml, truth.yaml, corners.csv). Renders with
// host/sim/render (TargetRenderer); seeded.
void WriteSynthDataset(const SynthScene& scene, const SynthRender& render, std::uint64_t seed,
                       const std::filesystem::path& dir);

}  // namespace mfns::host
