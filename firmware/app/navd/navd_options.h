// mfns-navd command line (DESIGN.md, "Firmware"):
//   mfns-navd --params FILE|DIR --source v4l2|replay:DIR [--output udp://HOST:PORT]...
//             [--output mavlink+udp://HOST:PORT]... [--log poses.csv] [--frames N] [options]
// Parsed into fixed storage (no heap); a bad argument gives a one-line reason.
#pragma once

#include <array>
#include <cstdint>

#include "common/limits.h"
#include "common/rig/rig.h"
#include "firmware/modules/publish/mavlink.h"

namespace mfns::fw {

enum class SourceKind : unsigned char { kV4l2 = 0, kReplay = 1 };

struct NavdOptions {
  using Path = std::array<char, limits::kMaxPathChars + 1>;
  Path params{};                 // blob file or parameter store directory
  SourceKind source = SourceKind::kReplay;
  Path replay_dir{};             // --source replay:DIR
  // --device NAME=PATH, per camera name (v4l2); unnamed cameras default to /dev/video<k>.
  int num_devices = 0;
  std::array<std::array<char, limits::kMaxCameraNameChars + 1>, limits::kMaxCameras> device_camera{};
  std::array<Path, limits::kMaxCameras> device_path{};
  bool y16 = false;              // --y16: negotiate V4L2 Y16 instead of GREY
  int buffers = limits::kMinCaptureBuffers;
  double rate_hz = 18.6;         // frame rate: deadline, replay timestamps without truth.csv
  bool rate_given = false;
  Path trigger_chip{};           // --trigger CHIP:LINE ("" = no trigger)
  int trigger_line = -1;
  int trigger_pulse_us = 1000;
  // --output, up to limits::kMaxOutputs of them: udp://HOST:PORT (the MFNS datagrams) or
  // mavlink+udp://HOST:PORT (MAVLink 2 HEARTBEAT and ODOMETRY).
  int num_outputs = 0;
  std::array<Path, limits::kMaxOutputs> outputs{};
  // --mavlink-sysid N (default 1), --mavlink-compid N (default 197,
  // MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY), --mavlink-frame frd|flu (default frd).
  MavlinkConfig mavlink;
  Path log{};                    // poses CSV ("" = none)
  std::int64_t frames = 0;       // frame sets to process (0 = until the source ends or SIGINT)
  int timeout_ms = 0;            // per camera per frame set (0 = 3 frame periods)
  double deadline_ms = 0.0;      // per frame set (0 = one frame period)
  double sigma_px = 0.15;        // centroid noise 1-sigma for the covariance
  int health_every = 0;          // a health datagram every N frame sets (0 = once a second)
  int camera_retry_every = 0;    // frame sets between retries of a set-aside camera (0 = 1 s)
  int camera_timeouts_to_set_aside = 3;
  // --initial-pose X,Y,Z,ROLL,PITCH,YAW: a known start pose (the dock) in the poses CSV's
  // terms (r_w_wb in mm; the paper's 2-1-3 Euler angles of C_b_w in deg), with its 1-sigma
  // errors (--initial-sigma MM,DEG).
  bool has_initial_pose = false;
  std::array<double, 6> initial_pose{};
  double initial_sigma_mm = 10.0, initial_sigma_deg = 1.0;
  Path pid_file{};               // --pid-file ("" = none); default /run/mfns-navd.pid
  bool quiet = false;
  bool realtime = false;  // replay: each frame set at its recorded time (ReplayConfig::realtime)
  bool windowed_detection = true;  // --no-windowed-detection: full frames always (NavLoopConfig)
  bool three_beacon_fixes = false;  // --three-beacon-fixes: TrackOptions::verify_three_beacons and three_beacon_fix_steady false
  bool help = false;
};

enum class OptionsStatus : unsigned char { kOk = 0, kHelp, kError };

// Parses argv. On kError *why holds a one-line reason (NUL-terminated, truncated to why_size).
OptionsStatus ParseNavdOptions(int argc, char** argv, NavdOptions* opt, char* why, std::size_t why_size);

// The --initial-pose as a body pose (r_w_wb in m, C_w_b); false when none was given.
bool InitialPoseOf(const NavdOptions& opt, BodyPose* pose);

// Usage text for --help.
const char* NavdUsage();

}  // namespace mfns::fw
