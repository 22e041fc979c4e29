#include "host/sim/faults/faults.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <opencv2/core.hpp>

#include "common/blob/param_blob.h"
#include "common/rotation/rotation.h"
#include "firmware/app/navd/nav_loop.h"
#include "firmware/lib/in_process_source.h"
#include "firmware/modules/params/param_loader.h"
#include "host/sim/frames/render_run.h"
#include "host/sim/navmatrix/navmatrix.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

constexpr int kReflectionsPerCamera = 5;  // the "5 reflections per camera"

// The frames of a run: per frame set, one image per camera.
using FrameImages = std::vector<std::array<cv::Mat, limits::kMaxCameras>>;

// The scenario whose images a fault shows in its span: the clutter faults change the scene (5
// random reflections per camera; the left half of the camera's image hidden); the others are
// injected into the base scenario's frames.
bool ChangesScene(const FaultSpec& f) { return f.kind == FaultKind::kReflections || f.kind == FaultKind::kOcclusion; }

Scenario SceneOf(const Scenario& base, const FaultSpec& f) {
  Scenario s = base;
  if (f.kind == FaultKind::kReflections) s.clutter.reflections_per_frame = kReflectionsPerCamera;
  if (f.kind == FaultKind::kOcclusion) {
    const CameraIntrinsics& cam = s.rig.cameras[static_cast<std::size_t>(f.camera)].intrinsics;
    Clutter::Occlusion o;
    o.first_frame = f.first;
    o.last_frame = f.last;
    o.camera = f.camera;
    o.has_rect = true;
    o.rect_px = Eigen::Vector4d(-0.5, -0.5, cam.width / 2.0 - 0.5, cam.height - 0.5);  // the left half
    s.clutter.occlusions.push_back(o);
  }
  return s;
}

FrameImages RenderAll(const Scenario& s, const std::vector<FrameTruth>& truth,
                      const std::function<void(const std::string&)>& progress) {
  FrameImages images(truth.size());
  for (std::size_t i = 0; i < truth.size(); ++i) {
    for (int k = 0; k < s.rig.num_cameras; ++k) images[i][static_cast<std::size_t>(k)] = RenderCameraFrame(s, truth[i], k);
    if (progress && ((i + 1) % 40 == 0 || i + 1 == truth.size()))
      progress("rendered " + std::to_string(i + 1) + "/" + std::to_string(truth.size()) + " frame sets");
  }
  return images;
}

// A blob file in a fresh temp folder, loaded through ParamLoader as mfns-navd loads --params,
// the rig id pinned (navd_main.cc): the run's rig and its reload path.
class BlobParams {
 public:
  explicit BlobParams(const Rig& rig) : dir_(std::filesystem::temp_directory_path() /
                                             ("mfns-faults-" + std::to_string(::getpid()) + "-" + std::to_string(++count_))) {
    std::filesystem::create_directories(dir_);
    Write(rig, 1);
    if (loader_->Open(path().c_str(), nullptr, &rig_, &info_) != fw::StoreStatus::kOk) throw UserError(Why());
    loader_->ExpectRigId(info_.rig_id.data());
  }
  ~BlobParams() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  const Rig& rig() const { return rig_; }
  // Replaces the blob with `next`'s and reloads as navd does between frame sets (SIGHUP); says
  // what happened. A blob that loads and differs is handed to the loop.
  std::string OfferReload(const Rig& next, std::uint64_t generation, fw::NavLoop* loop) {
    Write(next, generation);
    BlobInfo next_info;
    const fw::StoreStatus ls = loader_->Reload(&next_rig_, &next_info);
    const char* refused = nullptr;
    if (ls == fw::StoreStatus::kOk && !fw::SameBlob(next_info, info_) && loop->Reload(next_rig_, next_info.generation, &refused)) {
      info_ = next_info;
      return "taken: generation " + std::to_string(info_.generation);
    }
    return std::string("refused (") + (ls != fw::StoreStatus::kOk ? "no valid parameters" : refused ? refused : "nothing newer") +
           "): " + Why();
  }

 private:
  std::string path() const { return (dir_ / "params.bin").string(); }
  std::string Why() const {
    char why[512];
    loader_->Describe(why, sizeof(why));
    std::string said = why;  // (without the temp folder: the same words every run)
    for (std::size_t at; (at = said.find(dir_.string() + "/")) != std::string::npos;) said.erase(at, dir_.string().size() + 1);
    return said;
  }
  void Write(const Rig& rig, std::uint64_t generation) {
    std::array<std::uint8_t, limits::kMaxBlobBytes> bytes{};
    std::size_t n = 0;
    if (EncodeParamBlob(rig, generation, bytes, &n) != BlobStatus::kOk) throw UserError("faults: cannot encode the rig's blob");
    WriteFileAtomic(path(), std::span<const std::uint8_t>(bytes.data(), n));
  }
  static inline int count_ = 0;
  std::filesystem::path dir_;
  std::unique_ptr<fw::ParamLoader> loader_ = std::make_unique<fw::ParamLoader>();
  Rig rig_, next_rig_;
  BlobInfo info_;
};

// Another flyer's parameters: a new rig id, camera x 5 cm off (taken, it would bend every pose).
Rig WrongRig(const Rig& rig) {
  Rig other = rig;
  std::snprintf(other.rig_id.data(), other.rig_id.size(), "%s", "another-flyer");
  other.cameras[0].r_b_bk.x() += 0.05;
  return other;
}

// The driver stamp of frame set n under a clock fault.
std::uint64_t StampOf(const FaultSpec& f, const std::vector<FrameTruth>& truth, int n) {
  const auto t = static_cast<std::int64_t>(truth[static_cast<std::size_t>(n)].t_ns);
  const std::int64_t period = n > 0 ? t - truth[static_cast<std::size_t>(n - 1)].t_ns : 0;
  const auto jump = static_cast<std::int64_t>(f.jump_s * 1e9);
  if (f.kind == FaultKind::kTimeRepeat && n >= f.first) return static_cast<std::uint64_t>(t - period);
  if (f.kind == FaultKind::kTimeBackward && n >= f.first) return static_cast<std::uint64_t>(t - jump);
  if (f.kind == FaultKind::kTimeForward && n >= f.first) return static_cast<std::uint64_t>(t + jump);
  return static_cast<std::uint64_t>(t);
}

// Camera k's frame of frame set n as the fault corrupts it (a new image), or the frame itself.
cv::Mat CorruptFrame(const FaultSpec& f, const cv::Mat& image, int k, int n) {
  if (k != f.camera || n < f.first || n > f.last) return image;
  const double full = image.depth() == CV_16U ? 65535 : 255;
  if (f.kind == FaultKind::kZeroFrames) return cv::Mat::zeros(image.size(), image.type());
  if (f.kind == FaultKind::kWhiteFrames) return cv::Mat(image.size(), image.type(), cv::Scalar(full));
  if (f.kind != FaultKind::kTruncatedFrames && f.kind != FaultKind::kGlare) return image;
  cv::Mat out = image.clone();
  if (f.kind == FaultKind::kTruncatedFrames) out.rowRange(out.rows / 2, out.rows).setTo(0);  // the transfer stopped half-way
  if (f.kind == FaultKind::kGlare) out.colRange(0, out.cols / 2).setTo(full);  // a lamp or the sun: the left half saturated
  return out;
}

// Feeds camera k's entry for frame set n (a status or a frame) to the source. A set-aside
// camera is not read, so its queue fills: frames beyond are lost, as a driver drops them.
void FeedCamera(const FaultSpec& f, const cv::Mat& image, std::uint64_t stamp, int k, int n, fw::InProcessSource* source) {
  const bool stalled = f.kind == FaultKind::kStall && k == f.camera && n >= f.first && n <= f.last;
  const bool unplugged = f.kind == FaultKind::kUnplug && k == f.camera && n >= f.first;
  if (stalled || unplugged) {
    source->PushStatus(k, stalled ? fw::SourceStatus::kTimeout : fw::SourceStatus::kError);
    return;
  }
  fw::FrameView v;
  v.data = image.data;
  v.width = image.cols;
  v.height = image.rows;
  v.stride_bytes = static_cast<int>(image.step[0]);
  v.format = image.depth() == CV_16U ? fw::PixelFormat::kMono16 : fw::PixelFormat::kMono8;
  v.t_capture_ns = stamp;
  v.sequence = static_cast<std::uint32_t>(n);
  source->Push(k, v);
}

FaultFrame Score(const fw::PoseRecord& rec, const FrameTruth& truth, const FrameTruth& first) {
  FaultFrame f;
  f.frame = truth.frame;
  f.t_s = static_cast<double>(truth.t_ns - first.t_ns) * 1e-9;
  f.status = rec.status;
  f.reason = rec.reason;
  f.position_error_m = f.attitude_error_rad = std::nan("");
  if (rec.status == fw::NavStatus::kLost) return f;
  f.position_error_m = (rec.r_w_wb - truth.pose.r_w_wb).norm();
  f.attitude_error_rad = LogSO3(truth.pose.C_w_b.transpose() * rec.q_w_b.toRotationMatrix()).norm();
  const auto& P = rec.covariance;
  const double sigma_m = std::sqrt(std::max({P(0, 0), P(1, 1), P(2, 2), 0.0}));
  f.wrong = WrongPose(f.position_error_m, f.attitude_error_rad, sigma_m, NavMatrixOptions{});
  return f;
}

std::vector<HealthCount> HealthCounts(const fw::NavLoop& loop, const Rig& rig) {
  const fw::HealthRecord h = loop.Health();
  const fw::LoopCounters& c = loop.counters();
  std::vector<HealthCount> out = {{"fixes", static_cast<std::int64_t>(c.fixes)},
                                  {"degraded", static_cast<std::int64_t>(c.degraded)},
                                  {"lost", static_cast<std::int64_t>(c.lost)},
                                  {"clock_faults", static_cast<std::int64_t>(c.clock_faults)},
                                  {"clock_offsets", static_cast<std::int64_t>(c.clock_offsets)},
                                  {"stamp_jumps", static_cast<std::int64_t>(c.stamp_jumps)}};
  for (int k = 0; k < rig.num_cameras; ++k) {
    const std::string cam = std::string(rig.cameras[static_cast<std::size_t>(k)].name.data()) + ".";
    const fw::CameraHealth& ch = h.cameras[static_cast<std::size_t>(k)];
    const fw::CameraSupervision& sup = loop.supervision(k);
    for (const auto& [name, value] : std::initializer_list<std::pair<const char*, std::uint64_t>>{
             {"frames", ch.frames}, {"drops", ch.drops}, {"timeouts", ch.timeouts}, {"errors", ch.errors},
             {"bad_frames", ch.bad_frames}, {"detect_errors", ch.detect_errors}, {"set_asides", sup.set_asides},
             {"resets", sup.resets}, {"set_aside_at_end", sup.set_aside ? 1u : 0u},
             {"saturated_frames", sup.saturated_frames}})
      out.push_back({cam + name, static_cast<std::int64_t>(value)});
  }
  return out;
}

fw::NavLoopConfig LoopConfig(const Scenario& s, const std::vector<FrameTruth>& truth, bool known_start, bool windowed) {
  fw::NavLoopConfig c;  // mfns-navd's defaults
  c.deadline_ms = 1000.0 / s.frame_rate_hz;  // navd: --deadline-ms defaults to the frame period
  c.windowed_detection = windowed;
  c.has_initial_pose = known_start;
  c.initial_pose = truth.front().pose;
  return c;
}

// One run through NavLoop: `scene` holds the frames the fault shows in its span (or null).
FaultRun RunFault(const Scenario& s, const std::vector<FrameTruth>& truth, const FrameImages& base,
                  const FrameImages* scene, const FaultSpec& fault, bool known_start, bool windowed) {
  BlobParams params(TruthMapRig(s));
  fw::InProcessSource source(s.rig.num_cameras);
  source.Start();
  auto loop = std::make_unique<fw::NavLoop>(params.rig(), &source, nullptr, nullptr, nullptr);
  const char* why = nullptr;
  if (!loop->Configure(LoopConfig(s, truth, known_start, windowed), &why))
    throw UserError(std::string("faults: NavLoop: ") + why);
  FaultRun run;
  run.fault = fault;
  std::vector<cv::Mat> corrupt;  // kept until the run ends: a queued frame points into it
  for (int n = 0; n < static_cast<int>(truth.size()); ++n) {
    if (fault.kind == FaultKind::kWrongRigReload && n == fault.first)
      run.reload_said = params.OfferReload(WrongRig(params.rig()), 2, loop.get());
    const bool in_scene = scene != nullptr && n >= fault.first && n <= fault.last;
    for (int k = 0; k < s.rig.num_cameras; ++k) {
      const cv::Mat& image = (in_scene ? *scene : base)[static_cast<std::size_t>(n)][static_cast<std::size_t>(k)];
      corrupt.push_back(CorruptFrame(fault, image, k, n));
      FeedCamera(fault, corrupt.back(), StampOf(fault, truth, n), k, n, &source);
    }
    fw::PoseRecord rec;
    loop->Step(&rec);
    run.frames.push_back(Score(rec, truth[static_cast<std::size_t>(n)], truth.front()));
  }
  run.health = HealthCounts(*loop, s.rig);
  return run;
}

int Rank(fw::NavStatus s) { return s == fw::NavStatus::kFix ? 0 : s == fw::NavStatus::kDegraded ? 1 : 2; }

}  // namespace

std::string FaultSpec::Describe(const std::string& camera_name) const {
  const std::string span = "frame sets " + std::to_string(first) + "-" + std::to_string(last);
  const std::string cam = "camera " + camera_name;
  char jump[32];
  std::snprintf(jump, sizeof(jump), "%.1f s", jump_s);
  switch (kind) {
    case FaultKind::kNone: return "none";
    case FaultKind::kStall: return cam + " stalled (timeouts), " + span + ", then back";
    case FaultKind::kUnplug: return cam + " unplugged (driver errors) from frame set " + std::to_string(first);
    case FaultKind::kZeroFrames: return cam + " all-zero frames, " + span;
    case FaultKind::kWhiteFrames: return cam + " saturated (255) frames, " + span;
    case FaultKind::kTruncatedFrames: return cam + " frames cut after half their rows, " + span;
    case FaultKind::kReflections: return "5 random reflections per camera, " + span;
    case FaultKind::kOcclusion: return "left half of " + cam + " occluded, " + span;
    case FaultKind::kGlare: return "left half of " + cam + " saturated (a lamp, the sun in a window), " + span;
    case FaultKind::kTimeRepeat: return "frame set " + std::to_string(first) + " repeats the last stamp, the clock stays one period behind";
    case FaultKind::kTimeBackward: return std::string("the clock steps back ") + jump + " at frame set " + std::to_string(first);
    case FaultKind::kTimeForward: return std::string("the clock steps forward ") + jump + " at frame set " + std::to_string(first);
    case FaultKind::kWrongRigReload: return "another rig's blob (generation 2) offered as a reload before frame set " + std::to_string(first);
  }
  return "?";
}

std::int64_t FaultResult::Moved(const std::string& name) const {
  for (const HealthCount& h : health_moved)
    if (h.name == name) return h.value;
  return 0;
}

FaultResult ScoreFault(const FaultRun& run, const FaultRun& baseline, double period_s) {
  FaultResult r;
  r.run = run;
  for (std::size_t n = 0; n < run.frames.size() && n < baseline.frames.size(); ++n) {
    const FaultFrame& f = run.frames[n];
    if (Rank(f.status) > Rank(baseline.frames[n].status)) ++(f.status == fw::NavStatus::kLost ? r.lost_vs_baseline : r.degraded_vs_baseline);
    if (f.wrong) ++(f.status == fw::NavStatus::kFix ? r.wrong_fixes : r.wrong_degraded);
  }
  const int end = run.fault.last + 1;
  if (run.fault.kind != FaultKind::kUnplug)
    for (int n = end; n < static_cast<int>(run.frames.size()); ++n)
      if (run.frames[static_cast<std::size_t>(n)].status == fw::NavStatus::kFix) {
        r.recovery_sets = n - end;
        r.recovery_s = r.recovery_sets * period_s;
        break;
      }
  std::map<std::string, std::int64_t> base;
  for (const HealthCount& h : baseline.health) base[h.name] = h.value;
  for (const HealthCount& h : run.health)
    if (h.value != base[h.name]) r.health_moved.push_back({h.name, h.value - base[h.name]});
  return r;
}

FaultCampaign RunFaultCampaign(const FaultRunOptions& o, const std::vector<FaultSpec>& faults, bool cold,
                               const std::function<void(const std::string&)>& progress) {
  const Scenario s = FaultBaseScenario(o);
  const std::vector<FrameTruth> truth = SimulateTrajectory(s);
  FaultCampaign c;
  c.period_s = 1.0 / s.frame_rate_hz;
  for (int k = 0; k < s.rig.num_cameras; ++k) c.camera_names.emplace_back(s.rig.cameras[static_cast<std::size_t>(k)].name.data());
  const FrameImages base = RenderAll(s, truth, progress);
  c.baseline = RunFault(s, truth, base, nullptr, FaultSpec{"baseline"}, o.known_start, o.windowed_detection);
  if (cold) {
    const FaultRun cold_run = RunFault(s, truth, base, nullptr, FaultSpec{"cold"}, false, o.windowed_detection);
    for (const FaultFrame& f : cold_run.frames)
      if (f.status == fw::NavStatus::kFix) {
        c.cold_first_fix = f.frame;
        break;
      }
  }
  for (const FaultSpec& f : faults) {
    FrameImages scene;
    if (ChangesScene(f)) {
      const Scenario fs = SceneOf(s, f);
      scene.resize(truth.size());
      for (int n = f.first; n <= f.last && n < static_cast<int>(truth.size()); ++n)
        for (int k = 0; k < s.rig.num_cameras; ++k)
          scene[static_cast<std::size_t>(n)][static_cast<std::size_t>(k)] = RenderCameraFrame(fs, truth[static_cast<std::size_t>(n)], k);
    }
    c.results.push_back(
        ScoreFault(RunFault(s, truth, base, ChangesScene(f) ? &scene : nullptr, f, o.known_start, o.windowed_detection),
                   c.baseline, c.period_s));
    const FaultResult& r = c.results.back();
    if (progress)
      progress(f.name + ": " + std::to_string(r.wrong_fixes) + " wrong fixes, recovery " + std::to_string(r.recovery_sets) +
               " frame sets");
  }
  return c;
}

}  // namespace mfns::host
