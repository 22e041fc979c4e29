// Blob detection on a 1280x1024 mono8 frame with 10 spots and noise (issue 4, benchmarks):
// the detector (adaptive and fixed threshold) beside the OpenCV baseline measured in the same
// program: cv::threshold + cv::connectedComponentsWithStats + weighted centroid per component;
// and beside a memcpy of the frame (issue 20 item 2: adaptive detection within 3x of it).
#include <benchmark/benchmark.h>

#include <cstring>
#include <random>
#include <vector>

#include "firmware/modules/detect/detect.h"
#include "firmware/modules/detect/detect_testing.h"

#ifdef MFNS_HAVE_OPENCV  // host builds; the aarch64 cross build has no OpenCV
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#endif

namespace mfns::fw {
namespace {

constexpr double kBackground = 20.0;
constexpr double kNoise = 2.0;
constexpr int kThreshold = 40;  // fixed threshold for the fixed-mode run and the baseline

const testing::FrameBuffer& Frame() {
  static const testing::FrameBuffer frame = [] {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> ux(40.0, 1240.0), uy(40.0, 984.0), us(1.2, 2.2), up(80.0, 220.0);
    testing::SyntheticImage img(1280, 1024);
    img.AddBackground(kBackground);
    for (int i = 0; i < 10; ++i) {
      testing::Spot s;
      s.u = ux(rng);
      s.v = uy(rng);
      s.sigma_x = s.sigma_y = us(rng);
      s.flux = up(rng) * 2.0 * std::numbers::pi * s.sigma_x * s.sigma_y;
      img.AddSpot(s);
    }
    img.AddNoise(kNoise, rng);
    return testing::Quantize(img, PixelFormat::kMono8);
  }();
  return frame;
}

void RunDetector(benchmark::State& state, const DetectOptions& options) {
  const FrameView& view = Frame().view;
  BlobDetector detector(options);
  static BlobList out;  // 40 kB: not on the stack
  for (auto _ : state) {
    detector.Detect(view, nullptr, &out);
    benchmark::DoNotOptimize(out.blobs.data());
    benchmark::ClobberMemory();
  }
  state.counters["blobs"] = out.count;
  state.counters["vector_bytes"] = detector.vector_bytes();
  state.counters["Mpx/s"] = benchmark::Counter(static_cast<double>(view.width) * view.height,
                                               benchmark::Counter::kIsIterationInvariantRate);
}

void BM_DetectAdaptive(benchmark::State& state) { RunDetector(state, DetectOptions()); }

// The same on the baseline 16-byte vectors only (x86-64: SSE2; BM_DetectAdaptive uses AVX2 for
// the row skip where the CPU has it; the same BlobList).
void BM_DetectAdaptiveBaselineVectors(benchmark::State& state) {
  DetectOptions o;
  o.use_avx2 = false;
  RunDetector(state, o);
}

// The yardstick of issue 20 item 2: copying the same frame (its rows, stride as in the frame)
// into a buffer reserved before the loop. Adaptive detection must stay within 3x of this.
void BM_MemcpyFrame(benchmark::State& state) {
  const FrameView& view = Frame().view;
  const std::size_t bytes = static_cast<std::size_t>(view.stride_bytes) * static_cast<std::size_t>(view.height);
  std::vector<std::uint8_t> copy(bytes);
  for (auto _ : state) {
    std::memcpy(copy.data(), view.data, bytes);
    benchmark::DoNotOptimize(copy.data());
    benchmark::ClobberMemory();
  }
  state.counters["Mpx/s"] =
      benchmark::Counter(static_cast<double>(view.width) * view.height, benchmark::Counter::kIsIterationInvariantRate);
}

// Background sampled as before issue 20 item 2 (64-px tiles, every 4th pixel of every 4th row).
DetectOptions Issue4Sampling() {
  DetectOptions o;
  o.tile_px = 64;
  o.sample_step_px = 4;
  return o;
}

// The code before issue 20 item 2, same run: the per-pixel reference path with the sampling of
// then (it gives that code's BlobList; detect_test FastPathEqualsReference).
void BM_DetectAdaptiveBefore(benchmark::State& state) {
  DetectOptions o = Issue4Sampling();
  o.reference_path = true;
  RunDetector(state, o);
}

// The fast path with the sampling of before (the same BlobList as BM_DetectAdaptiveBefore).
void BM_DetectAdaptiveIssue4Sampling(benchmark::State& state) { RunDetector(state, Issue4Sampling()); }

// The fast path with 64-px tiles at the new step (64 samples a tile).
void BM_DetectAdaptiveTile64(benchmark::State& state) {
  DetectOptions o;
  o.tile_px = 64;
  RunDetector(state, o);
}

// Windowed detection while tracking (issue 20 item 1): 33 x 33 px windows around the 10 spots
// plus one of 8 stripes (1/8 of the rows + 2 x 16 margin rows), default options.
void BM_DetectWindowed(benchmark::State& state) {
  const FrameView& view = Frame().view;
  BlobDetector detector;
  static BlobList full, out;
  detector.Detect(view, nullptr, &full);
  std::vector<PixelWindow> windows;
  for (int i = 0; i < full.count; ++i) {
    const auto& b = full.blobs[static_cast<std::size_t>(i)];
    const int u = static_cast<int>(b.uv_px.x()), v = static_cast<int>(b.uv_px.y());
    windows.push_back(PixelWindow{u - 16, v - 16, u + 17, v + 17});
  }
  windows.push_back(PixelWindow{});
  int frame_set = 0;
  for (auto _ : state) {
    windows.back() = DetectionStripe(view.width, view.height, frame_set++, 8, 16);
    detector.Detect(view, nullptr, windows.data(), static_cast<int>(windows.size()), &out);
    benchmark::DoNotOptimize(out.blobs.data());
    benchmark::ClobberMemory();
  }
  state.counters["blobs"] = out.count;
}

void BM_DetectFixed(benchmark::State& state) {
  DetectOptions o;
  o.threshold_mode = ThresholdMode::kFixed;
  o.fixed_threshold_dn = kThreshold;
  o.fixed_background_dn = kBackground;
  RunDetector(state, o);
}

BENCHMARK(BM_MemcpyFrame)->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DetectAdaptive)->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DetectAdaptiveBaselineVectors)->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DetectAdaptiveBefore)->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DetectAdaptiveIssue4Sampling)->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DetectAdaptiveTile64)->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DetectWindowed)->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DetectFixed)->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);

#ifdef MFNS_HAVE_OPENCV
// The baseline of the issue, with every Mat preallocated and the weighted centroid computed
// only inside each component's bounding box. Argument: OpenCV threads (1, as the detector; or
// -1 = OpenCV's default, all cores, which parallelises the labelling). Times are process CPU.
void BM_OpenCvThresholdComponentsCentroid(benchmark::State& state) {
  const int threads_before = cv::getNumThreads();
  cv::setNumThreads(static_cast<int>(state.range(0)));
  const FrameView& f = Frame().view;
  const cv::Mat img(f.height, f.width, CV_8UC1, const_cast<std::uint8_t*>(f.data),
                    static_cast<std::size_t>(f.stride_bytes));
  cv::Mat mask(f.height, f.width, CV_8UC1), labels(f.height, f.width, CV_32S), stats, centroids;
  std::vector<double> u(limits::kMaxBlobsPerFrame + 1), v(limits::kMaxBlobsPerFrame + 1);
  int n = 0;
  for (auto _ : state) {
    cv::threshold(img, mask, kThreshold, 255, cv::THRESH_BINARY);
    n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
    for (int l = 1; l < n && l <= limits::kMaxBlobsPerFrame; ++l) {
      const int x0 = stats.at<int>(l, cv::CC_STAT_LEFT), y0 = stats.at<int>(l, cv::CC_STAT_TOP);
      const int x1 = x0 + stats.at<int>(l, cv::CC_STAT_WIDTH), y1 = y0 + stats.at<int>(l, cv::CC_STAT_HEIGHT);
      double s0 = 0.0, sx = 0.0, sy = 0.0;
      for (int y = y0; y < y1; ++y) {
        const int* lab = labels.ptr<int>(y);
        const std::uint8_t* p = img.ptr<std::uint8_t>(y);
        for (int x = x0; x < x1; ++x) {
          if (lab[x] != l) continue;
          const double w = std::max(p[x] - kBackground, 0.0);
          s0 += w;
          sx += w * x;
          sy += w * y;
        }
      }
      u[static_cast<std::size_t>(l)] = sx / s0;
      v[static_cast<std::size_t>(l)] = sy / s0;
    }
    benchmark::DoNotOptimize(u.data());
    benchmark::DoNotOptimize(v.data());
    benchmark::ClobberMemory();
  }
  cv::setNumThreads(threads_before);
  state.counters["blobs"] = n - 1;
  state.counters["Mpx/s"] = benchmark::Counter(static_cast<double>(f.width) * f.height,
                                               benchmark::Counter::kIsIterationInvariantRate);
}

BENCHMARK(BM_OpenCvThresholdComponentsCentroid)->ArgName("threads")->Arg(1)->Arg(-1)->MeasureProcessCPUTime()->Unit(
    benchmark::kMicrosecond);
#endif  // MFNS_HAVE_OPENCV

}  // namespace
}  // namespace mfns::fw

BENCHMARK_MAIN();
