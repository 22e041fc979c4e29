#include "host/calib/detect/target_detector.h"

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <memory>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "host/util/image_memory.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

// libapriltag indexes pixels by truncation: its pixel centres are at i + 0.5.
constexpr double kApriltagPixelOffset = 0.5;

// Mapping of OpenCV's raw grid position (r, c) to the target's (i, j).
struct GridMap {
  bool flip_i = false, flip_j = false;
};

Eigen::Matrix3d FitHomography(const std::vector<Eigen::Vector2d>& plane, const std::vector<Eigen::Vector2d>& image) {
  // Normalised DLT; plenty for deciding colours and handedness.
  std::vector<cv::Point2d> a, b;
  for (std::size_t n = 0; n < plane.size(); ++n) {
    a.emplace_back(plane[n].x(), plane[n].y());
    b.emplace_back(image[n].x(), image[n].y());
  }
  const cv::Mat H = cv::findHomography(a, b, 0);
  Eigen::Matrix3d h = Eigen::Matrix3d::Identity();
  if (H.empty()) return h;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) h(r, c) = H.at<double>(r, c);
  return h;
}

Eigen::Vector2d Apply(const Eigen::Matrix3d& H, const Eigen::Vector2d& p) {
  const Eigen::Vector3d q = H * Eigen::Vector3d(p.x(), p.y(), 1.0);
  return q.head<2>() / q.z();
}

// Mean of a 3x3 patch at uv, or NaN outside the image.
double Patch(const cv::Mat& mono8, const Eigen::Vector2d& uv) {
  const int u = static_cast<int>(std::lround(uv.x())), v = static_cast<int>(std::lround(uv.y()));
  if (u < 2 || v < 2 || u >= mono8.cols - 2 || v >= mono8.rows - 2) return std::nan("");
  double s = 0;
  for (int dv = -1; dv <= 1; ++dv)
    for (int du = -1; du <= 1; ++du) s += mono8.at<unsigned char>(v + dv, u + du);
  return s / 9.0;
}

struct Candidate {
  GridMap map;
  double contrast = 0.0;  // mean(white squares) - mean(black squares) as this labelling predicts
  bool front = false;     // the homography's handedness is that of a view of the +z face
  Eigen::Matrix3d H = Eigen::Matrix3d::Identity();
};

Candidate Score(const cv::Mat& mono8, const std::vector<cv::Point2f>& raw, const CheckerboardSpec& s, GridMap m) {
  Candidate cand;
  cand.map = m;
  std::vector<Eigen::Vector2d> plane, image;
  for (int r = 0; r < s.rows; ++r)
    for (int c = 0; c < s.cols; ++c) {
      const int i = m.flip_i ? s.rows - 1 - r : r, j = m.flip_j ? s.cols - 1 - c : c;
      plane.emplace_back(j * s.square_m, i * s.square_m);
      const cv::Point2f& p = raw[static_cast<std::size_t>(r * s.cols + c)];
      image.emplace_back(p.x, p.y);
    }
  cand.H = FitHomography(plane, image);
  // Handedness at the board centre: d(u, v)/d(x, y) has a negative determinant when the +z
  // face is seen (x right, y up on the sheet; v down in the image).
  const Eigen::Vector2d centre(0.5 * (s.cols - 1) * s.square_m, 0.5 * (s.rows - 1) * s.square_m);
  const double h = 0.01 * s.square_m;
  const Eigen::Vector2d p0 = Apply(cand.H, centre);
  Eigen::Matrix2d J;
  J.col(0) = (Apply(cand.H, centre + Eigen::Vector2d(h, 0)) - p0) / h;
  J.col(1) = (Apply(cand.H, centre + Eigen::Vector2d(0, h)) - p0) / h;
  cand.front = J.determinant() < 0.0;
  // Colours: square (ix, iy) spans x in [(ix - 1) q, ix q]; black when ix + iy is even.
  double black = 0, white = 0;
  int nb = 0, nw = 0;
  for (int iy = 0; iy <= s.rows; ++iy)
    for (int ix = 0; ix <= s.cols; ++ix) {
      const Eigen::Vector2d centre_xy((ix - 0.5) * s.square_m, (iy - 0.5) * s.square_m);
      const double val = Patch(mono8, Apply(cand.H, centre_xy));
      if (std::isnan(val)) continue;
      if ((ix + iy) % 2 == 0) {
        black += val;
        ++nb;
      } else {
        white += val;
        ++nw;
      }
    }
  cand.contrast = (nb > 0 && nw > 0) ? white / nw - black / nb : 0.0;
  return cand;
}

// image: the original (mono8 or mono16) for the refinement; mono8: its 8-bit view for OpenCV.
DetectResult DetectCheckerboard(const cv::Mat& image, const cv::Mat& mono8, const CheckerboardSpec& s, const DetectOptions& o) {
  DetectResult res;
  if (s.cols == s.rows) throw UserError("a square checkerboard (" + std::to_string(s.cols) + "x" + std::to_string(s.rows) +
                                        " inner corners) has no defined orientation; use cols != rows");
  std::vector<cv::Point2f> raw;
  const int flags = o.sb_accuracy ? cv::CALIB_CB_ACCURACY : 0;
  if (!cv::findChessboardCornersSB(mono8, cv::Size(s.cols, s.rows), raw, flags) ||
      raw.size() != static_cast<std::size_t>(s.cols * s.rows)) {
    res.reason = "checkerboard not found (findChessboardCornersSB, " + std::to_string(s.cols) + "x" + std::to_string(s.rows) + ")";
    return res;
  }
  if (o.corner_subpix) {
    const int w = o.subpix_half_window;
    cv::cornerSubPix(mono8, raw, cv::Size(w, w), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::MAX_ITER, 50, 1e-4));
  }
  std::array<Candidate, 4> cands;
  for (int k = 0; k < 4; ++k) cands[static_cast<std::size_t>(k)] = Score(mono8, raw, s, GridMap{(k & 1) != 0, (k & 2) != 0});
  double best = 0;
  for (const Candidate& c : cands) best = std::max(best, c.contrast);
  if (best < 10.0) {
    res.reason = "checkerboard colours not readable (contrast " + std::to_string(best) + " DN)";
    return res;
  }
  // Keep the labellings whose colours fit (equal contrast up to 20%), then prefer a view of the
  // printed face where the colours leave a mirror image open.
  std::vector<Candidate> keep;
  for (const Candidate& c : cands)
    if (c.contrast > 0.8 * best) keep.push_back(c);
  bool any_front = false;
  for (const Candidate& c : keep) any_front = any_front || c.front;
  if (any_front) std::erase_if(keep, [](const Candidate& c) { return !c.front; });
  // What remains is one labelling, or two related by the board's 180-degree turn.
  const Candidate& chosen = keep.front();
  res.orientation_ambiguous = keep.size() > 1;
  // Model fit per corner on the original image, in OpenCV's grid order (its neighbours).
  std::vector<Eigen::Vector2d> refined;
  refined.reserve(raw.size());
  for (const cv::Point2f& p : raw) refined.emplace_back(p.x, p.y);
  if (o.corner_refine) {
    const std::vector<CornerFit> fits = RefineCheckerboardCorners(image, s.rows, s.cols, refined, o.refine, &res.refine_stats);
    for (std::size_t n = 0; n < raw.size(); ++n) refined[n] = fits[n].uv;
  }
  for (int r = 0; r < s.rows; ++r)
    for (int c = 0; c < s.cols; ++c) {
      const int i = chosen.map.flip_i ? s.rows - 1 - r : r, j = chosen.map.flip_j ? s.cols - 1 - c : c;
      res.corners.push_back({i * s.cols + j, refined[static_cast<std::size_t>(r * s.cols + c)]});
    }
  std::sort(res.corners.begin(), res.corners.end(), [](const CornerObs& a, const CornerObs& b) { return a.id < b.id; });
  res.ok = true;
  return res;
}

// image: the original (mono8 or mono16) for the refinement; mono8: its 8-bit view for libapriltag.
DetectResult DetectAprilGrid(const cv::Mat& image, const cv::Mat& mono8, const AprilGridSpec& s, const DetectOptions& o) {
  DetectResult res;
  std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)> family(tag36h11_create(), tag36h11_destroy);
  std::unique_ptr<apriltag_detector_t, void (*)(apriltag_detector_t*)> detector(apriltag_detector_create(),
                                                                                apriltag_detector_destroy);
  apriltag_detector_add_family_bits(detector.get(), family.get(), 1);
  detector->quad_decimate = 1.0f;
  detector->nthreads = 1;
  detector->refine_edges = 1;
  cv::Mat img = mono8.isContinuous() ? mono8 : mono8.clone();
  image_u8_t im{img.cols, img.rows, static_cast<int32_t>(img.step), img.data};
  zarray_t* detections = apriltag_detector_detect(detector.get(), &im);
  const int n_tags = s.tag_cols * s.tag_rows;
  std::vector<bool> seen(static_cast<std::size_t>(n_tags), false);
  int foreign = 0;
  std::vector<cv::Point2f> pts;
  std::vector<int> ids;
  for (int n = 0; n < zarray_size(detections); ++n) {
    apriltag_detection_t* d = nullptr;
    zarray_get(detections, n, &d);
    const int t = d->id - s.first_id;
    if (t < 0 || t >= n_tags || seen[static_cast<std::size_t>(t)]) {
      ++foreign;
      continue;
    }
    seen[static_cast<std::size_t>(t)] = true;
    bool inside = true;
    for (int k = 0; k < 4; ++k) {
      const double u = d->p[k][0] - kApriltagPixelOffset, v = d->p[k][1] - kApriltagPixelOffset;
      inside = inside && u >= o.border_px - 0.5 && v >= o.border_px - 0.5 && u <= mono8.cols - 0.5 - o.border_px &&
               v <= mono8.rows - 0.5 - o.border_px;
    }
    if (!inside) continue;
    for (int k = 0; k < 4; ++k) {
      pts.emplace_back(static_cast<float>(d->p[k][0] - kApriltagPixelOffset), static_cast<float>(d->p[k][1] - kApriltagPixelOffset));
      ids.push_back(4 * t + k);
    }
  }
  apriltag_detections_destroy(detections);
  if (static_cast<int>(pts.size()) < o.min_corners) {
    res.reason = "AprilGrid: " + std::to_string(pts.size() / 4) + " tags of the grid found (" + std::to_string(pts.size()) +
                 " corners, at least " + std::to_string(o.min_corners) + " needed)" +
                 (foreign ? ", " + std::to_string(foreign) + " foreign or repeated tags ignored" : "");
    return res;
  }
  if (o.corner_subpix) {
    const int w = o.subpix_half_window;
    cv::cornerSubPix(mono8, pts, cv::Size(w, w), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::MAX_ITER, 50, 1e-4));
  }
  std::vector<Eigen::Vector2d> uv;
  for (const cv::Point2f& p : pts) uv.emplace_back(p.x, p.y);
  if (o.corner_refine) {
    // pts holds whole tags, 4 corners each in libapriltag's order.
    std::vector<std::array<Eigen::Vector2d, 4>> quads(uv.size() / 4);
    for (std::size_t n = 0; n < uv.size(); ++n) quads[n / 4][n % 4] = uv[n];
    const std::vector<CornerFit> fits = RefineAprilGridCorners(image, s, quads, o.refine, &res.refine_stats);
    for (std::size_t n = 0; n < uv.size(); ++n) uv[n] = fits[n].uv;
  }
  for (std::size_t n = 0; n < uv.size(); ++n) res.corners.push_back({ids[n], uv[n]});
  std::sort(res.corners.begin(), res.corners.end(), [](const CornerObs& a, const CornerObs& b) { return a.id < b.id; });
  res.ok = true;
  return res;
}

}  // namespace

cv::Mat ToMono8(const cv::Mat& image) {
  if (image.type() == CV_8UC1) return image;
  cv::Mat out;
  double lo = 0, hi = 0;
  cv::minMaxLoc(image, &lo, &hi);
  image.convertTo(out, CV_8UC1, hi > 0 ? 255.0 / hi : 1.0);
  return out;
}

DetectResult DetectTarget(const cv::Mat& image, const CalibrationTarget& target, const DetectOptions& options) {
  if (image.empty() || (image.type() != CV_8UC1 && image.type() != CV_16UC1)) {
    DetectResult r;
    r.reason = "not a mono8 or mono16 image";
    return r;
  }
  KeepImageBuffers();  // OpenCV's detectors allocate and free big blocks per image (image_memory.h)
  const cv::Mat mono8 = ToMono8(image);
  return target.type() == TargetType::kCheckerboard ? DetectCheckerboard(image, mono8, target.checkerboard(), options)
                                                    : DetectAprilGrid(image, mono8, target.aprilgrid(), options);
}

}  // namespace mfns::host
