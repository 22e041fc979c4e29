// `mfns-sim faults`' options checked and turned into the faults and the scenario of a run (faults.h),
// apart from the campaign (faults.cc): needs the scenario reader only, so that host_cli_fuzz
// runs these checks after each parse.
#include <algorithm>
#include <cmath>
#include <string>

#include "host/sim/faults/faults.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

int SpanOf(double seconds, double rate_hz) { return static_cast<int>(std::lround(seconds * rate_hz)); }

// A run renders every frame set of every camera into memory before it runs (RenderAll): --frames
// is bounded by that memory, so that a typo (--frames 1000000) is refused rather than an hour
// into rendering. 2000 megapixels: 8 138 frame sets of station-box's three 1280x1024 cameras at
// the default --divisor 4, 508 at --divisor 1.
constexpr double kMaxImageMegapixels = 2000.0;
// Cameras shrunk below this many pixels a side (--divisor) image no beacon usefully.
constexpr int kMinSidePx = 16;

Scenario Preset(const std::string& name) {
  try {
    return LoadPreset(name);
  } catch (const UserError& e) {
    throw UserError(std::string("--preset: ") + e.what());
  }
}

}  // namespace

Scenario FaultBaseScenario(const FaultRunOptions& o) {
  if (o.frames < 2 || o.frames > 1'000'000) throw UserError("--frames: must be 2..1000000");
  if (o.fault_at < 1 || o.fault_at >= o.frames) throw UserError("--fault-at: must be within 1..frames-1");
  if (o.image_divisor < 1) throw UserError("--divisor: must be >= 1");
  Scenario s = Preset(o.preset);
  s.seed = o.seed;
  s.frames = o.frames;
  const double d = o.image_divisor;
  double pixels = 0.0;
  for (int k = 0; k < s.rig.num_cameras; ++k) {
    CameraIntrinsics& c = s.rig.cameras[static_cast<std::size_t>(k)].intrinsics;
    c.width = static_cast<int>(c.width / d);
    c.height = static_cast<int>(c.height / d);
    if (std::min(c.width, c.height) < kMinSidePx)
      throw UserError("--divisor: " + std::to_string(o.image_divisor) + " leaves camera " +
                      s.rig.cameras[static_cast<std::size_t>(k)].name.data() + " " + std::to_string(c.width) + "x" +
                      std::to_string(c.height) + " px, fewer than " + std::to_string(kMinSidePx) + " a side");
    pixels += static_cast<double>(c.width) * c.height;
    c.alpha_x /= d;
    c.alpha_y /= d;
    c.skew /= d;
    c.u0 = (c.u0 + 0.5) / d - 0.5;
    c.v0 = (c.v0 + 0.5) / d - 0.5;
  }
  const double megapixels = pixels * o.frames * 1e-6;
  if (megapixels > kMaxImageMegapixels)
    throw UserError("--frames: " + std::to_string(o.frames) + " frame sets at --divisor " +
                    std::to_string(o.image_divisor) + " are " + std::to_string(std::lround(megapixels)) +
                    " megapixels of images held in memory, more than " +
                    std::to_string(std::lround(kMaxImageMegapixels)) + " (fewer frames or a larger --divisor)");
  return s;
}

std::vector<FaultSpec> IssueFaults(const FaultRunOptions& o) {
  const int a = o.fault_at;
  const int two_s = SpanOf(2.0, Preset(o.preset).frame_rate_hz);
  return {{"stall", FaultKind::kStall, 1, a, a + 19, 0.0},
          {"unplug", FaultKind::kUnplug, 1, a, o.frames - 1, 0.0},
          {"zero-frames", FaultKind::kZeroFrames, 0, a, a + 2, 0.0},
          {"white-frames", FaultKind::kWhiteFrames, 0, a, a + 2, 0.0},
          {"truncated-frames", FaultKind::kTruncatedFrames, 0, a, a + 2, 0.0},
          {"reflections", FaultKind::kReflections, 0, a, a + two_s - 1, 0.0},
          {"occlusion", FaultKind::kOcclusion, 2, a, a + two_s - 1, 0.0},
          {"glare", FaultKind::kGlare, 2, a, a + two_s - 1, 0.0},
          {"time-repeat", FaultKind::kTimeRepeat, 0, a, a, 0.0},
          {"time-backward", FaultKind::kTimeBackward, 0, a, a, 1.0},
          {"time-forward", FaultKind::kTimeForward, 0, a, a, 1.0},
          {"wrong-rig-reload", FaultKind::kWrongRigReload, 0, a, a, 0.0}};
}

std::vector<FaultSpec> SelectFaults(const FaultsCommandOptions& a) {
  FaultBaseScenario(a.run);  // checks --frames, --fault-at, --divisor and --preset as the campaign will
  std::vector<FaultSpec> all = IssueFaults(a.run), chosen;
  for (const std::string& name : a.only)
    if (std::none_of(all.begin(), all.end(), [&](const FaultSpec& f) { return f.name == name; }))
      throw UserError("--only: no fault named '" + OneLine(name) + "'");
  for (const FaultSpec& f : all)
    if (a.only.empty() || std::find(a.only.begin(), a.only.end(), f.name) != a.only.end()) chosen.push_back(f);
  return chosen;
}

}  // namespace mfns::host
