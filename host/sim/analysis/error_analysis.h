// Error analysis of the paper's Section 3 (issue 3, item 4): how beacon-map and camera-to-body
// calibration errors turn into pixel error of u, by Monte Carlo (Figures 4-6) and by the
// first-order analytic prediction beside it.
//
// Geometry (Table 1 and the paper's simplification): the MFNS body sits at the world origin
// with zero attitude (C_b_w = I, r_b_bw = 0) and camera Z has C_z_b = I, r_b_bz = 0, so the
// multi-camera model (eq. 2) p_z = C_z_b (C_b_w P_w + r_b_bw - r_b_bz) reduces to p_z = P_w and
// u = alpha_x X / Z + u0 (eq. 4). Each figure perturbs one term of eq. 2:
//   kBeaconPosition  P_w   -> P_w + e          (eq. 7), e in m
//   kCameraPosition  r_b_bz -> r_b_bz + e      (eq. 8; eq. 8 adds e to T, the opposite sign,
//                                               which changes no RMS), e in m
//   kCameraAttitude  Euler(C_z_b) -> 0 + e     (eqs. 9-10, the 2-1-3 set of rotation.h),
//                                               e = (d_phi, d_theta, d_psi) in rad
// Units: SI inside (m, rad); pixels for u. Host code: may allocate, throws
// std::invalid_argument on a setup it cannot handle (callers turn user input into UserError).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "common/camera/camera.h"

namespace mfns::host {

enum class ErrorFigure { kBeaconPosition = 4, kCameraPosition = 5, kCameraAttitude = 6 };

// How an error vector of magnitude m is drawn in one trial.
enum class ErrorDraw {
  kGaussian,  // each of the three components ~ N(0, m^2): m is a per-axis 1-sigma, as in
              // the calibration tables (Tables 2-4) and the simulator's error sources
  kSphere,    // a uniformly random direction with norm exactly m
};

const char* ToString(ErrorFigure f);  // "beacon-position", "camera-position", "camera-attitude"
const char* ToString(ErrorDraw d);    // "gaussian", "sphere"

// Beacon distribution and camera of Table 1. Beacons are uniform in the box, then kept only when
// Z >= min_depth and (with fov_gate) their nominal image lies inside the image (InImage).
struct AnalysisSetup {
  CameraIntrinsics camera;  // no distortion and no skew (the quadrature relies on it)
  Eigen::Vector2d x_range{0.0, 1.0};  // m, [min, max] of the world (= camera Z) X coordinate
  Eigen::Vector2d y_range{0.0, 1.0};  // m; the paper gives none, default: same as X
  Eigen::Vector2d z_range{0.0, 1.0};  // m
  double min_depth = 0.1;             // m; nearer beacons are rejected (see README)
  bool fov_gate = true;               // reject beacons whose nominal image is off the sensor
  ErrorDraw draw = ErrorDraw::kGaussian;
};

// Table 1: alpha_x = alpha_y = 1600, u0 = 640, v0 = 512, 1280 x 1024 (the paper's camera),
// X, Y, Z in [0, 1] m, min depth 0.1 m, FOV gate on, Gaussian draw.
AnalysisSetup PaperTable1Setup();

// Throws std::invalid_argument with a one-line reason when a range is empty or not finite,
// min_depth < 0, the camera has distortion or skew, or the kept region has no volume.
void ValidateSetup(const AnalysisSetup& s);

// True when a beacon at P_w (m) would be kept (in front, Z >= min_depth, in the image if gated).
bool KeepBeacon(const AnalysisSetup& s, const Eigen::Vector3d& P_w);

// u (px) of the beacon at P_w with error e applied to the term of figure f (e = 0: nominal u).
// Returns false when the perturbed point is not in front of the camera (no image).
bool PerturbedU(const AnalysisSetup& s, ErrorFigure f, const Eigen::Vector3d& P_w,
                const Eigen::Vector3d& e, double* u_px);

// du/de at e = 0 (px per m, or px per rad): the linearisation of eqs. 7, 8 and 10, from the
// camera model's analytic Jacobian and the derivative of the 2-1-3 Euler matrix.
Eigen::RowVector3d GradientU(const AnalysisSetup& s, ErrorFigure f, const Eigen::Vector3d& P_w);

// First-order prediction: RMS u error per unit error magnitude,
// sqrt(E_P[g Sigma g^T]) with g = GradientU, Sigma = I (kGaussian) or I/3 (kSphere) and E_P the
// mean over the kept beacon region, integrated by piecewise Gauss-Legendre quadrature (exact
// up to rounding for this integrand). px per m, or px per rad.
double AnalyticSlope(const AnalysisSetup& s, ErrorFigure f);

// Volume fraction of the beacon box that is kept (quadrature), in [0, 1].
double KeptFraction(const AnalysisSetup& s);

struct PointResult {
  double magnitude = 0.0;       // m or rad
  double mc_rms_px = 0.0;       // Monte Carlo RMS of (perturbed u - nominal u)
  double analytic_rms_px = 0.0; // AnalyticSlope * magnitude
  std::int64_t trials = 0;      // trials used (kept beacons with a perturbed image)
  std::int64_t draws = 0;       // candidates drawn, rejected ones included (drawn in the box cut
                                // to the depths and view cone that can be kept)
};

// One Monte Carlo point: `trials` kept beacons, each with one error draw. Deterministic for
// (seed, f, point_index): every point has its own random stream, so a point does not depend
// on which other points are run. Throws std::invalid_argument when too few beacons are kept
// (acceptance < 1e-6).
PointResult RunPoint(const AnalysisSetup& s, ErrorFigure f, double magnitude, std::int64_t trials,
                     std::uint64_t seed, int point_index);

struct FigureResult {
  ErrorFigure figure = ErrorFigure::kBeaconPosition;
  std::vector<PointResult> points;
  double mc_slope = 0.0;        // least-squares line through the origin of mc_rms vs magnitude
  double analytic_slope = 0.0;  // AnalyticSlope
};

// `points` magnitudes evenly spaced in [0, max_magnitude] (points >= 2). progress (optional)
// is called after each point with (index, count, result).
using PointProgress = std::function<void(int, int, const PointResult&)>;
FigureResult RunFigure(const AnalysisSetup& s, ErrorFigure f, double max_magnitude, int points,
                       std::int64_t trials, std::uint64_t seed, const PointProgress& progress = {});

// Slope of the least-squares line y = k x through the origin; 0 when all x are 0.
double SlopeThroughOrigin(const std::vector<double>& x, const std::vector<double>& y);

// CSV with a header line: <magnitude column>,mc_rms_u_px,analytic_rms_u_px,trials where the
// magnitude column is error_mm (figures 4, 5) or error_deg (figure 6).
std::string FigureCsv(const FigureResult& r);

// Magnitude in the figure's display unit (mm or deg) and back; the unit's name.
double ToDisplayUnit(ErrorFigure f, double magnitude_si);
double FromDisplayUnit(ErrorFigure f, double magnitude_display);
const char* DisplayUnit(ErrorFigure f);  // "mm" or "deg"

}  // namespace mfns::host
