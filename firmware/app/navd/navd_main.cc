// mfns-navd: the flyer's navigation program (DESIGN.md "Firmware"; docs/navd.md).
// Start: parse options, load parameters (refuse to navigate without a valid blob, saying
// why), open the source, trigger and outputs, reserve everything. Then one Step per frame set
// until the source ends, --frames is reached, or SIGINT/SIGTERM.
#include <signal.h>
#include <sys/stat.h>

#include <time.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>

#include "common/blob/param_blob.h"
#include "common/rotation/rotation.h"
#include "firmware/app/navd/nav_loop.h"
#include "firmware/app/navd/navd_options.h"
#include "firmware/drivers/gpio/gpio_line_io.h"
#include "firmware/drivers/replay/replay_source.h"
#include "firmware/drivers/v4l2/v4l2_io.h"
#include "firmware/drivers/v4l2/v4l2_source.h"
#include "firmware/lib/sd_notify.h"
#include "firmware/modules/params/param_loader.h"
#include "firmware/modules/params/reload_signal.h"

namespace mfns::fw {
namespace {

volatile sig_atomic_t g_stop = 0;
volatile sig_atomic_t g_reload = 0;
void OnStop(int) { g_stop = 1; }
void OnReload(int) { g_reload = 1; }


// The faults the health datagram counts, in one line, when there were any (a run that read
// corrupt frames must not look like one that saw too few beacons).
void ReportFaults(const HealthRecord& h) {
  std::uint64_t bad = 0, detect = 0, drops = 0, timeouts = 0, errors = 0;
  for (int k = 0; k < h.num_cameras; ++k) {
    const CameraHealth& c = h.cameras[static_cast<std::size_t>(k)];
    bad += c.bad_frames;
    detect += c.detect_errors;
    drops += c.drops;
    timeouts += c.timeouts;
    errors += c.errors;
  }
  if (bad + detect + drops + timeouts + errors + h.clock_faults + h.log_errors + h.trigger_errors == 0) return;
  std::fprintf(stderr,
               "mfns-navd: faults: bad frames %llu, detection errors %llu, dropped %llu, timeouts %llu, driver errors "
               "%llu, clock faults %u, log errors %u, trigger errors %u\n",
               static_cast<unsigned long long>(bad), static_cast<unsigned long long>(detect),
               static_cast<unsigned long long>(drops), static_cast<unsigned long long>(timeouts),
               static_cast<unsigned long long>(errors), h.clock_faults, h.log_errors, h.trigger_errors);
}

// A map that repeats itself cannot be acquired where it does (map_repeats.h): said once per
// parameter set, so that the user looks at the map and not at the flyer.
void WarnIfMapRepeats(const Navigator& nav) {
  char line[512];
  if (DescribeMapRepeats(nav.map_repeats(), line, sizeof(line))) std::fprintf(stderr, "mfns-navd: warning: %s\n", line);
}

int Run(int argc, char** argv) {
  static NavdOptions opt;
  char why[512] = {};
  const OptionsStatus os = ParseNavdOptions(argc, argv, &opt, why, sizeof(why));
  if (os == OptionsStatus::kHelp) {
    std::fputs(NavdUsage(), stdout);
    return 0;
  }
  if (os == OptionsStatus::kError) {
    std::fprintf(stderr, "mfns-navd: %s\n", why);
    return 1;
  }

  // Parameters: a blob file or a store directory (newest valid slot). Two rig buffers so a
  // reload can be decoded beside the rig in use and switched between frame sets.
  static std::array<Rig, 2> rigs;
  static ParamLoader loader;
  int active = 0;
  Rig& rig = rigs[0];
  BlobInfo info;
  if (loader.Open(opt.params.data(), nullptr, &rig, &info) != StoreStatus::kOk) {
    loader.Describe(why, sizeof(why));
    std::fprintf(stderr, "mfns-navd: refusing to navigate: %s\n", why);
    return 1;
  }
  // Reloads stay on this rig: another rig id's blob, however new, is refused (and said why).
  loader.ExpectRigId(info.rig_id.data());

  // Source.
  std::unique_ptr<FrameSource> source;
  static LinuxV4l2Io v4l2_io;
  static std::array<NavdOptions::Path, limits::kMaxCameras> default_paths{};
  std::array<const char*, limits::kMaxCameras> paths{};  // V4L2: each camera's device
  if (opt.source == SourceKind::kReplay) {
    // Without truth.csv the frames are timed by --rate-hz, default 18.6 (as --help says).
    ReplayConfig replay = ReplayConfigFromRig(rig, opt.replay_dir.data(), opt.rate_hz);
    replay.realtime = opt.realtime;
    source = std::make_unique<ReplaySource>(replay);
  } else {
    for (int k = 0; k < rig.num_cameras; ++k) {
      const auto ks = static_cast<std::size_t>(k);
      std::snprintf(default_paths[ks].data(), default_paths[ks].size(), "/dev/video%d", k);
      paths[ks] = default_paths[ks].data();
      for (int d = 0; d < opt.num_devices; ++d)
        if (std::strcmp(opt.device_camera[static_cast<std::size_t>(d)].data(), rig.cameras[ks].name.data()) == 0)
          paths[ks] = opt.device_path[static_cast<std::size_t>(d)].data();
    }
    source = std::make_unique<V4l2Source>(&v4l2_io, V4l2ConfigFromRig(rig, paths, opt.y16 ? PixelFormat::kMono16 : PixelFormat::kMono8));
  }
  const SourceStatus ss = source->Start();
  if (ss != SourceStatus::kOk) {
    const char* problem = opt.source == SourceKind::kReplay ? static_cast<ReplaySource*>(source.get())->problem() : "";
    std::fprintf(stderr, "mfns-navd: frame source did not start: %s%s%s\n", ToString(ss), problem[0] != '\0' ? ": " : "",
                 problem);
    if (opt.source == SourceKind::kReplay) return 1;
    const auto* v4l2 = static_cast<const V4l2Source*>(source.get());
    for (int k = 0; k < rig.num_cameras; ++k) {
      const SourceStatus cs = v4l2->camera_status(k);
      if (cs != SourceStatus::kOk)
        std::fprintf(stderr, "mfns-navd: camera %s (%s): %s\n", rig.cameras[static_cast<std::size_t>(k)].name.data(),
                     paths[static_cast<std::size_t>(k)], ToString(cs));
    }
    // V4L2: the cameras that started keep streaming; the loop retries the others.
  }

  // Trigger.
  static LibgpiodLineIo gpio_io;
  TriggerConfig tc;
  tc.enabled = opt.trigger_chip[0] != '\0';
  tc.chip = opt.trigger_chip.data();
  tc.line_offset = static_cast<unsigned>(opt.trigger_line < 0 ? 0 : opt.trigger_line);
  tc.pulse_width_ns = static_cast<std::int64_t>(opt.trigger_pulse_us) * 1000;
  GpioTrigger trigger(tc.enabled ? &gpio_io : nullptr, tc);
  if (tc.enabled) {
    const TriggerStatus ts = trigger.Start();
    if (ts != TriggerStatus::kOk) {
      std::fprintf(stderr, "mfns-navd: trigger %s:%d did not start: %s\n", tc.chip, opt.trigger_line, ToString(ts));
      return 1;
    }
  }

  // Outputs.
  static Outputs outputs;
  static PoseLog log;
  for (int i = 0; i < opt.num_outputs; ++i) {
    const char* url = opt.outputs[static_cast<std::size_t>(i)].data();
    const PublishStatus ps = outputs.Add(url, opt.mavlink);
    if (ps != PublishStatus::kOk) {
      std::fprintf(stderr, "mfns-navd: --output %s: %s\n", url, ToString(ps));
      return 1;
    }
  }
  NavLoopConfig config;
  config.timeout_ms = opt.timeout_ms;
  config.deadline_ms = opt.deadline_ms;
  config.sigma_px = opt.sigma_px;
  config.camera_timeouts_to_set_aside = opt.camera_timeouts_to_set_aside;
  config.camera_retry_every = opt.camera_retry_every;
  config.health_every = opt.health_every;
  config.param_generation = info.generation;
  config.has_initial_pose = InitialPoseOf(opt, &config.initial_pose);
  config.initial_sigma_m = opt.initial_sigma_mm * 1e-3;
  config.initial_sigma_rad = DegToRad(opt.initial_sigma_deg);
  config.windowed_detection = opt.windowed_detection;
  config.navigator.track.verify_three_beacons = !opt.three_beacon_fixes;
  config.navigator.track.three_beacon_fix_steady = !opt.three_beacon_fixes;
  auto loop = std::make_unique<NavLoop>(rig, source.get(), &trigger, &outputs, &log);
  const char* reason = nullptr;
  if (!loop->Configure(config, &reason)) {
    std::fprintf(stderr, "mfns-navd: --params %s (rig %s, generation %llu): %s\n", opt.params.data(), rig.rig_id.data(),
                 static_cast<unsigned long long>(info.generation), reason != nullptr ? reason : "configuration refused");
    return 1;
  }
  // The log last of all the start: a start that fails leaves the previous log alone.
  if (opt.log[0] != '\0' && log.Open(opt.log.data()) != PublishStatus::kOk) {
    std::fprintf(stderr, "mfns-navd: cannot write the log %s: %s\n", log.partial_path(), std::strerror(log.first_error()));
    return 1;
  }
  std::fprintf(stderr, "mfns-navd: rig %s, parameters generation %llu, %d cameras, %d beacons\n", rig.rig_id.data(),
               static_cast<unsigned long long>(info.generation), rig.num_cameras, rig.num_beacons);
  WarnIfMapRepeats(loop->navigator());

  struct sigaction sa {};
  sa.sa_handler = OnStop;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  struct sigaction sh {};
  sh.sa_handler = OnReload;
  sigaction(SIGHUP, &sh, nullptr);
  // A file-size limit (ulimit -f) must be a write error the log reports, not a kill.
  struct sigaction si {};
  si.sa_handler = SIG_IGN;
  sigaction(SIGXFSZ, &si, nullptr);
  // mfns-paramctl signals this pid after an install or rollback (the store is also watched).
  if (opt.pid_file[0] != '\0' && !WritePidFile(opt.pid_file.data()))
    std::fprintf(stderr, "mfns-navd: warning: cannot write the pid file %s (reload still follows the store)\n",
                 opt.pid_file.data());

  // systemd (Type=notify unit, packaging/): READY once navigating, WATCHDOG while frame sets
  // keep being processed, so a stuck loop is restarted. Outside systemd this does nothing.
  static SdNotifier notifier;
  const NotifyStatus ns = notifier.Open();
  if (ns != NotifyStatus::kOk && ns != NotifyStatus::kDisabled)
    std::fprintf(stderr, "mfns-navd: warning: systemd notification off: %s\n", ToString(ns));
  notifier.Ready();
  char status_line[96];
  std::snprintf(status_line, sizeof(status_line), "navigating, parameters generation %llu",
                static_cast<unsigned long long>(info.generation));
  notifier.Status(status_line);

  // ---- Start is over: from here on, no heap. ----
  const int per_second = opt.health_every;
  bool log_warned = false;
  for (std::int64_t n = 0; !g_stop && (opt.frames == 0 || n < opt.frames); ++n) {
    if (g_reload || loader.Changed()) {
      // Between frame sets: decode the newest valid parameters beside the ones in use. Every
      // attempt says what it did: taken, or why not (a newer slot corrupt or for another rig).
      g_reload = 0;
      BlobInfo next_info;
      Rig& next = rigs[static_cast<std::size_t>(1 - active)];
      const StoreStatus ls = loader.Reload(&next, &next_info);
      const char* refused = nullptr;
      if (ls == StoreStatus::kOk && !SameBlob(next_info, info) && loop->Reload(next, next_info.generation, &refused)) {
        active = 1 - active;
        info = next_info;
        std::fprintf(stderr, "mfns-navd: parameters reloaded: generation %llu\n",
                     static_cast<unsigned long long>(info.generation));
        WarnIfMapRepeats(loop->navigator());
        std::snprintf(status_line, sizeof(status_line), "navigating, parameters generation %llu",
                      static_cast<unsigned long long>(info.generation));
        notifier.Status(status_line);
      } else {
        loader.Describe(why, sizeof(why));
        std::fprintf(stderr, "mfns-navd: reload: %s (%s); generation %llu stays\n",
                     ls != StoreStatus::kOk ? "no valid parameters"
                     : refused != nullptr   ? refused
                                            : "nothing newer to take",
                     why, static_cast<unsigned long long>(info.generation));
      }
    }
    if (loop->Step() == StepStatus::kEndOfStream) break;
    if (log.failed() && !log_warned) {  // once: navigation goes on without the log
      log_warned = true;
      std::fprintf(stderr, "mfns-navd: warning: log %s: %s; rows are no longer logged, %s will not be replaced\n",
                   log.partial_path(), std::strerror(log.first_error()), opt.log.data());
    }
    notifier.Watchdog(MonotonicNs());
    const LoopCounters& c = loop->counters();
    if (!opt.quiet && c.frame_sets % static_cast<std::uint64_t>(per_second) == 0)
      std::fprintf(stderr, "mfns-navd: %llu frame sets: fix %llu, degraded %llu, lost %llu, slips %llu\n",
                   static_cast<unsigned long long>(c.frame_sets), static_cast<unsigned long long>(c.fixes),
                   static_cast<unsigned long long>(c.degraded), static_cast<unsigned long long>(c.lost),
                   static_cast<unsigned long long>(c.deadline_slips));
  }
  notifier.Stopping();
  source->Stop();
  const LoopCounters& c = loop->counters();
  std::fprintf(stderr,
               "mfns-navd: done: %llu frame sets, fix %llu, degraded %llu, lost %llu; deadline slips %llu, worst %.2f ms\n",
               static_cast<unsigned long long>(c.frame_sets), static_cast<unsigned long long>(c.fixes),
               static_cast<unsigned long long>(c.degraded), static_cast<unsigned long long>(c.lost),
               static_cast<unsigned long long>(c.deadline_slips), static_cast<double>(c.worst_frame_set_ns) * 1e-6);
  if (c.frame_sets > 0) {
    // Per stage, mean and worst of one frame set (under QEMU's -icount shift=0: 1 ms = 1 M
    // instructions, docs/benchmarks.md).
    char stages[256] = "";
    int used = 0;
    for (int i = 0; i < kNumStages && used >= 0 && used < static_cast<int>(sizeof(stages)); ++i) {
      const auto stage = static_cast<std::size_t>(i);
      used += std::snprintf(stages + used, sizeof(stages) - static_cast<std::size_t>(used), "%s%s %.3f / %.3f",
                            i > 0 ? ", " : "", ToString(static_cast<Stage>(i)),
                            static_cast<double>(c.stage_total_ns[stage]) * 1e-6 / static_cast<double>(c.frame_sets),
                            static_cast<double>(c.stage_worst_ns[stage]) * 1e-6);
    }
    std::fprintf(stderr, "mfns-navd: stages, ms per frame set (mean / worst): %s\n", stages);
  }
  ReportFaults(loop->Health());
  if (opt.pid_file[0] != '\0') RemovePidFile(opt.pid_file.data());
  if (log.is_open() && log.Close() != PublishStatus::kOk) {
    std::fprintf(stderr, "mfns-navd: log %s not written: %s after %llu rows, %llu failed or dropped writes; what was written is in %s\n",
                 opt.log.data(), std::strerror(log.first_error()),
                 static_cast<unsigned long long>(log.counters().log_rows),
                 static_cast<unsigned long long>(log.counters().log_errors), log.partial_path());
    return 1;
  }
  return 0;
}

}  // namespace
}  // namespace mfns::fw

int main(int argc, char** argv) { return mfns::fw::Run(argc, argv); }
