#include "host/testing/synth_calib.h"

#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "host/calib/core/dataset.h"
#include "host/core/image.h"
#include "host/rigio/rig_yaml.h"
#include "host/sim/render/sensor.h"
#include "host/sim/render/target_renderer.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

// Draws from the engine's raw output only (its sequence is fixed by the standard), so a seed
// gives the same scene with any standard library.
double Uniform01(std::mt19937_64* rng) { return static_cast<double>((*rng)() >> 11) * 0x1.0p-53; }
double Uniform(std::mt19937_64* rng, double lo, double hi) { return lo + (hi - lo) * Uniform01(rng); }
double StandardNormal(std::mt19937_64* rng) {  // Box-Muller
  const double u1 = 1.0 - Uniform01(rng), u2 = Uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

bool AllVisible(const CameraIntrinsics& cam, const Transform& T_w_k, const std::vector<Eigen::Vector3d>& pts,
                double margin) {
  if (T_w_k.r.z() <= 0.05) return false;  // the printed face (+z_w) must face the camera
  for (const Eigen::Vector3d& P : pts) {
    Eigen::Vector2d uv;
    if (Project(cam, T_w_k.C.transpose() * (P - T_w_k.r), &uv) != ProjectStatus::kOk) return false;
    if (!InImage(cam, uv, margin)) return false;
  }
  return true;
}

std::string Name(int i) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%03d", i);
  return buf;
}

std::string Row9(const Eigen::Matrix3d& C) {
  std::ostringstream o;
  o.precision(17);
  o << "[";
  for (int i = 0; i < 9; ++i) o << (i ? ", " : "") << C(i / 3, i % 3);
  o << "]";
  return o.str();
}

std::string Mm3(const Eigen::Vector3d& v) {
  std::ostringstream o;
  o.precision(17);
  o << "[" << v.x() * 1e3 << ", " << v.y() * 1e3 << ", " << v.z() * 1e3 << "]";
  return o.str();
}

}  // namespace

SynthScene MakeSynthScene(const SynthOptions& o) {
  std::mt19937_64 rng(o.seed * 0x9E3779B97F4A7C15ull + 17);
  SynthScene s;
  s.angle_sigma = o.angle_sigma;
  s.rig = PaperRig();
  s.rig.num_beacons = 0;
  s.rig.has_sigma = false;
  for (int k = 0; k < s.rig.num_cameras; ++k) {
    CameraIntrinsics& c = s.rig.cameras[static_cast<std::size_t>(k)].intrinsics;
    c.width = static_cast<int>(std::lround(c.width * o.image_scale));
    c.height = static_cast<int>(std::lround(c.height * o.image_scale));
    c.alpha_x *= o.image_scale;
    c.alpha_y *= o.image_scale;
    c.u0 = (c.u0 + 0.5) * o.image_scale - 0.5;
    c.v0 = (c.v0 + 0.5) * o.image_scale - 0.5;
  }
  s.target = CalibrationTarget::Checkerboard(o.board);
  const std::vector<Eigen::Vector3d> pts = TargetPoints(s.target);
  const Eigen::Vector3d centre = 0.5 * (pts.front() + pts.back());

  // Mount and turntable: the small misalignment of Table 3 (tenths of a degree), z_w down.
  s.mount.C_p_b = Eigen::Matrix3d::Identity();
  s.mount.r_p_pb = Eigen::Vector3d(0.0, 0.0, 0.108);
  const double mis = DegToRad(0.1);
  s.mount.C_w_t = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal() *
                  EulerToMatrix({mis * StandardNormal(&rng), mis * StandardNormal(&rng), mis * StandardNormal(&rng)});
  int z_index = 0;
  for (int k = 0; k < s.rig.num_cameras; ++k)
    if (std::string(s.rig.cameras[static_cast<std::size_t>(k)].name.data()) == "z") z_index = k;
  const Eigen::Vector3d cz = s.mount.r_p_pb + s.rig.cameras[static_cast<std::size_t>(z_index)].r_b_bk;
  const Eigen::Vector3d r_t_tc(cz.x() + Uniform(&rng, -0.005, 0.005), cz.y() + Uniform(&rng, -0.005, 0.005),
                               0.685 + Uniform(&rng, -0.005, 0.005));
  s.mount.r_w_wt = centre - s.mount.C_w_t * r_t_tc;

  for (int k = 0; k < s.rig.num_cameras; ++k) {
    const RigCamera& cam = s.rig.cameras[static_cast<std::size_t>(k)];
    const std::string name = cam.name.data();
    double main0 = 0, aux0 = 0;
    if (name == "y") aux0 = DegToRad(-90);
    if (name == "x") {
      main0 = DegToRad(90);
      aux0 = DegToRad(-90);
    }
    if (o.single_axis) {
      // Single-axis images turn about a base pose that sees the whole board: the nominal one
      // when it does (camera z), else the first random one that does.
      const auto visible = [&](double m, double a) {
        return AllVisible(cam.intrinsics, CameraInWorld(BodyInWorld(s.mount, m, a), cam.C_k_b, cam.r_b_bk), pts, o.margin_px);
      };
      const double var = DegToRad(o.variation_deg);
      double m = main0, a = aux0;
      for (int attempt = 0; !visible(m, a) && attempt < 2000; ++attempt) {
        m = DegToRad(std::round(RadToDeg(main0 + Uniform(&rng, -var, var))));
        a = DegToRad(std::round(RadToDeg(aux0 + Uniform(&rng, -var, var))));
      }
      main0 = m;
      aux0 = a;
    }
    int index = 0;
    for (int j = 0; j < o.turntable_images; ++j) {
      SynthImage im;
      im.camera = k;
      im.image = Name(index++);
      im.kind = ImageKind::kTurntable;
      double var = DegToRad(o.variation_deg);
      for (int attempt = 0;; ++attempt) {
        im.main_cmd = main0 + Uniform(&rng, -var, var);
        im.aux_cmd = aux0 + Uniform(&rng, -var, var);
        if (o.single_axis) (j % 2 == 0 ? im.aux_cmd : im.main_cmd) = j % 2 == 0 ? aux0 : main0;
        im.T_w_k = CameraInWorld(BodyInWorld(s.mount, im.main_cmd, im.aux_cmd), cam.C_k_b, cam.r_b_bk);
        if (AllVisible(cam.intrinsics, im.T_w_k, pts, o.margin_px)) break;
        if (attempt % 50 == 49) var *= 0.8;
        if (attempt > 2000) throw std::runtime_error("synth: camera " + name + " cannot see the board");
      }
      // Round the commanded angles as a turntable display would (0.001 deg), then draw the truth.
      im.main_cmd = DegToRad(std::round(RadToDeg(im.main_cmd) * 1000.0) / 1000.0);
      im.aux_cmd = DegToRad(std::round(RadToDeg(im.aux_cmd) * 1000.0) / 1000.0);
      im.main_true = im.main_cmd + o.angle_sigma * StandardNormal(&rng);
      im.aux_true = im.aux_cmd + o.angle_sigma * StandardNormal(&rng);
      im.T_w_k = CameraInWorld(BodyInWorld(s.mount, im.main_true, im.aux_true), cam.C_k_b, cam.r_b_bk);
      s.images.push_back(im);
    }
    for (int j = 0; j < o.free_images; ++j) {
      SynthImage im;
      im.camera = k;
      im.image = Name(index++);
      im.kind = ImageKind::kFree;
      for (int attempt = 0;; ++attempt) {
        const double tilt = Uniform(&rng, 0.0, DegToRad(o.free_max_tilt_deg)), az = Uniform(&rng, 0.0, 2 * kPi);
        const double dist = Uniform(&rng, 0.42, 0.8);
        const Eigen::Vector3d look = centre + Eigen::Vector3d(Uniform(&rng, -0.04, 0.04), Uniform(&rng, -0.03, 0.03), 0);
        const Eigen::Vector3d eye =
            look + dist * Eigen::Vector3d(std::sin(tilt) * std::cos(az), std::sin(tilt) * std::sin(az), std::cos(tilt));
        const double roll = Uniform(&rng, -kPi, kPi);
        const Eigen::Vector3d down(std::cos(roll), std::sin(roll), 0.0);
        try {
          const CameraPose p = LookAt(eye, look, down);
          im.T_w_k = {p.C_k_w.transpose(), p.r_w_wk};
        } catch (const std::invalid_argument&) {
          continue;
        }
        if (AllVisible(cam.intrinsics, im.T_w_k, pts, o.margin_px)) break;
        if (attempt > 5000) throw std::runtime_error("synth: no free view for camera " + name);
      }
      s.images.push_back(im);
    }
  }
  return s;
}

CalibInput SynthCorners(const SynthScene& s, double pixel_sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed * 0xD1B54A32D192ED03ull + 5);
  CalibInput in;
  in.target_points = TargetPoints(s.target);
  for (int k = 0; k < s.rig.num_cameras; ++k) {
    const RigCamera& c = s.rig.cameras[static_cast<std::size_t>(k)];
    in.cameras.push_back({c.name.data(), c.intrinsics.width, c.intrinsics.height});
  }
  in.C_p_b = s.mount.C_p_b;
  in.r_p_pb = s.mount.r_p_pb;
  in.angle_sigma = s.angle_sigma;
  for (const SynthImage& im : s.images) {
    const CameraIntrinsics& cam = s.rig.cameras[static_cast<std::size_t>(im.camera)].intrinsics;
    ViewObservation v;
    v.camera = im.camera;
    v.image = im.image;
    v.kind = im.kind;
    v.main_cmd = im.main_cmd;
    v.aux_cmd = im.aux_cmd;
    for (std::size_t id = 0; id < in.target_points.size(); ++id) {
      Eigen::Vector2d uv;
      if (Project(cam, im.T_w_k.C.transpose() * (in.target_points[id] - im.T_w_k.r), &uv) != ProjectStatus::kOk) continue;
      if (!InImage(cam, uv, 0.5)) continue;
      uv += pixel_sigma * Eigen::Vector2d(StandardNormal(&rng), StandardNormal(&rng));
      v.corners.push_back({static_cast<int>(id), uv});
    }
    in.views.push_back(std::move(v));
  }
  return in;
}

void WriteSynthDataset(const SynthScene& s, const SynthRender& render, std::uint64_t seed,
                       const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir / "images");
  WriteFileAtomic(dir / "target.yaml", FormatTargetYaml(s.target));
  std::ostringstream csv, truth, corners;
  csv << kImagesCsvHeader << "\n";
  csv.precision(10);
  truth.precision(17);
  truth << "C_w_t: " << Row9(s.mount.C_w_t) << "\nr_w_wt_mm: " << Mm3(s.mount.r_w_wt) << "\nC_p_b: " << Row9(s.mount.C_p_b)
        << "\nr_p_pb_mm: " << Mm3(s.mount.r_p_pb) << "\nimages:\n";
  corners << "camera,image,corner,u_px,v_px\n";
  corners.precision(10);
  std::mt19937_64 rng(seed * 0x94D049BB133111EBull + 3);
  TargetPhotometry ph;
  ph.illumination_e = render.illumination_e;
  ph.blur_sigma_px = render.blur_sigma_px;
  SensorModel sensor = render.noise ? SensorModel{} : SensorModel::Noiseless(8);
  sensor.gain_dn_per_e = 200.0 / (render.illumination_e * ph.white_reflectance);
  sensor.read_noise_e = render.noise ? render.read_noise_e : 0.0;
  for (int k = 0; k < s.rig.num_cameras; ++k) {
    const RigCamera& cam = s.rig.cameras[static_cast<std::size_t>(k)];
    const std::string name = cam.name.data();
    std::filesystem::create_directories(dir / "images" / name);
    const TargetRenderer renderer(cam.intrinsics);
    for (const SynthImage& im : s.images) {
      if (im.camera != k) continue;
      CameraPose pose;
      pose.C_k_w = im.T_w_k.C.transpose();
      pose.r_w_wk = im.T_w_k.r;
      const cv::Mat image = renderer.Render(s.target, pose, ph, sensor, &rng);
      WritePgm((dir / "images" / name / (im.image + ".pgm")).string(), image);
      if (im.kind == ImageKind::kTurntable) {
        csv << name << "," << im.image << ",turntable," << RadToDeg(im.main_cmd) << "," << RadToDeg(im.aux_cmd) << "\n";
        truth << "  - {camera: " << name << ", image: \"" << im.image << "\", kind: turntable, main_true_deg: "
              << RadToDeg(im.main_true) << ", aux_true_deg: " << RadToDeg(im.aux_true) << "}\n";
      } else {
        csv << name << "," << im.image << ",free,,\n";
        truth << "  - {camera: " << name << ", image: \"" << im.image << "\", kind: free, C_k_w: "
              << Row9(im.T_w_k.C.transpose()) << ", r_w_wk_mm: " << Mm3(im.T_w_k.r) << "}\n";
      }
      for (const CornerTruth& t : renderer.Corners(s.target, pose, 0.0))
        if (t.projection.visible)
          corners << name << "," << im.image << "," << t.corner.id << "," << t.projection.uv_px.x() << ","
                  << t.projection.uv_px.y() << "\n";
    }
  }
  WriteFileAtomic(dir / "images.csv", csv.str());
  WriteFileAtomic(dir / "truth.yaml", truth.str());
  WriteFileAtomic(dir / "corners.csv", corners.str());
  Rig rig = s.rig;
  WriteRigYaml(dir / "truth-rig.yaml", rig);
}

}  // namespace mfns::host
