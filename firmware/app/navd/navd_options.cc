#include "firmware/app/navd/navd_options.h"

#include <getopt.h>

#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "common/rotation/rotation.h"
#include "firmware/modules/publish/publishers.h"

namespace mfns::fw {
namespace {

bool HasMavlinkOutput(const NavdOptions& o) {
  for (int i = 0; i < o.num_outputs; ++i) {
    OutputProtocol protocol{};
    const char* udp = nullptr;
    if (ParseOutputUrl(o.outputs[static_cast<std::size_t>(i)].data(), &protocol, &udp) == PublishStatus::kOk &&
        protocol == OutputProtocol::kMavlink)
      return true;
  }
  return false;
}

enum : int {
  kParams = 1000, kRealtime, kSource, kDevice, kY16, kBuffers, kRate, kTrigger, kPulse, kOutput, kLog, kFrames, kTimeout,
  kDeadline, kSigma, kHealthEvery, kRetryEvery, kSetAside, kInitialPose, kInitialSigma, kPidFile, kQuiet, kHelp,
  kMavlinkSysid, kMavlinkCompid, kMavlinkFrame, kNoWindowed, kThreeBeaconFixes
};

const option kLongOptions[] = {
    {"params", required_argument, nullptr, kParams},       {"source", required_argument, nullptr, kSource},
    {"device", required_argument, nullptr, kDevice},       {"y16", no_argument, nullptr, kY16},
    {"buffers", required_argument, nullptr, kBuffers},     {"rate-hz", required_argument, nullptr, kRate},
    {"trigger", required_argument, nullptr, kTrigger},     {"trigger-pulse-us", required_argument, nullptr, kPulse},
    {"output", required_argument, nullptr, kOutput},       {"log", required_argument, nullptr, kLog},
    {"frames", required_argument, nullptr, kFrames},       {"timeout-ms", required_argument, nullptr, kTimeout},
    {"deadline-ms", required_argument, nullptr, kDeadline}, {"sigma-px", required_argument, nullptr, kSigma},
    {"health-every", required_argument, nullptr, kHealthEvery},
    {"camera-retry-every", required_argument, nullptr, kRetryEvery},
    {"camera-timeouts", required_argument, nullptr, kSetAside},
    {"initial-pose", required_argument, nullptr, kInitialPose},
    {"initial-sigma", required_argument, nullptr, kInitialSigma},
    {"pid-file", required_argument, nullptr, kPidFile},
    {"mavlink-sysid", required_argument, nullptr, kMavlinkSysid},
    {"mavlink-compid", required_argument, nullptr, kMavlinkCompid},
    {"mavlink-frame", required_argument, nullptr, kMavlinkFrame},
    {"no-windowed-detection", no_argument, nullptr, kNoWindowed},
    {"three-beacon-fixes", no_argument, nullptr, kThreeBeaconFixes},
    {"realtime", no_argument, nullptr, kRealtime},         {"quiet", no_argument, nullptr, kQuiet},               {"help", no_argument, nullptr, kHelp},
    {nullptr, 0, nullptr, 0},
};

template <std::size_t N>
bool CopyText(const char* s, std::array<char, N>* out) {
  const std::size_t n = std::strlen(s);
  if (n == 0 || n >= N) return false;
  out->fill('\0');
  std::memcpy(out->data(), s, n);
  return true;
}

bool ParseLong(const char* s, long long lo, long long hi, long long* v) {
  errno = 0;
  char* end = nullptr;
  const long long x = std::strtoll(s, &end, 10);
  if (errno != 0 || end == s || *end != '\0' || x < lo || x > hi) return false;
  *v = x;
  return true;
}

bool ParseDouble(const char* s, double lo, double hi, double* v) {
  errno = 0;
  char* end = nullptr;
  const double x = std::strtod(s, &end);
  if (errno != 0 || end == s || *end != '\0' || !(x >= lo && x <= hi)) return false;
  *v = x;
  return true;
}

// Parses exactly n comma-separated finite numbers.
bool ParseList(const char* s, int n, double* out) {
  const char* p = s;
  for (int i = 0; i < n; ++i) {
    errno = 0;
    char* end = nullptr;
    out[i] = std::strtod(p, &end);
    if (errno != 0 || end == p || !std::isfinite(out[i])) return false;
    const char want = i + 1 < n ? ',' : '\0';
    if (*end != want) return false;
    p = end + 1;
  }
  return true;
}

// Writes the one-line reason and returns kError.
__attribute__((format(printf, 3, 4))) OptionsStatus Fail(char* why, std::size_t why_size, const char* fmt, ...) {
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(why, why_size, fmt, args);
  va_end(args);
  return OptionsStatus::kError;
}

}  // namespace

bool InitialPoseOf(const NavdOptions& opt, BodyPose* pose) {
  if (!opt.has_initial_pose) return false;
  const auto& p = opt.initial_pose;
  pose->r_w_wb = Eigen::Vector3d(p[0], p[1], p[2]) * 1e-3;
  // The poses CSV's angles are the Euler angles of C_b_w (nav_loop.cc Publish).
  pose->C_w_b = EulerToMatrix(EulerAngles{DegToRad(p[3]), DegToRad(p[4]), DegToRad(p[5])}).transpose();
  return true;
}

const char* NavdUsage() {
  return "usage: mfns-navd --params FILE|DIR --source v4l2|replay:DIR [options]\n"
         "  --params FILE|DIR       parameter blob, or parameter store directory (newest valid slot)\n"
         "  --source v4l2           cameras through V4L2 (see --device)\n"
         "  --source replay:DIR     frames directory DIR/frames/<camera>/<frame:06d>.pgm (+ truth.csv)\n"
         "  --device NAME=PATH      V4L2 device of camera NAME (default: /dev/video<k> in rig order)\n"
         "  --y16                   negotiate 16-bit Y16 instead of GREY\n"
         "  --buffers N             V4L2 MMAP buffers per camera (4..8, default 4)\n"
         "  --rate-hz R             frame rate (deadline; replay timestamps without truth.csv), default 18.6\n"
         "  --trigger CHIP:LINE     pulse GPIO LINE of CHIP (e.g. gpiochip0:17) once per frame set\n"
         "  --trigger-pulse-us N    trigger pulse width, default 1000\n"
         "  --output udp://HOST:PORT  pose and health datagrams (docs/navd.md)\n"
         "  --output mavlink+udp://HOST:PORT  MAVLink 2 ODOMETRY + HEARTBEAT for an autopilot (docs/navd.md);\n"
         "                          --output may be given up to 4 times, any mix\n"
         "  --mavlink-sysid N       MAVLink system id, 1..255, default 1 (the autopilot's)\n"
         "  --mavlink-compid N      MAVLink component id, 1..255, default 197 (VISUAL_INERTIAL_ODOMETRY)\n"
         "  --mavlink-frame frd|flu axes of the world and body frames: frd (default) sent as they are;\n"
         "                          flu turned half a turn about x into MAVLink's FRD\n"
         "  --log FILE              poses CSV (written to FILE.partial, renamed at exit)\n"
         "  --frames N              stop after N frame sets (default: at end of stream or SIGINT/SIGTERM)\n"
         "  --timeout-ms N          wait per camera per frame set (default: 3 frame periods)\n"
         "  --deadline-ms X         frame-set processing deadline (default: one frame period)\n"
         "  --sigma-px X            centroid noise 1-sigma for the covariance, default 0.15\n"
         "  --health-every N        health datagram every N frame sets (default: once a second)\n"
         "  --camera-retry-every N  frame sets between retries of a camera set aside (default: 1 s)\n"
         "  --camera-timeouts N     consecutive failures before a camera is set aside, default 3\n"
         "  --initial-pose X,Y,Z,ROLL,PITCH,YAW  known start pose (mm, deg; as the poses CSV): no acquisition\n"
         "  --initial-sigma MM,DEG  1-sigma errors of --initial-pose, default 10,1\n"
         "  --pid-file PATH         pid file for mfns-paramctl's reload signal (default /run/mfns-navd.pid; '' = none)\n"
         "  --quiet                 no per-second status line on stderr\n"
         "  --realtime              replay: deliver each frame set at its recorded time, not as fast as read\n"
         "  --no-windowed-detection detect in full frames also while tracking (default: windows about the\n"
         "                          predicted beacons plus a stripe, docs/navd.md)\n"
         "  --three-beacon-fixes    a track found on three beacons is a fix at once (default: degraded,\n"
         "                          'unverified', until a pose on four), and a pose on three beacons\n"
         "                          one of which just appeared (default: degraded until its blob is\n"
         "                          steady); only where every light the cameras see is a mapped\n"
         "                          beacon, docs/navd.md)\n"
         "  --help                  this text\n";
}

OptionsStatus ParseNavdOptions(int argc, char** argv, NavdOptions* opt, char* why, std::size_t why_size) {
  *opt = NavdOptions{};
  std::memcpy(opt->pid_file.data(), "/run/mfns-navd.pid", sizeof("/run/mfns-navd.pid"));
  optind = 1;
  opterr = 0;
  bool have_source = false;
  const char* mavlink_option = nullptr;  // a --mavlink-* option given (it needs a MAVLink output)
  for (int guard = 0; guard <= argc; ++guard) {
    const int c = getopt_long(argc, argv, "", kLongOptions, nullptr);
    if (c == -1) break;
    const char* a = optarg;
    long long n = 0;
    switch (c) {
      case kParams:
        if (!CopyText(a, &opt->params)) return Fail(why, why_size, "--params: path empty or too long: '%s'", a);
        break;
      case kSource:
        if (std::strcmp(a, "v4l2") == 0) {
          opt->source = SourceKind::kV4l2;
        } else if (std::strncmp(a, "replay:", 7) == 0) {
          opt->source = SourceKind::kReplay;
          if (!CopyText(a + 7, &opt->replay_dir)) return Fail(why, why_size, "--source replay:DIR: directory empty or too long: '%s'", a);
        } else {
          return Fail(why, why_size, "--source: expected v4l2 or replay:DIR, got '%s'", a);
        }
        have_source = true;
        break;
      case kDevice: {
        const char* eq = std::strchr(a, '=');
        if (eq == nullptr || eq == a || opt->num_devices >= limits::kMaxCameras)
          return Fail(why, why_size, "--device: expected NAME=PATH (at most 4), got '%s'", a);
        auto& name = opt->device_camera[static_cast<std::size_t>(opt->num_devices)];
        const auto len = static_cast<std::size_t>(eq - a);
        if (len >= name.size()) return Fail(why, why_size, "--device: camera name too long in '%s'", a);
        name.fill('\0');
        std::memcpy(name.data(), a, len);
        if (!CopyText(eq + 1, &opt->device_path[static_cast<std::size_t>(opt->num_devices)]))
          return Fail(why, why_size, "--device: path empty or too long in '%s'", a);
        ++opt->num_devices;
        break;
      }
      case kY16: opt->y16 = true; break;
      case kBuffers:
        if (!ParseLong(a, limits::kMinCaptureBuffers, limits::kMaxCaptureBuffers, &n))
          return Fail(why, why_size, "--buffers: expected 4..8, got '%s'", a);
        opt->buffers = static_cast<int>(n);
        break;
      case kRate:
        if (!ParseDouble(a, 0.1, 1000.0, &opt->rate_hz)) return Fail(why, why_size, "--rate-hz: expected 0.1..1000, got '%s'", a);
        opt->rate_given = true;
        break;
      case kTrigger: {
        const char* colon = std::strrchr(a, ':');
        if (colon == nullptr || colon == a) return Fail(why, why_size, "--trigger: expected CHIP:LINE, got '%s'", a);
        const auto len = static_cast<std::size_t>(colon - a);
        if (len >= opt->trigger_chip.size()) return Fail(why, why_size, "--trigger: chip name too long in '%s'", a);
        opt->trigger_chip.fill('\0');
        std::memcpy(opt->trigger_chip.data(), a, len);
        if (!ParseLong(colon + 1, 0, 1023, &n)) return Fail(why, why_size, "--trigger: line must be 0..1023 in '%s'", a);
        opt->trigger_line = static_cast<int>(n);
        break;
      }
      case kPulse:
        if (!ParseLong(a, 1, 100000, &n)) return Fail(why, why_size, "--trigger-pulse-us: expected 1..100000, got '%s'", a);
        opt->trigger_pulse_us = static_cast<int>(n);
        break;
      case kOutput: {
        OutputProtocol protocol = OutputProtocol::kMfns;
        const char* udp_url = nullptr;
        if (ParseOutputUrl(a, &protocol, &udp_url) != PublishStatus::kOk)
          return Fail(why, why_size, "--output: expected udp://HOST:PORT or mavlink+udp://HOST:PORT, got '%s'", a);
        if (opt->num_outputs >= limits::kMaxOutputs)
          return Fail(why, why_size, "--output: at most %d outputs, '%s' is one more", limits::kMaxOutputs, a);
        if (!CopyText(a, &opt->outputs[static_cast<std::size_t>(opt->num_outputs)]))
          return Fail(why, why_size, "--output: too long: '%s'", a);
        ++opt->num_outputs;
        break;
      }
      case kMavlinkSysid:
      case kMavlinkCompid:
        mavlink_option = c == kMavlinkSysid ? "--mavlink-sysid" : "--mavlink-compid";
        if (!ParseLong(a, 1, 255, &n))
          return Fail(why, why_size, "--mavlink-%s: expected 1..255, got '%s'", c == kMavlinkSysid ? "sysid" : "compid", a);
        (c == kMavlinkSysid ? opt->mavlink.system_id : opt->mavlink.component_id) = static_cast<std::uint8_t>(n);
        break;
      case kMavlinkFrame:
        mavlink_option = "--mavlink-frame";
        if (std::strcmp(a, ToString(MavlinkAxes::kFrd)) == 0) opt->mavlink.axes = MavlinkAxes::kFrd;
        else if (std::strcmp(a, ToString(MavlinkAxes::kFlu)) == 0) opt->mavlink.axes = MavlinkAxes::kFlu;
        else return Fail(why, why_size, "--mavlink-frame: expected frd or flu, got '%s'", a);
        break;
      case kLog:
        if (!CopyText(a, &opt->log)) return Fail(why, why_size, "--log: path empty or too long: '%s'", a);
        break;
      case kFrames:
        if (!ParseLong(a, 1, 1000000000LL, &n)) return Fail(why, why_size, "--frames: expected a positive count, got '%s'", a);
        opt->frames = n;
        break;
      case kTimeout:
        if (!ParseLong(a, 1, 60000, &n)) return Fail(why, why_size, "--timeout-ms: expected 1..60000, got '%s'", a);
        opt->timeout_ms = static_cast<int>(n);
        break;
      case kDeadline:
        if (!ParseDouble(a, 0.1, 60000.0, &opt->deadline_ms)) return Fail(why, why_size, "--deadline-ms: expected 0.1..60000, got '%s'", a);
        break;
      case kSigma:
        if (!ParseDouble(a, 1e-4, 100.0, &opt->sigma_px)) return Fail(why, why_size, "--sigma-px: expected 0.0001..100, got '%s'", a);
        break;
      case kHealthEvery:
        if (!ParseLong(a, 1, 1000000, &n)) return Fail(why, why_size, "--health-every: expected a positive count, got '%s'", a);
        opt->health_every = static_cast<int>(n);
        break;
      case kRetryEvery:
        if (!ParseLong(a, 1, 1000000, &n)) return Fail(why, why_size, "--camera-retry-every: expected a positive count, got '%s'", a);
        opt->camera_retry_every = static_cast<int>(n);
        break;
      case kSetAside:
        if (!ParseLong(a, 1, 1000, &n)) return Fail(why, why_size, "--camera-timeouts: expected 1..1000, got '%s'", a);
        opt->camera_timeouts_to_set_aside = static_cast<int>(n);
        break;
      case kInitialPose:
        if (!ParseList(a, 6, opt->initial_pose.data()))
          return Fail(why, why_size, "--initial-pose: expected X,Y,Z,ROLL,PITCH,YAW (mm, deg), got '%s'", a);
        opt->has_initial_pose = true;
        break;
      case kInitialSigma: {
        double v[2] = {0.0, 0.0};
        if (!ParseList(a, 2, v) || v[0] < 0.0 || v[0] > 1e4 || v[1] < 0.0 || v[1] > 180.0)
          return Fail(why, why_size, "--initial-sigma: expected MM,DEG (0..10000, 0..180), got '%s'", a);
        opt->initial_sigma_mm = v[0];
        opt->initial_sigma_deg = v[1];
        break;
      }
      case kPidFile:
        if (std::strlen(a) >= opt->pid_file.size()) return Fail(why, why_size, "--pid-file: path too long: '%s'", a);
        opt->pid_file.fill('\0');
        std::memcpy(opt->pid_file.data(), a, std::strlen(a));
        break;
      case kQuiet: opt->quiet = true; break;
      case kRealtime: opt->realtime = true; break;
      case kNoWindowed: opt->windowed_detection = false; break;
      case kThreeBeaconFixes: opt->three_beacon_fixes = true; break;
      case kHelp: opt->help = true; return OptionsStatus::kHelp;
      default: {
        const char* bad = (optind >= 1 && optind <= argc) ? argv[optind - 1] : "?";
        return Fail(why, why_size, "unknown option or missing value: '%s' (see --help)", bad);
      }
    }
  }
  if (optind < argc) return Fail(why, why_size, "unexpected argument '%s' (see --help)", argv[optind]);
  if (opt->params[0] == '\0') return Fail(why, why_size, "%s", "--params FILE|DIR is required");
  if (!have_source) return Fail(why, why_size, "%s", "--source v4l2|replay:DIR is required");
  // A MAVLink setting with no MAVLink output would be ignored: say so rather than run without it.
  if (mavlink_option != nullptr && !HasMavlinkOutput(*opt))
    return Fail(why, why_size, "%s: no --output mavlink+udp://HOST:PORT to apply it to", mavlink_option);
  // Defaults that depend on the rate.
  const double period_ms = 1000.0 / opt->rate_hz;
  if (opt->timeout_ms == 0) opt->timeout_ms = static_cast<int>(3.0 * period_ms + 0.5);
  if (opt->deadline_ms == 0.0) opt->deadline_ms = period_ms;
  const int per_second = static_cast<int>(opt->rate_hz + 0.5) > 0 ? static_cast<int>(opt->rate_hz + 0.5) : 1;
  if (opt->health_every == 0) opt->health_every = per_second;
  if (opt->camera_retry_every == 0) opt->camera_retry_every = per_second;
  return OptionsStatus::kOk;
}

}  // namespace mfns::fw
