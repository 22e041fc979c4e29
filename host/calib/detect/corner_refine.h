// Sub-pixel checkerboard and AprilGrid corners by fitting a model of the blurred corner to the pixels around
// each corner (issue 5: findChessboardCornersSB's ~0.022 px error, mostly a common offset per
// image, limited the rig calibration).
//
// Model of the image near a corner c = (u, v) (px, pixel centres at integers), x a pixel centre:
//   I(x) = (1 + g . (x - x0)) * (m + h * P(x)),
//   P(x) = sum_{k,l in -1..1} w_k w_l Fbar(x + (k, l)),  w = [a, 1 - 2a, a]   (3-tap pixel kernel)
//   Fbar(y) = mean of F over n x n points of the pixel square at y               (pixel area)
//   F(y) = E[sgn(d1(y + s z)) sgn(d2(y + s z))], z ~ N(0, I2)                     (Gaussian optics)
//        = 4 Phi2(d1 / s, d2 / s; rho) - 2 Phi(d1 / s) - 2 Phi(d2 / s) + 1,
//   d_i(y) = n_i . (y - c),  n_i = (cos th_i, sin th_i),  rho = n1 . n2.
// F is the exact Gaussian blur of the ideal corner sgn(d1) sgn(d2) with straight edges at any
// angle (Phi2: the bivariate normal CDF; the edges of a tilted board are not perpendicular).
// The 3-tap kernel is blur acting between sampled pixels (crosstalk, ISP filtering, and the
// simulator's cv::GaussianBlur on the pixel grid, whose sigma-0.6 kernel is ~[0.17, 0.66, 0.17]):
// where edges run near the pixel grid each edge is seen at few sub-pixel phases, and a wrong
// profile shape then moves it (measured: without a: 0.0079 px RMS on the dataset, with: 0.004).
// g: a linear illumination gradient (vignetting; m g.(x - x0) is odd about the corner and would
// pull it towards the brighter side). Free: u, v, th1, th2, s, a, m, h, gx, gy (10).
//
// Fit: Levenberg-Marquardt with the analytic Jacobian over the pixels within radius r of the
// start x0, r = window_fraction x the distance from the corner to the nearest side of the four
// adjacent squares that does not pass through it (so no other edge or corner enters the window;
// smaller near the image border), weights tapered to 0 at r. Start: edge directions from the
// grid neighbours, s = 0.25 px (sharp: the cost of an evaluation grows with s), a = 0, levels
// by linear least squares. Speed (~1.1 ms per corner, README): a pixel whose every sub-sample
// is beyond 6 s of both edges is +-1 without evaluation, one beyond 6 s of one edge takes that
// edge's profile alone; Phi2 with Genz's 6 / 12 / 20 nodes by |rho|; converged when the
// corner's Gauss-Newton steps fall below 1e-3 then 1e-4 px. s >= sqrt(1/12) / n (the
// pixel area's own blur not modelled by the n x n points), 0 <= a <= 0.25.
// A corner keeps its start (and is counted) when the window is too small, the fit does not
// converge, it moves by more than max_shift_px, or the contrast or edge angle is implausible.
// Edges exactly along the pixel grid remain the weak case (one sub-pixel phase per edge: shape
// and position are not separable), corner_refine_test measures it.
#pragma once

#include <Eigen/Core>
#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "host/core/target.h"

namespace mfns::host {

struct CornerRefineOptions {
  double window_fraction = 0.42;  // window radius / distance to the nearest opposite square side
  double min_radius_px = 4.0;     // smaller windows: kept (kWindowTooSmall)
  double max_radius_px = 40.0;    // larger squares use this radius (information grows slowly)
  // Converged: the step stops moving the corner (1e-6 px) and the edges, or the corner's
  // Gauss-Newton steps fall below 10 x then 1 x converged_step_px (the last one is taken without
  // evaluating it), or it moved < 1e-4 px over the last 8 accepted steps (s and a can creep along
  // a shallow valley after it). The steps shrink quadratically: far less than converged_step_px is
  // left to move, 5-10x below the refined corners' noise (1e-5 until session 25, 1e-4 until
  // session 26: the same corners to 1e-4 px on the datasets, 2 evaluations more per corner).
  double converged_step_px = 1e-3;
  int max_iterations = 150;
  double max_shift_px = 0.5;      // a larger move is refused (kMovedTooFar)
  bool fit_gradient = true;       // gx, gy free (else 0)
  bool fit_pixel_kernel = true;   // a free (else 0): the 3-tap pixel kernel
  int pixel_subsamples = 3;       // where two edges meet: F averaged over n x n points per pixel (its area)
  // AprilGrid tag corners (RefineTagCorner): the window keeps tag_margin_px from every other edge
  // of the printed pattern (the border cell's inner side, the next tag, a corner square's far
  // sides), whose blurred profile would otherwise leak into it; each arm runs along its edge for
  // tag_arm_fraction of the tag's side (at most tag_max_arm_px: the cost, session 25: 40 px gave
  // 0.0069 px, 30 px 0.0076 px on the paper-calibration AprilGrid, for 20 % less CPU) and reaches
  // at most tag_strip_px across it on either side; a strip narrower than tag_min_strip_px after
  // the margin: the corner is kept (kWindowTooSmall).
  double tag_margin_px = 1.5;
  double tag_arm_fraction = 0.5;
  double tag_max_arm_px = 30.0;
  double tag_strip_px = 3.0;
  double tag_min_strip_px = 0.5;
};

// The corner's picture near its centre: kX two dark quadrants opposite each other (a
// checkerboard's; an AprilGrid tag's corner touching Kalibr's corner square), kL one dark
// quadrant (a tag's outer corner without corner squares). Model of kL, as F above:
//   P_L(y) = 2 Phi2(-d1 / s, -d2 / s; rho) - 1 = F / 2 - Phi(d1 / s) - Phi(d2 / s) + 1 / 2,
// +1 deep in the dark quadrant {d1 < 0, d2 < 0} (n_i: the edges' outward normals), -1 elsewhere.
enum class CornerShape : unsigned char { kX, kL };

enum class CornerRefineStatus : unsigned char {
  kRefined = 0,
  kWindowTooSmall,  // radius < min_radius_px: squares too small, or the corner at the image border
  kNotConverged,    // no convergence within max_iterations, or a singular system
  kMovedTooFar,     // |refined - start| > max_shift_px
  kBadFit,          // blur above 6 px, contrast below 4 % of the level, or edges near parallel
  kCount
};
const char* ToString(CornerRefineStatus s);

// One corner's outcome. uv is the refined position when status == kRefined, else the start.
struct CornerFit {
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();
  CornerRefineStatus status = CornerRefineStatus::kNotConverged;
  double radius_px = 0.0;  // window radius used
  double blur_px = 0.0;    // fitted s (px)
  double kernel_a = 0.0;   // fitted 3-tap weight a
  double rms_dn = 0.0;     // weighted RMS residual (image units)
  int iterations = 0;
};

// Outcome counts of one image (index: CornerRefineStatus).
struct CornerRefineStats {
  std::array<int, static_cast<std::size_t>(CornerRefineStatus::kCount)> count{};
  int Refined() const { return count[0]; }
  int Kept() const;  // every status but kRefined
  void Add(const CornerRefineStats& other);
};
// "N refined, M kept" and, when M > 0, the count per reason: "(2 fit did not converge, ...)".
std::string ToString(const CornerRefineStats& s);

// Refines one corner. image: CV_8UC1 or CV_16UC1 (used at its own bit depth). uv0: start (px).
// edge1_px, edge2_px: image vectors along the two edges through the corner (e.g. to the next
// corner in the row and in the column; only their directions are used). radius_px: window radius.
CornerFit RefineCorner(const cv::Mat& image, const Eigen::Vector2d& uv0, const Eigen::Vector2d& edge1_px,
                       const Eigen::Vector2d& edge2_px, double radius_px, const CornerRefineOptions& options = {});

// Refines every inner corner of a checkerboard seen as a rows x cols grid of corners, uv in
// row-major order (uv[r * cols + c]; OpenCV's findChessboardCorners order; neighbours in the
// grid are neighbours on the board). Returns one CornerFit per corner in the same order and adds
// the outcomes to *stats (may be null). Throws std::invalid_argument when uv.size() != rows * cols
// or the image type is not CV_8UC1/CV_16UC1.
std::vector<CornerFit> RefineCheckerboardCorners(const cv::Mat& image, int rows, int cols,
                                                 const std::vector<Eigen::Vector2d>& uv,
                                                 const CornerRefineOptions& options = {},
                                                 CornerRefineStats* stats = nullptr);

// One outer corner of an AprilGrid tag (host/core/target.h; Kalibr's layout: a 1-cell black
// border of side/8, gaps of tag_spacing x side to the next tags). uv0: start (libapriltag's
// corner); along1_px, along2_px: image vectors from it to the tag's adjacent corners (so the
// tag's side, border and gap in pixels follow, to first order). Model kL, or kX when
// corner_squares. Window: two arms along the tag's edges, each from the border cell's inner side
// to the gap's far side (less tag_margin_px on both, at most tag_strip_px from the edge),
// tag_arm_fraction of the side long: the only region whose picture is the corner's whatever the
// tag's bits; when the fitted blur's sigma (pixel area and 3-tap kernel included) exceeds
// tag_margin_px / 2, the window again with margins and strips of 3 sigma and a second fit. Too
// small (tags below ~16 px) or cut by the image border: kept as kWindowTooSmall.
// prior (may be null): a refined corner of the
// same image whose blur and kernel start the fit (the optics' blur varies slowly across an image;
// 7.7 -> 6.8 iterations on the paper-calibration AprilGrid dataset).
CornerFit RefineTagCorner(const cv::Mat& image, const Eigen::Vector2d& uv0, const Eigen::Vector2d& along1_px,
                          const Eigen::Vector2d& along2_px, double tag_spacing, bool corner_squares,
                          const CornerRefineOptions& options = {}, const CornerFit* prior = nullptr);

// Refines the 4 corners of every tag, tags[t] in libapriltag's order (p[0..3]: round the tag).
// Returns 4 fits per tag (tag-major, same order) and adds the outcomes to *stats (may be null).
// Throws std::invalid_argument when the image type is not CV_8UC1/CV_16UC1.
std::vector<CornerFit> RefineAprilGridCorners(const cv::Mat& image, const AprilGridSpec& spec,
                                              const std::vector<std::array<Eigen::Vector2d, 4>>& tags,
                                              const CornerRefineOptions& options = {},
                                              CornerRefineStats* stats = nullptr);

// P(X < h, Y < k) for standard bivariate normal X, Y with correlation rho, |rho| <= 0.95
// (Drezner-Wesolowsky / Genz: Gauss-Legendre over asin rho, 6 / 12 / 20 nodes for |rho| below
// 0.3 / 0.75 / above; tested to 1e-10).
double BivariateNormalCdf(double h, double k, double rho);

// F(x) and its partial derivatives for the model above, exposed for tests: the blurred corner at
// standardised edge distances mu1 = d1 / s, mu2 = d2 / s with normal correlation rho.
struct CornerProfile {
  double f = 0.0, df_dmu1 = 0.0, df_dmu2 = 0.0, df_drho = 0.0;
};
// shape kL: the L-corner's P_L instead of F.
CornerProfile BlurredCorner(double mu1, double mu2, double rho, CornerShape shape = CornerShape::kX);

// The pixel-area average of one blurred edge, exposed for tests: the mean of
// Phi((d + cos(theta) x + sin(theta) y) / sigma) over the unit pixel x, y in [-1/2, 1/2] (d: the
// pixel centre's signed distance from the edge, px; theta: the edge normal's angle; sigma > 0,
// px) and its partial derivatives, theta's with d held. What the fit uses for a pixel near one
// edge only.
struct PixelEdge {
  double value = 0.0, d_d = 0.0, d_sigma = 0.0, d_theta = 0.0;
};
PixelEdge PixelAveragedEdge(double d, double theta, double sigma);

}  // namespace mfns::host
