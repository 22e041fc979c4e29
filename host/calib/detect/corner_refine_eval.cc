// Accuracy of the corner refinement on simulated datasets (a measuring tool, not a test; built
// with the benchmarks): refines the given corners (e.g. SB's, from `mfns-calib rig ...
// --write-corners` without the refinement) of every complete image and compares both with the
// dataset's exact corners.csv:
//   corner_refine_eval DATASET_DIR START_CORNERS_CSV [DATASET_DIR START_CORNERS_CSV ...]
// Prints RMS error per axis, the RMS and max of the per-image mean offset, refusals, CPU time.
#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <ctime>
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

int Value(const std::string& yaml, const std::string& key) {
  const std::size_t p = yaml.find(key + ":");
  return p == std::string::npos ? 0 : std::stoi(yaml.substr(p + key.size() + 1));
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
    std::ifstream ty(dir + "/target.yaml");
    const std::string yaml((std::istreambuf_iterator<char>(ty)), std::istreambuf_iterator<char>());
    const int rows = Value(yaml, "rows"), cols = Value(yaml, "cols");
    const std::map<Key, Eigen::Vector2d> truth = ReadCorners(dir + "/corners.csv", rows * cols);
    const std::map<Key, Eigen::Vector2d> start = ReadCorners(argv[a + 1], rows * cols);
    std::map<std::pair<std::string, std::string>, int> per_image;
    for (const auto& [k, uv] : start) ++per_image[{std::get<0>(k), std::get<1>(k)}];
    for (const auto& [ci, n] : per_image) {
      if (n != rows * cols) continue;
      std::vector<Eigen::Vector2d> uv0, tr;
      for (int id = 0; id < n; ++id) {
        uv0.push_back(start.at({ci.first, ci.second, id}));
        tr.push_back(truth.at({ci.first, ci.second, id}));
      }
      const cv::Mat image = mfns::host::ReadPgm(dir + "/images/" + ci.first + "/" + ci.second + ".pgm");
      const std::clock_t t0 = std::clock();
      const std::vector<mfns::host::CornerFit> fits = mfns::host::RefineCheckerboardCorners(image, rows, cols, uv0, {}, &stats);
      cpu_s += static_cast<double>(std::clock() - t0) / CLOCKS_PER_SEC;
      std::vector<Eigen::Vector2d> e0, e1;
      for (int id = 0; id < n; ++id) {
        e0.push_back(uv0[static_cast<std::size_t>(id)] - tr[static_cast<std::size_t>(id)]);
        const mfns::host::CornerFit& f = fits[static_cast<std::size_t>(id)];
        e1.push_back(f.uv - tr[static_cast<std::size_t>(id)]);
        iterations += f.iterations;
        radius += f.radius_px;
        blur += f.blur_px;
      }
      start_sum.Add(e0);
      refined_sum.Add(e1);
    }
  }
  start_sum.Print("start");
  refined_sum.Print("refined");
  const double n = std::max(refined_sum.corners, 1);
  std::printf("refined %d kept %d; mean iterations %.1f, window radius %.1f px, blur %.2f px\n", stats.Refined(),
              stats.Kept(), iterations / n, radius / n, blur / n);
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
