// LED beacon frames: sensor-integrated beacon spots placed through the full camera model, plus
// clutter (reflections, bright regions, a stopped camera), then the sensor model (sensor.h).
//
// A spot is an isotropic 2-D Gaussian (the optics' PSF around a small emitter) of standard
// deviation sigma_px, integrated exactly over each pixel's area:
//   signal(u, v) += flux_e * [Phi((u+.5-uc)/s) - Phi((u-.5-uc)/s)] * [Phi((v+.5-vc)/s) - Phi((v-.5-vc)/s)]
// with Phi the standard normal CDF. For a beacon, (uc, vc) = mfns::Project(cam, p_k)
// including distortion; that projected centre is the beacon's true blob centre.
// Signals are CV_64FC1 images in expected electrons (image.h); nothing here is random.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "common/camera/camera.h"
#include "host/sim/render/sensor.h"
#include "host/sim/render/visibility.h"

namespace mfns::host {

struct GaussianSpot {
  Eigen::Vector2d uv_px = Eigen::Vector2d::Zero();  // centre, pixel coordinates
  double sigma_px = 1.0;                            // PSF standard deviation (> 0)
  double flux_e = 1000.0;                           // total electrons of the spot (>= 0)
};

// Adds the pixel-integrated spot to *signal_e (CV_64FC1) within 8 sigma of the centre (the
// flux beyond is < 1e-15 of the total); parts outside the image are lost. Throws
// std::invalid_argument on sigma <= 0, negative or non-finite flux, or a bad signal image.
void AddGaussianSpot(const GaussianSpot& spot, cv::Mat* signal_e);

// The total flux for which a spot centred on a pixel centre gives that pixel peak_e electrons.
double FluxForPeak(double peak_e, double sigma_px);

// How a beacon looks in one camera (a scenario may vary it with range).
struct BeaconAppearance {
  double sigma_px = 1.2;
  double flux_e = 6000.0;
};

// Renders a beacon at p_k (camera frame, any length unit) when it projects (Project ok),
// whether or not its centre is in the image (a spot straddling the border is partly drawn).
// Returns the truth: projected centre and visibility with margin_px (visibility.h).
ProjectedPoint AddBeaconSpot(const CameraIntrinsics& cam, const Eigen::Vector3d& p_k,
                             const BeaconAppearance& appearance, cv::Mat* signal_e,
                             double margin_px = 0.0);

// A bright axis-aligned rectangle (e.g. a lit window) in continuous pixel coordinates (pixel
// u spans [u - .5, u + .5]); each pixel gets level_e times its exact covered fraction.
struct BrightRectangle {
  double u_min = 0.0, v_min = 0.0, u_max = 0.0, v_max = 0.0;
  double level_e = 200.0;
};

// A bright filled ellipse (e.g. a lamp or porthole); pixels crossed by the outline get their
// covered fraction from 8x8 sub-samples.
struct BrightEllipse {
  Eigen::Vector2d centre_px = Eigen::Vector2d::Zero();
  double semi_axis_u_px = 10.0;  // before rotation
  double semi_axis_v_px = 5.0;
  double angle_rad = 0.0;        // rotation of the u semi-axis towards +v (clockwise on screen)
  double level_e = 200.0;
};

void AddBrightRectangle(const BrightRectangle& rect, cv::Mat* signal_e);
void AddBrightEllipse(const BrightEllipse& ellipse, cv::Mat* signal_e);

// One beacon as a camera sees it; beacons the caller considers occluded are simply left out.
struct BeaconInView {
  int id = 0;  // the caller's beacon id, copied to the truth
  Eigen::Vector3d p_k = Eigen::Vector3d::UnitZ();  // beacon in camera frame k
  BeaconAppearance appearance;
};

// Everything in one LED frame of one camera.
struct LedFrameSpec {
  double background_e = 8.0;  // uniform expected background, electrons per pixel
  std::vector<BeaconInView> beacons;
  std::vector<GaussianSpot> reflections;  // extra spots at given pixels (no truth)
  std::vector<BrightRectangle> rectangles;
  std::vector<BrightEllipse> ellipses;
  bool blank = false;  // the camera stopped: an all-zero frame, no beacons, no noise
  double margin_px = 0.0;  // visibility margin of the truth
};

struct BeaconTruth {
  int id = 0;
  ProjectedPoint projection;  // true blob centre = projected beacon centre; visibility flag
};

struct LedFrame {
  cv::Mat image;  // CV_8UC1 or CV_16UC1 as the sensor says
  std::vector<BeaconTruth> truth;  // one per spec beacon, in spec order (empty when blank)
};

// Signal of the frame (background, beacons, reflections, regions) without the sensor; truth
// optional.
cv::Mat RenderLedSignal(const CameraIntrinsics& cam, const LedFrameSpec& spec,
                        std::vector<BeaconTruth>* truth = nullptr);

// The frame through the sensor model; draws from *rng only for a noisy sensor and a non-blank
// frame. Throws std::invalid_argument on a bad camera size, spot or sensor.
LedFrame RenderLedFrame(const CameraIntrinsics& cam, const LedFrameSpec& spec,
                        const SensorModel& sensor, std::mt19937_64* rng);

}  // namespace mfns::host
