#include "host/sim/calibdata/calib_dataset.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>

#include "common/rotation/rotation.h"
#include "host/rigio/rig_yaml.h"
#include "host/core/image.h"
#include "host/core/target.h"
#include "host/sim/render/target_renderer.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

struct ImagePlan {
  int camera = 0;
  int index = 0;  // per camera: turntable images first, then free ones
  bool free = false;
  double main_cmd = 0, aux_cmd = 0, main_true = 0, aux_true = 0;  // rad
  CameraPose pose;                                                // camera in the target frame
};

CalibrationTarget MakeTarget(const CalibrationSetup& c) {
  if (c.aprilgrid) {
    AprilGridSpec spec;
    spec.tag_cols = c.cols;
    spec.tag_rows = c.rows;
    spec.tag_size_m = c.square;
    spec.tag_spacing = c.tag_spacing;
    return CalibrationTarget::AprilGrid(spec);
  }
  CheckerboardSpec spec;
  spec.cols = c.cols;
  spec.rows = c.rows;
  spec.square_m = c.square;
  spec.border_m = c.square;
  return CalibrationTarget::Checkerboard(spec);
}

Eigen::Vector3d TargetCentre(const CalibrationTarget& t) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const TargetCorner& c : t.corners()) sum += c.P_w;
  return sum / static_cast<double>(t.corners().size());
}

CameraPose CameraInTarget(const RigCamera& cam, const BodyPose& body) {
  CameraPose p;
  p.C_k_w = cam.C_k_b * body.C_w_b.transpose();
  p.r_w_wk = body.r_w_wb + body.C_w_b * cam.r_b_bk;
  return p;
}

// The turntable base angles that best turn camera k's optic axis towards the target centre.
std::pair<double, double> BaseAngles(const Scenario& s, int k, const Eigen::Vector3d& centre) {
  double best = -2.0;
  std::pair<double, double> out{0.0, 0.0};
  for (int m = 0; m < 4; ++m) {
    for (int a : {0, -90, 90}) {
      const double main = DegToRad(90.0 * m), aux = DegToRad(a);
      const CameraPose p = CameraInTarget(s.rig.cameras[static_cast<std::size_t>(k)], TurntablePose(s.turntable, main, aux));
      const Eigen::Vector3d axis_w = p.C_k_w.transpose() * Eigen::Vector3d::UnitZ();
      const double score = axis_w.dot((centre - p.r_w_wk).normalized());
      if (score > best + 1e-9) {
        best = score;
        out = {main, aux};
      }
    }
  }
  return out;
}

// Offsets (main, aux) in units of the variation; both axes, then diagonals, then half steps.
constexpr double kOffsets[][2] = {{0, 0}, {1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1},
                                  {-1, -1}, {1, -1}, {-1, 1}, {0.5, -0.5}, {-0.5, 0.5}};

Eigen::Matrix3d RotateAbout(const Eigen::Vector3d& axis, double angle) { return ExpSO3(axis.normalized() * angle); }

std::vector<ImagePlan> PlanImages(const Scenario& s, const CalibrationTarget& target) {
  const CalibrationSetup& c = s.calibration;
  const Eigen::Vector3d centre = TargetCentre(target);
  std::mt19937_64 angle_rng(s.seed * 0x9E3779B97F4A7C15ull + 11);
  std::normal_distribution<double> angle_noise(0.0, s.errors.turntable_angle ? s.errors.turntable_angle_sigma : 0.0);
  std::vector<ImagePlan> plans;
  for (int k = 0; k < s.rig.num_cameras; ++k) {
    const RigCamera& cam = s.rig.cameras[static_cast<std::size_t>(k)];
    const auto [main0, aux0] = BaseAngles(s, k, centre);
    // A camera looking along the main axis only turns its view of the target about the main
    // axis: larger steps there give the turntable poses more diversity.
    // The main axis in t after the outer aux tilt: Rx(aux) z = R1(aux)^T z.
    const Eigen::Matrix3d C_t_b0 = s.turntable.C_w_t.transpose() * TurntablePose(s.turntable, main0, aux0).C_w_b;
    const Eigen::Vector3d view_t = C_t_b0 * cam.C_k_b.transpose() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d main_axis_t = R1(aux0).transpose() * Eigen::Vector3d::UnitZ();
    const double main_scale = std::abs(view_t.dot(main_axis_t)) > 0.9 ? 2.0 : 1.0;
    for (int i = 0; i < c.turntable_images; ++i) {
      const double* o = kOffsets[static_cast<std::size_t>(i) % std::size(kOffsets)];
      const double shrink = 1.0 / (1.0 + static_cast<double>(i / static_cast<int>(std::size(kOffsets))));
      ImagePlan p;
      p.camera = k;
      p.index = i;
      p.main_cmd = main0 + main_scale * c.variation * o[0] * shrink;
      p.aux_cmd = aux0 + c.variation * o[1] * shrink;
      p.main_true = p.main_cmd + angle_noise(angle_rng);
      p.aux_true = p.aux_cmd + angle_noise(angle_rng);
      p.pose = CameraInTarget(cam, TurntablePose(s.turntable, p.main_true, p.aux_true));
      plans.push_back(p);
    }
  }
  // Hand-held views: the camera at distance d, tilted from the target normal, looking near the
  // centre, rolled about its axis; redrawn (bounded) until every corner is in view.
  for (int k = 0; k < s.rig.num_cameras; ++k) {
    const TargetRenderer corners_only(s.rig.cameras[static_cast<std::size_t>(k)].intrinsics);
    for (int i = 0; i < c.free_images; ++i) {
      std::seed_seq seq{static_cast<std::uint32_t>(s.seed), static_cast<std::uint32_t>(k),
                        static_cast<std::uint32_t>(i), 0xf7eeu};
      std::mt19937_64 rng(seq);
      std::uniform_real_distribution<double> u01(0.0, 1.0);
      ImagePlan p;
      p.camera = k;
      p.index = c.turntable_images + i;
      p.free = true;
      for (int attempt = 0; attempt < 50; ++attempt) {
        const double d = c.free_distance_min + (c.free_distance_max - c.free_distance_min) * u01(rng);
        const double tilt = c.free_tilt * std::sqrt(u01(rng)), azimuth = 2.0 * kPi * u01(rng);
        const Eigen::Vector3d n(std::sin(tilt) * std::cos(azimuth), std::sin(tilt) * std::sin(azimuth), std::cos(tilt));
        const Eigen::Vector3d look = centre + Eigen::Vector3d(u01(rng) - 0.5, u01(rng) - 0.5, 0.0) * 2.0 * c.square;
        const Eigen::Vector3d down = RotateAbout(n, DegToRad(50.0) * (u01(rng) - 0.5)) * -Eigen::Vector3d::UnitY();
        p.pose = LookAt(centre + d * n, look, down);
        bool all = true;
        for (const CornerTruth& t : corners_only.Corners(target, p.pose, 4.0)) all = all && t.projection.visible;
        if (all) break;
      }
      plans.push_back(p);
    }
  }
  return plans;
}

std::string Num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.10g", v);
  return buf;
}

std::string Mat9(const Eigen::Matrix3d& M) {
  std::string s = "[";
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) s += (r + c == 0 ? "" : ", ") + Num(M(r, c));
  return s + "]";
}

std::string Vec3Mm(const Eigen::Vector3d& v) {
  return "[" + Num(v.x() * 1e3) + ", " + Num(v.y() * 1e3) + ", " + Num(v.z() * 1e3) + "]";
}

std::string Stem(int index) {
  char buf[16];
  std::snprintf(buf, sizeof(buf), "%03d", index);
  return buf;
}

std::string TargetYaml(const CalibrationSetup& c) {
  std::ostringstream o;
  if (c.aprilgrid)
    o << "type: aprilgrid\ntag_cols: " << c.cols << "\ntag_rows: " << c.rows << "\ntag_size_mm: " << Num(c.square * 1e3)
      << "\ntag_spacing: " << Num(c.tag_spacing) << "\nfirst_id: 0\nfamily: tag36h11\n";
  else
    o << "type: checkerboard\ncols: " << c.cols << "\nrows: " << c.rows << "\nsquare_mm: " << Num(c.square * 1e3) << "\n";
  return o.str();
}

}  // namespace

CalibDatasetSummary WriteCalibDataset(const Scenario& s, const std::string& scenario_text,
                                      const CalibDatasetOptions& options) {
  if (!s.calibration.present) throw UserError("scenario '" + s.name + "' has no calibration target (target: ...)");
  const CalibrationTarget target = MakeTarget(s.calibration);
  const std::vector<ImagePlan> plans = PlanImages(s, target);
  const std::filesystem::path& dir = options.out_dir;
  std::error_code ec;
  for (int k = 0; k < s.rig.num_cameras; ++k) {
    std::filesystem::create_directories(dir / "images" / s.rig.cameras[static_cast<std::size_t>(k)].name.data(), ec);
    if (ec) throw UserError((dir / "images").string() + ": cannot create directory: " + ec.message());
  }
  std::vector<TargetRenderer> renderers;
  for (int k = 0; k < s.rig.num_cameras; ++k) renderers.emplace_back(s.rig.cameras[static_cast<std::size_t>(k)].intrinsics);

  TargetPhotometry light;
  light.illumination_e = s.calibration.illumination_e;
  light.blur_sigma_px = s.calibration.blur_sigma_px;
  light.vignetting = s.calibration.vignetting ? Vignetting::kCos4 : Vignetting::kNone;
  SensorModel sensor;
  sensor.bit_depth = s.sensor.mono16 ? 16 : 8;
  sensor.gain_dn_per_e = (s.sensor.mono16 ? 257.0 : 1.0) / s.sensor.gain_e_per_dn;
  sensor.shot_noise = s.errors.pixel_noise;
  sensor.read_noise_e = s.errors.pixel_noise ? s.sensor.read_noise_e : 0.0;
  sensor.full_well_e = s.sensor.full_well_e;

  std::vector<std::string> corner_rows(plans.size());
  std::vector<char> complete(plans.size(), 0);
  std::atomic<int> next{0}, done{0};
  std::mutex mutex;
  std::string error;
  const auto worker = [&]() {
    for (int i = next++; i < static_cast<int>(plans.size()); i = next++) {
      const ImagePlan& p = plans[static_cast<std::size_t>(i)];
      const RigCamera& cam = s.rig.cameras[static_cast<std::size_t>(p.camera)];
      try {
        std::seed_seq seq{static_cast<std::uint32_t>(s.seed), static_cast<std::uint32_t>(p.camera),
                          static_cast<std::uint32_t>(p.index), 0x1a6eu};
        std::mt19937_64 rng(seq);
        const cv::Mat image = renderers[static_cast<std::size_t>(p.camera)].Render(target, p.pose, light, sensor, &rng);
        WritePgm((dir / "images" / cam.name.data() / (Stem(p.index) + ".pgm")).string(), image);
        std::ostringstream rows;
        bool all = true;
        for (const CornerTruth& t : renderers[static_cast<std::size_t>(p.camera)].Corners(target, p.pose, 0.0)) {
          all = all && t.projection.visible;
          if (!t.projection.visible) continue;
          rows << cam.name.data() << ',' << Stem(p.index) << ',' << t.corner.id << ',' << Num(t.projection.uv_px.x())
               << ',' << Num(t.projection.uv_px.y()) << '\n';
        }
        corner_rows[static_cast<std::size_t>(i)] = rows.str();
        complete[static_cast<std::size_t>(i)] = all;
      } catch (const std::exception& e) {
        const std::lock_guard<std::mutex> lock(mutex);
        if (error.empty()) error = e.what();
        next = static_cast<int>(plans.size());
      }
      const int n = ++done;
      if (options.progress) {
        const std::lock_guard<std::mutex> lock(mutex);
        std::fprintf(stderr, "mfns-sim: calibration image %d/%zu\n", n, plans.size());
      }
    }
  };
  const int threads = std::max(1, options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency()));
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(worker);
  for (std::thread& t : pool) t.join();
  if (!error.empty()) throw UserError(error);

  std::ostringstream images, truth, corners;
  images << "camera,image,kind,main_deg,aux_deg\n";
  corners << "camera,image,corner,u_px,v_px\n";
  truth << "C_w_t: " << Mat9(s.turntable.C_w_t) << "\nr_w_wt_mm: " << Vec3Mm(s.turntable.r_w_wt)
        << "\nC_p_b: " << Mat9(s.turntable.C_p_b) << "\nr_p_pb_mm: " << Vec3Mm(s.turntable.r_p_pb)
        << "\nturntable_angle_sigma_arcsec: "
        << Num(s.errors.turntable_angle ? RadToDeg(s.errors.turntable_angle_sigma) * 3600.0 : 0.0) << "\nimages:\n";
  CalibDatasetSummary sum;
  sum.turntable_images.assign(static_cast<std::size_t>(s.rig.num_cameras), 0);
  sum.turntable_complete.assign(static_cast<std::size_t>(s.rig.num_cameras), 0);
  for (std::size_t i = 0; i < plans.size(); ++i) {
    const ImagePlan& p = plans[i];
    const char* name = s.rig.cameras[static_cast<std::size_t>(p.camera)].name.data();
    if (p.free) {
      images << name << ',' << Stem(p.index) << ",free,,\n";
      truth << "  - {camera: " << name << ", image: \"" << Stem(p.index) << "\", kind: free, C_k_w: " << Mat9(p.pose.C_k_w)
            << ", r_w_wk_mm: " << Vec3Mm(p.pose.r_w_wk) << "}\n";
    } else {
      ++sum.turntable_images[static_cast<std::size_t>(p.camera)];
      sum.turntable_complete[static_cast<std::size_t>(p.camera)] += complete[i];
      images << name << ',' << Stem(p.index) << ",turntable," << Num(RadToDeg(p.main_cmd)) << ','
             << Num(RadToDeg(p.aux_cmd)) << '\n';
      truth << "  - {camera: " << name << ", image: \"" << Stem(p.index)
            << "\", kind: turntable, main_true_deg: " << Num(RadToDeg(p.main_true))
            << ", aux_true_deg: " << Num(RadToDeg(p.aux_true)) << "}\n";
    }
    corners << corner_rows[i];
    ++sum.images;
    sum.complete += complete[i];
  }
  WriteFileAtomic(dir / "target.yaml", TargetYaml(s.calibration));
  WriteFileAtomic(dir / "images.csv", images.str());
  WriteFileAtomic(dir / "corners.csv", corners.str());
  WriteFileAtomic(dir / "truth.yaml", truth.str());
  WriteRigYaml(dir / "truth-rig.yaml", s.rig);
  WriteFileAtomic(dir / "scenario.yaml", scenario_text);
  return sum;
}

std::vector<std::string> TurntableWarnings(const Scenario& s, const CalibDatasetSummary& sum) {
  std::vector<std::string> out;
  for (std::size_t k = 0; k < sum.turntable_images.size() && k < sum.turntable_complete.size(); ++k) {
    if (sum.turntable_images[k] == 0 || sum.turntable_complete[k] > 0) continue;
    out.push_back("camera " + std::string(s.rig.cameras[k].name.data()) + ": none of its " +
                  std::to_string(sum.turntable_images[k]) +
                  " turntable images shows the whole target: the turntable cannot turn it to face the target "
                  "with this mount (turntable: C_p_b), and mfns-calib rig will refuse the camera");
  }
  return out;
}

}  // namespace mfns::host
