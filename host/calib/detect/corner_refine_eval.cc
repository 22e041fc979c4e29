// Accuracy of the corner refinement on simulated datasets (a measuring tool, not a test; built
// with the benchmarks): refines the given corners (SB's or libapriltag's, from `mfns-calib rig
// ... --no-refine-corners --write-corners`) of every complete checkerboard image, or of every
// whole AprilGrid tag, and compares both with the dataset's exact corners.csv:
//   corner_refine_eval DATASET_DIR START_CORNERS_CSV [DATASET_DIR START_CORNERS_CSV ...]
// Prints RMS error per axis, the RMS and max of the per-image mean offset, refusals, CPU time.
#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <array>
#include <fstream>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "host/calib/core/dataset.h"
#include "host/calib/detect/corner_refine.h"
#include "host/core/image.h"
#include "host/util/atomic_file.h"

namespace {

using Key = std::tuple<std::string, std::string, int>;  // camera, image, corner

// A corners CSV (header optional) by camera, image and corner id; ids must lie in 0..num_ids-1.
std::map<Key, Eigen::Vector2d> ReadCorners(const std::string& path, int num_ids) {
  std::map<Key, Eigen::Vector2d> out;
  for (const mfns::host::CornerRow& row : mfns::host::ParseCornersCsv(mfns::host::ReadFile(path), path, num_ids))
    out[{row.camera, row.image, row.corner.id}] = row.corner.uv;
  return out;
}

struct Sum {
  double ss = 0.0, ss_mean = 0.0, max_mean = 0.0;
  int corners = 0, images = 0;
  void Add(const std::vector<Eigen::Vector2d>& err) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const Eigen::Vector2d& e : err) {
      ss += e.squaredNorm();
      mean += e;
    }
    mean /= static_cast<double>(err.size());
    ss_mean += mean.squaredNorm();
    max_mean = std::max(max_mean, mean.norm());
    corners += static_cast<int>(err.size());
    ++images;
  }
  void Print(const char* name) const {
    std::printf("%-8s images %d corners %d  RMS per axis %.4f px  per-image mean offset: RMS %.4f max %.4f px\n", name,
                images, corners, std::sqrt(ss / (2.0 * corners)), std::sqrt(ss_mean / images), max_mean);
  }
};

// One image's start corners, truth and fits, in the same order.
struct ImageFit {
  std::vector<Eigen::Vector2d> start, truth;
  std::vector<mfns::host::CornerFit> fits;
};

// Refines the image's corners the way the detector does: a complete checkerboard, or every
// AprilGrid tag whose 4 corners are in the start CSV. Empty when there is nothing to refine.
ImageFit RefineImage(const mfns::host::CalibrationTarget& target, const cv::Mat& image,
                     const std::map<int, Eigen::Vector2d>& start, const std::map<int, Eigen::Vector2d>& truth,
                     mfns::host::CornerRefineStats* stats) {
  ImageFit out;
  if (target.type() == mfns::host::TargetType::kCheckerboard) {
    const mfns::host::CheckerboardSpec& s = target.checkerboard();
    if (static_cast<int>(start.size()) != s.rows * s.cols) return out;
    for (const auto& [id, uv] : start) {
      out.start.push_back(uv);
      out.truth.push_back(truth.at(id));
    }
    out.fits = mfns::host::RefineCheckerboardCorners(image, s.rows, s.cols, out.start, {}, stats);
    return out;
  }
  std::vector<std::array<Eigen::Vector2d, 4>> quads;
  for (const auto& [id, uv] : start) {
    if (id % 4 != 0 || !start.contains(id + 3)) continue;
    std::array<Eigen::Vector2d, 4> q;
    for (int k = 0; k < 4; ++k) {
      q[static_cast<std::size_t>(k)] = start.at(id + k);
      out.start.push_back(start.at(id + k));
      out.truth.push_back(truth.at(id + k));
    }
    quads.push_back(q);
  }
  out.fits = mfns::host::RefineAprilGridCorners(image, target.aprilgrid(), quads, {}, stats);
  return out;
}

// The tool; main adds the error report.
int Run(int argc, char** argv) {
  if (argc < 3 || argc % 2 == 0) {
    std::fprintf(stderr, "usage: corner_refine_eval DATASET_DIR START_CORNERS_CSV [...]\n");
    return 2;
  }
  Sum start_sum, refined_sum;
  mfns::host::CornerRefineStats stats;
  double cpu_s = 0.0, iterations = 0.0, radius = 0.0, blur = 0.0;
  for (int a = 1; a + 1 < argc; a += 2) {
    const std::string dir = argv[a];
    const mfns::host::CalibDataset ds = mfns::host::ReadCalibDataset(dir);
    const int num_ids = static_cast<int>(ds.target.corners().size());
    const std::map<Key, Eigen::Vector2d> truth = ReadCorners(dir + "/corners.csv", num_ids);
    const std::map<Key, Eigen::Vector2d> start = ReadCorners(argv[a + 1], num_ids);
    std::map<std::pair<std::string, std::string>, std::map<int, Eigen::Vector2d>> per_image, per_image_truth;
    for (const auto& [k, uv] : start) per_image[{std::get<0>(k), std::get<1>(k)}][std::get<2>(k)] = uv;
    for (const auto& [k, uv] : truth) per_image_truth[{std::get<0>(k), std::get<1>(k)}][std::get<2>(k)] = uv;
    for (const auto& [ci, corners] : per_image) {
      const cv::Mat image = mfns::host::ReadPgm(dir + "/images/" + ci.first + "/" + ci.second + ".pgm");
      const std::clock_t t0 = std::clock();
      const ImageFit f = RefineImage(ds.target, image, corners, per_image_truth[ci], &stats);
      cpu_s += static_cast<double>(std::clock() - t0) / CLOCKS_PER_SEC;
      if (f.fits.empty()) continue;
      std::vector<Eigen::Vector2d> e0, e1;
      for (std::size_t n = 0; n < f.fits.size(); ++n) {
        e0.push_back(f.start[n] - f.truth[n]);
        e1.push_back(f.fits[n].uv - f.truth[n]);
        iterations += f.fits[n].iterations;
        radius += f.fits[n].radius_px;
        blur += f.fits[n].blur_px;
      }
      start_sum.Add(e0);
      refined_sum.Add(e1);
    }
  }
  start_sum.Print("start");
  refined_sum.Print("refined");
  const double n = std::max(refined_sum.corners, 1);
  std::printf("%s; mean iterations %.1f, window radius %.1f px, blur %.2f px\n", mfns::host::ToString(stats).c_str(),
              iterations / n, radius / n, blur / n);
  std::printf("refinement CPU %.2f s (%.3f s per image)\n", cpu_s, cpu_s / std::max(refined_sum.images, 1));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const mfns::host::UserError& e) {  // a malformed corners CSV, named by file and line
    std::fprintf(stderr, "corner_refine_eval: %s\n", e.what());
    return 1;
  }
}
