// Speed of the simulator's renderers on the paper camera (1280x1024). Run:
//   build/host/bin/render_benchmark --benchmark_min_time=2
#include <benchmark/benchmark.h>

#include <random>

#include "common/rig/paper_rig.h"
#include "host/sim/render/spot.h"
#include "host/sim/render/target_renderer.h"

namespace mfns::host {
namespace {

const CameraIntrinsics& PaperCamera() {
  static const CameraIntrinsics cam = PaperRig().cameras[0].intrinsics;
  return cam;
}

CameraPose TiltedView() {
  return LookAt({0.16 + 0.3, 0.10 - 0.2, 0.7}, {0.16, 0.10, 0.0}, {0.3, -1.0, 0.0});
}

// Per camera, once: unproject every pixel corner.
void BM_TargetRendererSetup(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(TargetRenderer(PaperCamera()));
}
BENCHMARK(BM_TargetRendererSetup)->Unit(benchmark::kMillisecond);

// One 1280x1024 checkerboard (9x6, 4 cm squares) filling most of the image, tilted.
// Arg 0: the noiseless signal; 1: signal with a 1 px blur; 2: a full 8-bit frame with shot
// and read noise (no blur).
void BM_CheckerboardRender(benchmark::State& state) {
  static const TargetRenderer renderer(PaperCamera());
  const CalibrationTarget board = CalibrationTarget::Checkerboard({9, 6, 0.04, 0.04});
  TargetPhotometry ph;
  ph.blur_sigma_px = state.range(0) == 1 ? 1.0 : 0.0;
  SensorModel sensor;
  sensor.read_noise_e = 2.0;
  std::mt19937_64 rng(1);
  for (auto _ : state) {
    if (state.range(0) == 2) {
      benchmark::DoNotOptimize(renderer.Render(board, TiltedView(), ph, sensor, &rng));
    } else {
      benchmark::DoNotOptimize(renderer.RenderSignal(board, TiltedView(), ph));
    }
  }
}
BENCHMARK(BM_CheckerboardRender)->DenseRange(0, 2)->Unit(benchmark::kMillisecond);

// The same with a 6x6 AprilGrid (many small cells).
void BM_AprilGridRender(benchmark::State& state) {
  static const TargetRenderer renderer(PaperCamera());
  const CalibrationTarget grid = CalibrationTarget::AprilGrid({});
  SensorModel sensor;
  sensor.read_noise_e = 2.0;
  std::mt19937_64 rng(1);
  for (auto _ : state) benchmark::DoNotOptimize(renderer.Render(grid, LookAt({0.3, 0.1, 0.5}, {0.15, 0.15, 0.0}), {}, sensor, &rng));
}
BENCHMARK(BM_AprilGridRender)->Unit(benchmark::kMillisecond);

// The sensor model alone on a 1280x1024 flat field: arg 0 noiseless, 1 read noise, 2 shot
// noise at 8 e- (Poisson by inversion), 3 shot noise at 150 e- (PTRS) plus read noise.
void BM_Sensor(benchmark::State& state) {
  const double level = state.range(0) == 3 ? 150.0 : 8.0;
  const cv::Mat signal(1024, 1280, CV_64FC1, cv::Scalar(level));
  SensorModel sensor;
  sensor.shot_noise = state.range(0) >= 2;
  sensor.read_noise_e = state.range(0) == 1 || state.range(0) == 3 ? 2.0 : 0.0;
  std::mt19937_64 rng(1);
  for (auto _ : state) benchmark::DoNotOptimize(ApplySensor(signal, sensor, &rng));
}
BENCHMARK(BM_Sensor)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

// The baseline of BM_Sensor/3 in the same run: the same model on a field of 150 e- whose pixels
// all differ by < 1e-6 e- (no common level: every pixel drawn one by one, a Poisson and a
// normal draw each, as every pixel was before LevelDistribution).
void BM_SensorPixelByPixel(benchmark::State& state) {
  cv::Mat signal(1024, 1280, CV_64FC1);
  for (int v = 0; v < signal.rows; ++v)
    for (int u = 0; u < signal.cols; ++u) signal.at<double>(v, u) = 150.0 + 1e-12 * (v * signal.cols + u);
  SensorModel sensor;
  sensor.read_noise_e = 2.0;
  std::mt19937_64 rng(1);
  for (auto _ : state) benchmark::DoNotOptimize(ApplySensor(signal, sensor, &rng));
}
BENCHMARK(BM_SensorPixelByPixel)->Unit(benchmark::kMillisecond);

// One LED frame: 4 beacons, a reflection, a window, shot and read noise.
void BM_LedFrame(benchmark::State& state) {
  LedFrameSpec spec;
  for (int i = 0; i < 4; ++i) spec.beacons.push_back({i, Eigen::Vector3d(0.1 * i - 0.15, 0.05 * i - 0.1, 2.0), {}});
  spec.reflections.push_back({{100.0, 200.0}, 2.0, 3000.0});
  spec.rectangles.push_back({900.0, 100.0, 1100.0, 300.0, 150.0});
  SensorModel sensor;
  sensor.read_noise_e = 2.0;
  std::mt19937_64 rng(1);
  for (auto _ : state) benchmark::DoNotOptimize(RenderLedFrame(PaperCamera(), spec, sensor, &rng));
}
BENCHMARK(BM_LedFrame)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace mfns::host

BENCHMARK_MAIN();
