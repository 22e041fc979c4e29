#include "host/sim/frames/render_run.h"

#include <unistd.h>

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
#include "host/sim/crb/pose_bound.h"
#include "host/sim/observe/observe.h"
#include "host/core/image.h"
#include "host/sim/render/spot.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

struct BlobRow {
  int camera, beacon;
  Eigen::Vector2d uv, uv_geom;
};

SensorModel MakeSensor(const Scenario& s) {
  SensorModel m;
  m.bit_depth = s.sensor.mono16 ? 16 : 8;
  m.gain_dn_per_e = (s.sensor.mono16 ? 257.0 : 1.0) / s.sensor.gain_e_per_dn;
  m.shot_noise = s.errors.pixel_noise;
  m.read_noise_e = s.errors.pixel_noise ? s.sensor.read_noise_e : 0.0;
  m.full_well_e = s.sensor.full_well_e;
  return m;
}

// Everything one camera renders for one frame set (ObserveCamera decides what is seen);
// appends the truth of the listed beacons.
LedFrameSpec FrameSpec(const Scenario& s, const CameraView& view, int camera, std::vector<BlobRow>* blobs) {
  LedFrameSpec spec;
  spec.background_e = s.sensor.background_e;
  spec.blank = view.state != CameraState::kDelivered;
  for (const Spot& spot : view.spots) {
    if (spot.source == SpotSource::kBeacon || spot.source == SpotSource::kStaticReflection) {
      // Drawn through the camera model at its (noisy) ray, so partly visible spots are drawn too.
      BeaconInView in_view;
      in_view.id = spot.id;
      in_view.p_k = spot.p_k;
      in_view.appearance.sigma_px = s.sensor.psf_sigma_px;
      in_view.appearance.flux_e = spot.flux_e;
      spec.beacons.push_back(in_view);
      if (spot.source == SpotSource::kBeacon && spot.listed) blobs->push_back({camera, spot.id, spot.uv_px, spot.uv_geom_px});
    } else {
      GaussianSpot r;
      r.uv_px = spot.uv_px;
      r.sigma_px = s.sensor.psf_sigma_px;
      r.flux_e = spot.flux_e;
      spec.reflections.push_back(r);
    }
  }
  for (const Clutter::Region& region : s.clutter.bright_regions) {
    if (region.camera != camera) continue;
    BrightRectangle rect;
    rect.u_min = region.rect_px[0];
    rect.v_min = region.rect_px[1];
    rect.u_max = region.rect_px[2];
    rect.v_max = region.rect_px[3];
    rect.level_e = region.level_e;
    spec.rectangles.push_back(rect);
  }
  return spec;
}

// One camera's frame: the spec through the sensor, or the blinded camera's saturated frame.
cv::Mat RenderCamera(const Scenario& s, const CameraView& view, const LedFrameSpec& spec, const SensorModel& sensor,
                     int camera, std::mt19937_64* rng) {
  const CameraIntrinsics& cam = s.rig.cameras[static_cast<std::size_t>(camera)].intrinsics;
  if (view.state == CameraState::kBlindedSaturated)
    return cv::Mat(cam.height, cam.width, sensor.bit_depth == 16 ? CV_16UC1 : CV_8UC1,
                   cv::Scalar(sensor.bit_depth == 16 ? 65535 : 255));
  return RenderLedFrame(cam, spec, sensor, rng).image;
}

// Camera k's frame of frame set f from its own random stream (ImageStream); appends the truth
// of its listed beacons to *blobs. With image false only the truth (an empty image).
cv::Mat RenderFrame(const Scenario& s, const FrameTruth& f, int k, const SensorModel& sensor, std::vector<BlobRow>* blobs,
                    bool image) {
  std::mt19937_64 rng = ImageStream(s, f.frame, k);
  const CameraView view = ObserveCamera(s, f, k, &rng);
  const LedFrameSpec spec = FrameSpec(s, view, k, blobs);
  return image ? RenderCamera(s, view, spec, sensor, k, &rng) : cv::Mat();
}

// Fixed-point text of v with `digits` decimals ("nan" for NaN).
std::string Fmt(int digits, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", digits, v);
  return buf;
}

std::string TruthCsv(const std::vector<FrameTruth>& frames) {
  std::ostringstream o;
  o << "frame,t_ns,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n";
  for (const FrameTruth& f : frames) {
    const EulerAngles e = MatrixToEuler(f.pose.C_w_b.transpose());
    const Eigen::Vector3d r = f.pose.r_w_wb * 1e3;
    o << f.frame << ',' << f.t_ns << ',' << Fmt(6, r.x()) << ',' << Fmt(6, r.y()) << ','
      << Fmt(6, r.z()) << ',' << Fmt(8, RadToDeg(e.phi)) << ',' << Fmt(8, RadToDeg(e.theta)) << ','
      << Fmt(8, RadToDeg(e.psi)) << '\n';
  }
  return o.str();
}

std::string TurntableCsv(const std::vector<FrameTruth>& frames) {
  std::ostringstream o;
  o << "frame,main_cmd_deg,aux_cmd_deg,main_true_deg,aux_true_deg\n";
  for (const FrameTruth& f : frames)
    o << f.frame << ',' << Fmt(9, RadToDeg(f.main_cmd)) << ',' << Fmt(9, RadToDeg(f.aux_cmd)) << ','
      << Fmt(9, RadToDeg(f.main_true)) << ',' << Fmt(9, RadToDeg(f.aux_true)) << '\n';
  return o.str();
}

// turntable-survey.yaml: the turntable's placement as surveyed (SurveyTurntable), what
// `mfns-calib survey --turntable-placement FILE` reads (host/calib/survey/
// turntable_placement_yaml.h: the same keys); never the truth.
std::string TurntableSurveyYaml(const Scenario& s) {
  const SurveyedTurntable t = SurveyTurntable(s);
  const auto triple = [](const Eigen::Vector3d& v, double scale, int digits) {
    return "[" + Fmt(digits, scale * v.x()) + ", " + Fmt(digits, scale * v.y()) + ", " + Fmt(digits, scale * v.z()) + "]";
  };
  return "# The turntable's placement as surveyed (drawn about the truth; host/sim/scenario SurveyTurntable)\n"
         "centre_mm: " + triple(t.centre_w, 1e3, 4) + "\ncentre_sigma_mm: " + Fmt(4, 1e3 * t.centre_sigma) +
         "\ncentre_b_mm: " + triple(t.centre_b, 1e3, 4) + "\ncentre_b_sigma_mm: " + Fmt(4, 1e3 * t.centre_b_sigma) +
         "\naxis: " + triple(t.axis_w, 1.0, 9) +
         "\naxis_sigma_deg: " + Fmt(7, RadToDeg(t.axis_sigma)) + "\n";
}

void EnsureDir(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw UserError(dir.string() + ": cannot create directory: " + ec.message());
}

// A calibration scenario may come without beacons (scenario.h); frames and the bound need them.
void RequireBeacons(const Scenario& s) {
  if (s.rig.num_beacons == 0)
    throw UserError("scenario '" + s.name + "' has no beacons (give beacons_mm or a rig with beacons)");
}

}  // namespace

RenderSummary WriteBoundCsv(const Scenario& s, const std::filesystem::path& path) {
  RequireBeacons(s);
  const std::vector<FrameTruth> frames = SimulateTrajectory(s);
  std::ostringstream o;
  o << "frame,t_ns,n_visible";
  for (int k = 0; k < s.rig.num_cameras; ++k) o << ",n_" << s.rig.cameras[static_cast<std::size_t>(k)].name.data();
  o << ",valid,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_roll_deg,sigma_pitch_deg,sigma_yaw_deg\n";
  RenderSummary sum;
  long total = 0;
  for (const FrameTruth& f : frames) {
    // The beacons the blob lists hold (SimulateBlobs: facing, occlusions, blinded and stopped
    // cameras), so crb.csv counts what blobs.csv lists.
    const BlobFrameSet blob_set = SimulateBlobs(s, f);
    std::vector<VisibleBeacon> seen;
    for (std::size_t j = 0; j < blob_set.blobs.size(); ++j)
      if (blob_set.beacon[j] >= 0) seen.push_back({blob_set.blobs[j].camera, blob_set.beacon[j], blob_set.uv_geom_px[j]});
    const PoseBound b = PoseCramerRao(s.rig, f.pose, seen, s.errors.centroid_sigma_px);
    o << f.frame << ',' << f.t_ns << ',' << seen.size();
    for (int k = 0; k < s.rig.num_cameras; ++k) o << ',' << b.per_camera[static_cast<std::size_t>(k)];
    o << ',' << (b.valid ? 1 : 0);
    for (int i = 0; i < 3; ++i) o << ',' << Fmt(6, b.valid ? b.sigma_position[i] * 1e3 : std::nan(""));
    for (int i = 0; i < 3; ++i) o << ',' << Fmt(8, b.valid ? RadToDeg(b.sigma_euler[i]) : std::nan(""));
    o << '\n';
    ++sum.frames;
    sum.frames_with_3 += seen.size() >= 3;
    sum.frames_with_none += seen.empty();
    total += static_cast<long>(seen.size());
  }
  sum.mean_visible = sum.frames > 0 ? static_cast<double>(total) / sum.frames : 0.0;
  WriteFileAtomic(path, o.str());
  return sum;
}

cv::Mat RenderCameraFrame(const Scenario& s, const FrameTruth& f, int camera) {
  std::vector<BlobRow> blobs;
  return RenderFrame(s, f, camera, MakeSensor(s), &blobs, true);
}

RenderSummary RenderScenario(const Scenario& s, const std::string& scenario_text, const RenderOptions& options) {
  namespace fs = std::filesystem;
  const fs::path& dir = options.out_dir;
  RequireBeacons(s);
  EnsureDir(dir);
  const std::vector<FrameTruth> frames = SimulateTrajectory(s);
  const SensorModel sensor = MakeSensor(s);
  ValidateSensor(sensor);
  // The frames go to DIR/.frames.partial-PID and replace DIR/frames as a whole only once all are
  // written: a render into a folder of an earlier one leaves none of its frames behind (a longer
  // earlier run's frame 000360.pgm would be replayed after this run's last), and a failed render
  // leaves the earlier frames as they were. Other files in DIR are left alone.
  const std::string pid = std::to_string(::getpid());
  const fs::path partial = dir / (".frames.partial-" + pid);
  std::error_code ec;
  fs::remove_all(partial, ec);
  struct RemoveOnExit {
    fs::path path;
    ~RemoveOnExit() {
      std::error_code e;
      fs::remove_all(path, e);
    }
  } cleanup{partial};
  for (int k = 0; k < s.rig.num_cameras; ++k)
    EnsureDir(partial / s.rig.cameras[static_cast<std::size_t>(k)].name.data());

  std::vector<std::vector<BlobRow>> blobs(frames.size());
  std::atomic<int> next{0}, done{0};
  std::mutex error_mutex;
  std::string error;
  const auto worker = [&]() {
    for (int i = next++; i < static_cast<int>(frames.size()); i = next++) {
      try {
        for (int k = 0; k < s.rig.num_cameras; ++k) {
          const cv::Mat image = RenderFrame(s, frames[static_cast<std::size_t>(i)], k, sensor,
                                            &blobs[static_cast<std::size_t>(i)], options.write_images);
          if (!options.write_images) continue;
          char name[32];
          std::snprintf(name, sizeof(name), "%06d.pgm", i);
          WritePgm((partial / s.rig.cameras[static_cast<std::size_t>(k)].name.data() / name).string(), image);
        }
      } catch (const std::exception& e) {
        const std::lock_guard<std::mutex> lock(error_mutex);
        if (error.empty()) error = e.what();
        next = static_cast<int>(frames.size());
      }
      const int n = ++done;
      if (options.progress && (n % 10 == 0 || n == static_cast<int>(frames.size()))) {
        const std::lock_guard<std::mutex> lock(error_mutex);
        std::fprintf(stderr, "\rmfns-sim: rendered %d/%zu frame sets", n, frames.size());
        if (n == static_cast<int>(frames.size())) std::fprintf(stderr, "\n");
      }
    }
  };
  const int threads = std::max(1, options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency()));
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(worker);
  for (std::thread& t : pool) t.join();
  if (!error.empty()) throw UserError(error);
  // Swap: the earlier frames aside, the new ones in, the earlier ones gone (with --no-images the
  // earlier frames go too: they would not match the new truth).
  const fs::path frames_dir = dir / "frames", old_frames = dir / (".frames.old-" + pid);
  fs::remove_all(old_frames, ec);
  if (fs::symlink_status(frames_dir, ec).type() != fs::file_type::not_found) {
    fs::rename(frames_dir, old_frames, ec);
    if (ec) throw UserError(frames_dir.string() + ": cannot move the earlier frames aside: " + ec.message());
  }
  if (options.write_images) {
    fs::rename(partial, frames_dir, ec);
    if (ec) {
      std::error_code back;
      fs::rename(old_frames, frames_dir, back);
      throw UserError(frames_dir.string() + ": cannot put the new frames in place: " + ec.message());
    }
  }
  fs::remove_all(old_frames, ec);

  std::ostringstream b;
  b << "frame,camera,beacon,u_px,v_px,u_geom_px,v_geom_px\n";
  for (std::size_t i = 0; i < blobs.size(); ++i)
    for (const BlobRow& r : blobs[i])
      b << i << ',' << s.rig.cameras[static_cast<std::size_t>(r.camera)].name.data() << ',' << r.beacon << ','
        << Fmt(6, r.uv.x()) << ',' << Fmt(6, r.uv.y()) << ',' << Fmt(6, r.uv_geom.x()) << ','
        << Fmt(6, r.uv_geom.y()) << '\n';
  WriteFileAtomic(dir / "blobs.csv", b.str());
  WriteFileAtomic(dir / "truth.csv", TruthCsv(frames));
  if (s.trajectory.kind == TrajectoryKind::kTurntable) {
    WriteFileAtomic(dir / "turntable.csv", TurntableCsv(frames));
    WriteFileAtomic(dir / "turntable-survey.yaml", TurntableSurveyYaml(s));
  }
  // rig.yaml is the truth: its beacon map is exact (beacon_sigma 0, whatever survey accuracy the
  // scenario's rig quotes); believed-rig.yaml carries the surveyed map and its sigma. Both carry
  // the beacons' facing only when the scenario's map does (map_facing).
  WriteRigYaml(dir / "rig.yaml", TruthMapRig(s));
  WriteRigYaml(dir / "believed-rig.yaml", BelievedRig(s));
  WriteFileAtomic(dir / "scenario.yaml", scenario_text);
  return WriteBoundCsv(s, dir / "crb.csv");
}

}  // namespace mfns::host
