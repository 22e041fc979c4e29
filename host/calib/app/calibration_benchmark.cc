// What the default calibration costs against the corner detector's library alone on the same
// images (issue 18 item 1: at most 1.5x), measured in the same run, one thread each:
//   - OpenCvCornerDetection/<dataset> (checkerboards): cv::findChessboardCornersSB with
//     CALIB_CB_ACCURACY (the detector's default) on the 8-bit view of every image, nothing else
//     (the images are read before the timed loop), with the detector's malloc tuning
//     (KeepImageBuffers: without it the same calls take 2.4x as long, a third of it in the kernel);
//   - AprilTagDetection/<dataset> (AprilGrids): libapriltag as DetectTarget runs it (tag36h11, no
//     decimation, edge refinement, one thread), through DetectTarget without the refinement (its
//     own bookkeeping, ids and sorting, is ~1e-3 of the detector's time);
//   - DefaultCalibration/<dataset>: `mfns-calib rig DATASET --out DIR --jobs 1` in process
//     (reading the images, SB, the corner refinement, the ml solve with its covariance, every
//     output file): what a user runs;
//   - SbOnlyCalibration/<dataset>: the same with --no-refine-corners (the refinement's share;
//     the detector's corners, SB's or libapriltag's).
// Usage (MFNS_BUILD_BENCHMARKS=ON; datasets from `mfns-sim calib-dataset`, either target):
//   build/host/bin/calibration_benchmark DATASET_DIR [DATASET_DIR ...] [--benchmark_* flags]
// docs/benchmarks.md has the runs and the commands that made the datasets.
#include <benchmark/benchmark.h>

#include <unistd.h>

#include <cstdio>
#include <exception>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>

#include "host/calib/app/calib_cli.h"
#include "host/calib/app/calib_commands.h"
#include "host/calib/core/dataset.h"
#include "host/calib/detect/target_detector.h"
#include "host/core/image.h"
#include "host/util/image_memory.h"

namespace mfns::host {
namespace {

namespace fs = std::filesystem;

// One image's detection by the library alone: true when the target was found.
bool LibraryDetect(const CalibrationTarget& target, const cv::Mat& mono8) {
  if (target.type() == TargetType::kAprilGrid) {
    DetectOptions o;
    o.corner_refine = false;
    const DetectResult r = DetectTarget(mono8, target, o);
    benchmark::DoNotOptimize(r.corners.data());
    return r.ok;
  }
  const CheckerboardSpec& s = target.checkerboard();
  std::vector<cv::Point2f> corners;
  const bool ok = cv::findChessboardCornersSB(mono8, cv::Size(s.cols, s.rows), corners, cv::CALIB_CB_ACCURACY);
  benchmark::DoNotOptimize(corners.data());
  return ok;
}

void LibraryCornerDetection(benchmark::State& state, const fs::path& dir) {
  const CalibDataset ds = ReadCalibDataset(dir);
  KeepImageBuffers();  // as the detector does: OpenCV's per-image blocks stay in the heap (image_memory.h)
  std::vector<cv::Mat> mono8;
  for (const DatasetImage& im : ds.images) mono8.push_back(ToMono8(ReadPgm(im.path.string())));
  int found = 0;
  for (auto _ : state) {
    found = 0;
    for (const cv::Mat& m : mono8) found += LibraryDetect(ds.target, m) ? 1 : 0;
  }
  state.counters["images"] = static_cast<double>(mono8.size());
  state.counters["found"] = found;
}

void Calibration(benchmark::State& state, const fs::path& dir, bool refine) {
  const fs::path out = fs::temp_directory_path() / ("mfns_calibration_benchmark_" + std::to_string(::getpid()));
  RigCommandOptions o;
  o.dataset = dir.string();
  o.out_dir = out.string();
  o.jobs = 1;
  o.refine_corners = refine;
  o.refine_corners_given = true;
  o.generation = 1;
  o.generation_set = true;
  for (auto _ : state) {
    std::ostringstream log;
    try {
      const RigCalibration rig = RunRigCommand(o, log);
      benchmark::DoNotOptimize(rig.cameras.data());
    } catch (const std::exception& e) {
      state.SkipWithError(e.what());
      break;
    }
  }
  fs::remove_all(out);
}

}  // namespace
}  // namespace mfns::host

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (argc < 2) {
    std::fprintf(stderr, "usage: calibration_benchmark DATASET_DIR [DATASET_DIR ...] [--benchmark_* flags]\n");
    return 2;
  }
  // One run each (tens of seconds), in seconds of process CPU time (OpenCV's threads counted).
  const auto once = [](benchmark::internal::Benchmark* b) { b->MeasureProcessCPUTime()->Unit(benchmark::kSecond)->Iterations(1); };
  for (int i = 1; i < argc; ++i) {
    const std::filesystem::path dir = argv[i];
    const std::string name = dir.filename().string();
    const bool grid = mfns::host::ReadCalibDataset(dir).target.type() == mfns::host::TargetType::kAprilGrid;
    const std::string library = grid ? "AprilTagDetection/" : "OpenCvCornerDetection/";
    once(benchmark::RegisterBenchmark((library + name).c_str(), mfns::host::LibraryCornerDetection, dir));
    once(benchmark::RegisterBenchmark(("DefaultCalibration/" + name).c_str(), mfns::host::Calibration, dir, true));
    once(benchmark::RegisterBenchmark(("SbOnlyCalibration/" + name).c_str(), mfns::host::Calibration, dir, false));
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
