// Calibration-target images: a planar target (target.h) seen by a camera at a pose, rendered
// by inverse mapping through the full camera model, with exact area-sampled edges, then
// vignetting, optical blur and the sensor model (sensor.h). Truth: each corner's projection.
//
// Rendering: every pixel corner (u - .5, v - .5) is unprojected once per camera
// (mfns::Unproject) to a ray; per pose each ray is intersected with the target plane z = 0.
// A pixel's footprint on the plane is the quadrilateral of its 4 corner points (exact to
// second order in the pixel size: distortion and perspective are smooth over one pixel). A
// footprint inside one cell of the pattern takes that cell's reflectance; a footprint that
// crosses cell edges is clipped against each cell it touches (Sutherland-Hodgman) and takes
// the area-weighted mean reflectance: anti-aliased edges with no sampling noise. Footprints
// spanning more than 64 cells (only near the horizon of a grazing view) fall back to 4x4
// point samples; pixels whose rays miss the plane see the background.
//   signal_e(u, v) = illumination_e * vignetting(ray) * reflectance,   then Gaussian blur.
#pragma once

#include <Eigen/Core>
#include <array>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "common/camera/camera.h"
#include "host/sim/render/sensor.h"
#include "host/core/target.h"
#include "host/sim/render/visibility.h"

namespace mfns::host {

// Camera k relative to the target (world) frame w: p_k = C_k_w * (P_w - r_w_wk), with C_k_w
// mapping w coordinates to camera k (common/rotation/rotation.h conventions) and r_w_wk the
// camera's projection centre in w (m). The camera sees the printed face when r_w_wk.z() > 0.
struct CameraPose {
  Eigen::Matrix3d C_k_w = Eigen::Matrix3d::Identity();
  Eigen::Vector3d r_w_wk = Eigen::Vector3d::Zero();
};

// A camera at eye_w whose optic axis (+z_k) goes through look_at_w and whose image "down"
// (+y_k) is as close to down_w as possible. The default down_w = -y_w shows a target upright.
// Throws std::invalid_argument when eye == look_at or down_w is parallel to the optic axis.
CameraPose LookAt(const Eigen::Vector3d& eye_w, const Eigen::Vector3d& look_at_w,
                  const Eigen::Vector3d& down_w = -Eigen::Vector3d::UnitY());

enum class Vignetting : unsigned char {
  kNone,
  kCos4,        // V = cos^4(angle of the ray to the optic axis) = 1 / (1 + r^2)^2
  kPolynomial,  // V = 1 + c0 r^2 + c1 r^4 + c2 r^6 (clamped at 0)
};                // r^2 = x^2 + y^2 of the undistorted normalised ray (x, y) = (X/Z, Y/Z)

// Light and optics of a calibration image. Signals are expected electrons.
struct TargetPhotometry {
  double illumination_e = 200.0;      // electrons from a reflectance-1 surface on the axis
  double white_reflectance = 0.85;    // paper
  double black_reflectance = 0.05;    // ink
  double background_reflectance = 0.3;  // the scene around the target (rays that miss it)
  double back_reflectance = 0.3;      // the board seen from behind
  Vignetting vignetting = Vignetting::kNone;
  std::array<double, 3> vignetting_coeffs{};  // c0, c1, c2 for kPolynomial
  double blur_sigma_px = 0.0;          // Gaussian optical blur, 0 = none
};

struct CornerTruth {
  TargetCorner corner;
  // Projection of the corner; visible also requires the camera to face the printed side.
  ProjectedPoint projection;
};

// Renders targets for one camera. Construction unprojects every pixel corner (about 0.15 s
// for 1280x1024, 21 MB); reuse the renderer for every image of that camera. Thread-compatible: const
// methods may run concurrently.
class TargetRenderer {
 public:
  // Throws std::invalid_argument on a non-positive image size or focal length.
  explicit TargetRenderer(const CameraIntrinsics& cam);

  const CameraIntrinsics& camera() const { return cam_; }

  // The noiseless signal (CV_64FC1, electrons). Throws std::invalid_argument on a pose that
  // is not a rotation or non-finite, or negative photometry.
  cv::Mat RenderSignal(const CalibrationTarget& target, const CameraPose& pose,
                       const TargetPhotometry& photometry) const;

  // RenderSignal through the sensor model (draws from *rng only for a noisy sensor).
  cv::Mat Render(const CalibrationTarget& target, const CameraPose& pose,
                 const TargetPhotometry& photometry, const SensorModel& sensor,
                 std::mt19937_64* rng) const;

  // Truth for every corner of the target, in target.corners() order: image position through
  // mfns::Project and visibility (in front, inside the image with margin_px, not a distortion
  // ghost, printed face towards the camera).
  std::vector<CornerTruth> Corners(const CalibrationTarget& target, const CameraPose& pose,
                                   double margin_px) const;

 private:
  // Multiplies each pixel by the vignetting of its centre's ray.
  void ApplyVignetting(const TargetPhotometry& photometry, cv::Mat* signal) const;

  CameraIntrinsics cam_;
  // Normalised ray (x, y) of pixel corner (u - .5, v - .5), u in 0..W, v in 0..H, row-major;
  // NaN where Unproject fails.
  std::vector<Eigen::Vector2d> corner_rays_;
};

}  // namespace mfns::host
