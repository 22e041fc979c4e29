// Speed of the corner refinement on one rendered 1280x1024 image of the paper-calibration
// dataset's board (9x6 inner corners, 20 mm squares, paper camera x, blur 0.6 px, cos^4
// vignetting, 40 e/DN with shot and 10 e read noise), from findChessboardCornersSB's corners
// (found once, outside the timed loop). Run (MFNS_BUILD_BENCHMARKS=ON):
//   build/host/bin/corner_refine_benchmark --benchmark_min_time=2
// Arg 0: a turntable-like view (0.58 m, edges 1.5 deg off the pixel grid); 1: 30-deg diagonal tilt;
// 2: view 0 as the rendered-image tests render (host/testing SynthRender: dim, 80 e on
// white with 6 e read noise, blur 1 px), where the fit's blur s is large and costs most.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "host/calib/detect/corner_refine.h"
#include "host/calib/detect/target_detector.h"
#include "host/testing/target_images.h"

namespace mfns::host {
namespace {

struct Scene {
  cv::Mat image;
  int rows = 0, cols = 0;
  std::vector<Eigen::Vector2d> sb;  // SB corners in grid order
};

Scene MakeScene(int view) {
  static const TargetRenderer renderer(PaperRig().cameras[0].intrinsics);
  const CalibrationTarget board = CalibrationTarget::Checkerboard({9, 6, 0.02, 0.02});
  const CheckerboardSpec& s = board.checkerboard();
  const Eigen::Vector3d centre(0.5 * (s.cols - 1) * s.square_m, 0.5 * (s.rows - 1) * s.square_m, 0.0);
  const bool tilted = view == 1, dim = view == 2;
  const double d = tilted ? 0.55 : 0.58, tilt = DegToRad(tilted ? 30.0 : 6.0);
  const double az = DegToRad(tilted ? 45.0 : 30.0), roll = DegToRad(tilted ? 10.0 : 1.5);
  const Eigen::Vector3d eye =
      centre + d * Eigen::Vector3d(std::sin(tilt) * std::cos(az), std::sin(tilt) * std::sin(az), std::cos(tilt));
  const CameraPose pose = LookAt(eye, centre, Eigen::Vector3d(std::sin(roll), -std::cos(roll), 0.0));
  TargetPhotometry ph;
  ph.illumination_e = 9400;
  ph.blur_sigma_px = 0.6;
  ph.vignetting = Vignetting::kCos4;
  SensorModel sensor;
  sensor.gain_dn_per_e = 1.0 / 40.0;
  sensor.read_noise_e = 10.0;
  sensor.full_well_e = 10200;
  if (dim) {
    ph.illumination_e = 80.0;
    ph.blur_sigma_px = 1.0;
    ph.vignetting = Vignetting::kNone;
    sensor = SensorModel{};
    sensor.gain_dn_per_e = 200.0 / (ph.illumination_e * ph.white_reflectance);
    sensor.read_noise_e = 6.0;
  }
  std::mt19937_64 rng(1);
  Scene sc;
  sc.image = renderer.Render(board, pose, ph, sensor, &rng);
  sc.rows = s.rows;
  sc.cols = s.cols;
  DetectOptions sb_only;
  sb_only.corner_refine = false;
  const DetectResult det = DetectTarget(sc.image, board, sb_only);
  if (!det.ok || det.corners.size() != static_cast<std::size_t>(s.rows * s.cols))
    throw std::runtime_error("corner_refine_benchmark: the board was not detected");
  // DetectTarget's ids are row-major on the board, as RefineCheckerboardCorners wants.
  sc.sb.assign(det.corners.size(), Eigen::Vector2d::Zero());
  for (const CornerObs& c : det.corners) sc.sb[static_cast<std::size_t>(c.id)] = c.uv;
  return sc;
}

// Whole image: every corner of the board refined (54 fits).
void BM_RefineCheckerboardCorners(benchmark::State& state) {
  const Scene sc = MakeScene(static_cast<int>(state.range(0)));
  CornerRefineStats stats;
  std::vector<CornerFit> fits;
  for (auto _ : state) {
    stats = {};
    fits = RefineCheckerboardCorners(sc.image, sc.rows, sc.cols, sc.sb, {}, &stats);
    benchmark::DoNotOptimize(fits.data());
  }
  state.counters["refined"] = stats.Refined();
  state.counters["kept"] = stats.Kept();
  double iterations = 0.0, blur = 0.0, radius = 0.0;
  for (const CornerFit& f : fits) {
    iterations += f.iterations;
    blur += f.blur_px;
    radius += f.radius_px;
  }
  const double n = static_cast<double>(std::max<std::size_t>(fits.size(), 1));
  state.counters["iterations"] = iterations / n;  // mean per corner
  state.counters["blur_px"] = blur / n;           // mean fitted s
  state.counters["radius_px"] = radius / n;       // mean window radius
}
BENCHMARK(BM_RefineCheckerboardCorners)->DenseRange(0, 2)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace mfns::host

BENCHMARK_MAIN();
