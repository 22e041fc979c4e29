#include "firmware/app/navd/nav_loop.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/camera/camera.h"
#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "common/testing/loopback_udp.h"
#include "firmware/drivers/gpio/fake_gpio_line_io.h"
#include "firmware/drivers/gpio/gpio_trigger.h"
#include "firmware/lib/in_process_source.h"
#include "firmware/modules/publish/publishers.h"
#include "firmware/modules/detect/detect_testing.h"
#include "firmware/modules/solve/synthetic_scene.h"
#include "firmware/lib/testing/alloc_counter.h"

namespace mfns::fw {
namespace {

// The paper rig shrunk to 320x256 cameras (same field of view) so that thousands of frame
// sets stay fast, also under qemu.
Rig SmallRig() {
  Rig rig = PaperRig();
  rig.beacon_sigma = 0.0;  // the frames are rendered with this very map: it is exact
  for (int k = 0; k < rig.num_cameras; ++k) {
    CameraIntrinsics& c = rig.cameras[static_cast<std::size_t>(k)].intrinsics;
    c.width = 320;
    c.height = 256;
    c.alpha_x /= 4;
    c.alpha_y /= 4;
    c.u0 = (c.u0 + 0.5) / 4 - 0.5;
    c.v0 = (c.v0 + 0.5) / 4 - 0.5;
  }
  return rig;
}

// Renders the frame sets of a yaw sweep (1 deg per frame set, the paper turntable's step)
// into buffers reserved at construction, so that the loop under test can be fed thousands of
// frame sets without a heap allocation in the test either: background 9-11 DN (a fixed
// pattern), every beacon in an image a Gaussian spot (sigma 1 px, 1200 DN), no temporal noise.
class SweepRenderer {
 public:
  explicit SweepRenderer(const Rig& rig) : rig_(rig) {
    for (int k = 0; k < rig.num_cameras; ++k) {
      const CameraIntrinsics& c = rig.cameras[static_cast<std::size_t>(k)].intrinsics;
      const auto n = static_cast<std::size_t>(c.width) * static_cast<std::size_t>(c.height);
      frames_[static_cast<std::size_t>(k)].resize(n);
      // The sensor's fixed pattern: 9-11 DN (a perfectly flat frame is a blank one, which
      // the loop treats as a camera fault: DetectStatus::kBlankFrame).
      std::vector<std::uint8_t>& bg = background_[static_cast<std::size_t>(k)];
      bg.resize(n);
      std::uint32_t h = 2166136261u + static_cast<std::uint32_t>(k);
      for (std::uint8_t& p : bg) {
        h = h * 1664525u + 1013904223u;
        p = static_cast<std::uint8_t>(9 + (h >> 24) % 3);
      }
    }
  }

  // Frame set n: yaw n deg (n x deg_per_set); returns the number of beacons in view (images, 3
  // px inside).
  int Render(long n, double deg_per_set = 1.0) {
    pose_ = BodyPose{};
    pose_.C_w_b = R3(DegToRad(std::fmod(static_cast<double>(n) * deg_per_set, 360.0))).transpose();
    int visible = 0;
    for (int k = 0; k < rig_.num_cameras; ++k) {
      const RigCamera& cam = rig_.cameras[static_cast<std::size_t>(k)];
      std::vector<std::uint8_t>& img = frames_[static_cast<std::size_t>(k)];
      img = background_[static_cast<std::size_t>(k)];  // (same size: no allocation)
      for (int b = 0; b < rig_.num_beacons; ++b) {
        Eigen::Vector2d uv;
        if (ProjectBeacon(cam, pose_, rig_.beacons_w[static_cast<std::size_t>(b)], &uv) != ProjectStatus::kOk ||
            !InImage(cam.intrinsics, uv, 3.0))
          continue;
        ++visible;
        AddSpot(cam.intrinsics.width, cam.intrinsics.height, uv, &img);
      }
    }
    return visible;
  }

  FrameView View(int k, std::uint64_t t_ns, std::uint32_t seq) const {
    FrameView v;
    v.data = frames_[static_cast<std::size_t>(k)].data();
    v.width = rig_.cameras[static_cast<std::size_t>(k)].intrinsics.width;
    v.height = rig_.cameras[static_cast<std::size_t>(k)].intrinsics.height;
    v.stride_bytes = v.width;
    v.format = PixelFormat::kMono8;
    v.t_capture_ns = t_ns;
    v.sequence = seq;
    v.camera = k;
    return v;
  }

  const BodyPose& pose() const { return pose_; }

  // A spot the map does not predict (a reflection) into camera k's current frame.
  void AddReflection(int k, const Eigen::Vector2d& uv) {
    const CameraIntrinsics& c = rig_.cameras[static_cast<std::size_t>(k)].intrinsics;
    AddSpot(c.width, c.height, uv, &frames_[static_cast<std::size_t>(k)]);
  }

 private:
  static void AddSpot(int w, int h, const Eigen::Vector2d& uv, std::vector<std::uint8_t>* img) {
    const int x0 = std::max(0, static_cast<int>(uv.x()) - 5), x1 = std::min(w - 1, static_cast<int>(uv.x()) + 6);
    const int y0 = std::max(0, static_cast<int>(uv.y()) - 5), y1 = std::min(h - 1, static_cast<int>(uv.y()) + 6);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        std::uint8_t& p = (*img)[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)];
        const double v = p + 1200.0 * testing::PixelFraction(x, uv.x(), 1.0) * testing::PixelFraction(y, uv.y(), 1.0);
        p = static_cast<std::uint8_t>(std::min(255L, std::lround(v)));
      }
  }

  const Rig& rig_;
  BodyPose pose_;
  std::array<std::vector<std::uint8_t>, limits::kMaxCameras> frames_, background_;
};

constexpr std::uint64_t kFrameNs = 53763441;  // 18.6 Hz

NavLoopConfig Config() {
  NavLoopConfig c;
  c.sigma_px = 0.05;
  c.health_every = 5;
  c.camera_retry_every = 4;
  // (SmallRig has the paper's optics at a quarter of the pixels: the navigator scales its gates.)
  // The paper's dark lab, where every light is a beacon: a track found on three beacons is a fix
  // (these tests count fixes of the loop; the default, degraded until a pose on four beacons, is
  // tracker_test's and navmatrix_test's).
  c.navigator.track.verify_three_beacons = false;
  return c;
}

long FrameSetsForAllocationTest() { return testing::Trials(10000, 1000); }

// A fix is right when the pose is the truth's (identities are checked by the navigator tests).
bool FixIsRight(const PoseRecord& rec, const BodyPose& truth) {
  const Eigen::Matrix3d C_w_b = rec.q_w_b.toRotationMatrix();
  return (rec.r_w_wb - truth.r_w_wb).norm() < 0.02 && LogSO3(truth.C_w_b.transpose() * C_w_b).norm() < DegToRad(1.0);
}

// The shrunk sweep feeding a loop that starts at the sweep's first pose exactly (no
// acquisition; Start(false): cold, no initial pose); trigger, outputs and log as given (null:
// none). Start() before use.
struct TrackedSweep {
  explicit TrackedSweep(GpioTrigger* trigger = nullptr, Outputs* outputs = nullptr, PoseLog* log = nullptr)
      : sweep(rig), source(rig.num_cameras), loop(rig, &source, trigger, outputs, log) {}
  bool Start(bool from_first_pose = true) {
    NavLoopConfig c = Config();
    c.has_initial_pose = from_first_pose;
    return source.Start() == SourceStatus::kOk && loop.Configure(c, nullptr);
  }
  // Renders frame set n and gives it to every camera, stamped t_ns; returns the beacons in view.
  // sequence: the driver's frame number (default n; a gap counts as dropped frames).
  int Push(long n, std::uint64_t t_ns, int sequence = -1) {
    const int visible = sweep.Render(n);
    const auto seq = static_cast<std::uint32_t>(sequence >= 0 ? sequence : n);
    for (int k = 0; k < rig.num_cameras; ++k) EXPECT_TRUE(source.Push(k, sweep.View(k, t_ns, seq)));
    return visible;
  }
  // Frame set n through the loop into *rec (Push); counts a wrong pose in *wrong and returns the
  // beacons in view.
  int StepStamped(int n, std::uint64_t t_ns, PoseRecord* rec, int* wrong, int sequence = -1) {
    const int visible = Push(n, t_ns, sequence);
    EXPECT_EQ(loop.Step(rec), StepStatus::kOk);
    *wrong += rec->status != NavStatus::kLost && !FixIsRight(*rec, sweep.pose());
    return visible;
  }
  const Rig rig = SmallRig();
  SweepRenderer sweep;
  InProcessSource source;
  NavLoop loop;
};

// Issue 4: no heap after start, counted over 10,000 frame sets (1,000 under qemu and the
// sanitizers); and the images of the sweep give a fix in every frame set with >= 3 beacons
// after the first one (the acquisition), each right.
TEST(NavLoop, NoAllocationAfterStartAndFixesFromImages) {
  TrackedSweep s;
  ASSERT_TRUE(s.Start(false));
  const SweepRenderer& sweep = s.sweep;
  NavLoop* loop = &s.loop;

  const long sets = FrameSetsForAllocationTest();
  const std::uint64_t before = testing::AllocationCount();
  long first_fix = -1, sets_3plus = 0, fixes_3plus = 0, posed_3plus = 0, wrong = 0;
  PoseRecord rec;
  for (long n = 0; n < sets; ++n) {
    const int visible = s.Push(n, 1'000'000'000ull + static_cast<std::uint64_t>(n) * kFrameNs);
    ASSERT_EQ(loop->Step(&rec), StepStatus::kOk);
    const bool fix = rec.status != NavStatus::kLost;
    if (fix && first_fix < 0) first_fix = n;
    if (fix && !FixIsRight(rec, sweep.pose())) ++wrong;
    if (first_fix >= 0 && visible >= 3) {
      ++sets_3plus;
      fixes_3plus += rec.status == NavStatus::kFix;
      posed_3plus += fix;
    }
  }
  std::printf("%ld frame sets of 320x256 images: first fix at %ld, then fix in %ld (posed in %ld) of %ld frame sets "
              "with >= 3 beacons, %ld wrong\n",
              sets, first_fix, fixes_3plus, posed_3plus, sets_3plus, wrong);
  EXPECT_EQ(testing::AllocationCount() - before, 0u) << "heap allocations after start";
  EXPECT_GE(first_fix, 0);
  EXPECT_LT(first_fix, 40);
  // (Measured: posed in 8221 of 8572. The frame sets without a pose follow the long gap of the
  // sweep (2.3 s with 2 beacons; the full-resolution sweep settles at once, see navigator_test
  // and the must-show test): on these 320 x 256 images the beacon that ends the gap enters at
  // the image border, truncated, and several poses stay consistent within the prediction's
  // bounds for ~12 frame sets. Lost, with reason "acquiring", never a wrong pose. Of the posed,
  // 84 three-beacon poses carry an attitude 1-sigma above TrackOptions::max_attitude_sigma_rad
  // (0.25 deg: these images have a quarter of the paper's pixels per radian): degraded.)
  EXPECT_GE(posed_3plus, sets_3plus * 95 / 100);
  EXPECT_GE(fixes_3plus, sets_3plus * 93 / 100);
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(loop->counters().frame_sets, static_cast<std::uint64_t>(sets));
}

// The per-stage times (LoopCounters::stage_*, what -icount turns into instruction counts on the
// emulated board): every stage that runs is counted, none more than the wall time around the
// steps, each worst between the mean and the total; detection of three frames costs more than
// publishing nowhere.
TEST(NavLoop, StageTimesAddUpWithinTheFrameSets) {
  TrackedSweep s;
  ASSERT_TRUE(s.Start(false));
  constexpr int kSets = 40;
  std::uint64_t wall_ns = 0;
  for (int n = 0; n < kSets; ++n) {
    s.Push(n, 1'000'000'000ull + static_cast<std::uint64_t>(n) * kFrameNs);
    const std::uint64_t t0 = MonotonicNs();  // (the pushes above are the test's, not the loop's)
    ASSERT_EQ(s.loop.Step(), StepStatus::kOk);
    wall_ns += MonotonicNs() - t0;
  }
  const LoopCounters& c = s.loop.counters();
  std::uint64_t sum = 0;
  for (int i = 0; i < kNumStages; ++i) {
    const auto si = static_cast<std::size_t>(i);
    const char* name = ToString(static_cast<Stage>(i));
    sum += c.stage_total_ns[si];
    EXPECT_LE(c.stage_worst_ns[si], c.stage_total_ns[si]) << name;
    EXPECT_GE(c.stage_worst_ns[si] * kSets, c.stage_total_ns[si]) << name;
  }
  EXPECT_GT(c.stage_total_ns[static_cast<std::size_t>(Stage::kDetect)], 0u);
  EXPECT_GT(c.stage_total_ns[static_cast<std::size_t>(Stage::kNavigate)], 0u);
  EXPECT_GT(c.stage_total_ns[static_cast<std::size_t>(Stage::kDetect)],
            c.stage_total_ns[static_cast<std::size_t>(Stage::kPublish)]);
  EXPECT_LE(sum, wall_ns);
  EXPECT_STREQ(ToString(Stage::kAcquire), "acquire");
  EXPECT_STREQ(ToString(Stage::kPublish), "publish");
}

// A UDP socket on loopback for the outputs to send to; *url gets its address in scheme.
int LoopbackReceiver(const char* scheme, std::string* url) {
  std::string port;
  const int rx = ::mfns::testing::LoopbackUdpSocket(&port);
  *url = std::string(scheme) + "127.0.0.1:" + port;
  return rx;
}

// A frame set's blobs datagram against its pose: lost, no blob is matched; posed, at least as
// many as the pose's beacons, each where the pose projects its beacon (1 px). Returns 1.
int CheckBlobsMatchThePose(const Rig& rig, const PoseRecord& pose, const BlobsRecord& blobs) {
  int matched = 0;
  const Eigen::Matrix3d C_w_b = pose.q_w_b.toRotationMatrix();
  for (int i = 0; i < blobs.num_blobs; ++i) {
    const BlobEntry& b = blobs.blobs[static_cast<std::size_t>(i)];
    if (b.beacon < 0) continue;
    ++matched;
    if (pose.status == NavStatus::kLost) continue;
    const RigCamera& cam = rig.cameras[b.camera];
    const Eigen::Vector3d p_k =
        cam.C_k_b * (C_w_b.transpose() * (rig.beacons_w[static_cast<std::size_t>(b.beacon)] - pose.r_w_wb) - cam.r_b_bk);
    Eigen::Vector2d uv;
    EXPECT_EQ(Project(cam.intrinsics, p_k, &uv), ProjectStatus::kOk);
    EXPECT_LT((uv - Eigen::Vector2d(b.u_px, b.v_px)).norm(), 1.0) << "frame set " << pose.frame_set << " beacon " << b.beacon;
  }
  if (pose.status == NavStatus::kLost) EXPECT_EQ(matched, 0);
  else EXPECT_GE(matched, pose.num_beacons);
  EXPECT_EQ(blobs.t_capture_ns, pose.t_capture_ns);
  return 1;
}

// Issue 14 item 6: no heap after start also with every output on: the trigger pulsing a line
// (the fake gpiod seam, its call record reserved beforehand), UDP pose and health datagrams to
// a local socket, and the poses log. Each output is checked to have worked every frame set.
// Issue 17: and MAVLink (HEARTBEAT, ODOMETRY) to a second socket at the same time.
TEST(NavLoop, NoAllocationAfterStartWithTriggerUdpMavlinkAndLog) {
  const Rig rig = SmallRig();
  SweepRenderer sweep(rig);
  InProcessSource source(rig.num_cameras);
  ASSERT_EQ(source.Start(), SourceStatus::kOk);
  const long sets = testing::Trials(2000, 300);
  FakeGpioLineIo gpio;
  gpio.calls.reserve(static_cast<std::size_t>(8 * sets + 16));
  TriggerConfig tc;
  tc.enabled = true;
  tc.chip = "gpiochip0";
  tc.line_offset = 17;
  GpioTrigger trigger(&gpio, tc);
  ASSERT_EQ(trigger.Start(), TriggerStatus::kOk);
  std::string url, mav_url;
  const int rx = LoopbackReceiver("udp://", &url);
  const int mav_rx = LoopbackReceiver("mavlink+udp://", &mav_url);
  ASSERT_GE(rx, 0);
  ASSERT_GE(mav_rx, 0);
  Outputs outputs;
  ASSERT_EQ(outputs.Add(url.c_str()), PublishStatus::kOk);
  ASSERT_EQ(outputs.Add(mav_url.c_str()), PublishStatus::kOk);
  const std::string path = ::testing::TempDir() + "nav_loop_outputs.csv";
  PoseLog log;
  ASSERT_EQ(log.Open(path.c_str()), PublishStatus::kOk);
  auto loop = std::make_unique<NavLoop>(rig, &source, &trigger, &outputs, &log);
  ASSERT_TRUE(loop->Configure(Config(), nullptr));

  const std::uint64_t before = testing::AllocationCount();
  std::array<std::uint8_t, kMaxBlobsMessageBytes> datagram{};
  long received = 0, heartbeats = 0, odometry = 0, posed = 0, blob_messages = 0, blobs_checked = 0;
  PoseRecord rec;
  BlobsRecord blobs;
  for (long n = 0; n < sets; ++n) {
    sweep.Render(n);
    for (int k = 0; k < rig.num_cameras; ++k)
      ASSERT_TRUE(source.Push(k, sweep.View(k, 1'000'000'000ull + static_cast<std::uint64_t>(n) * kFrameNs,
                                            static_cast<std::uint32_t>(n))));
    ASSERT_EQ(loop->Step(&rec), StepStatus::kOk);
    posed += rec.status != NavStatus::kLost;
    for (ssize_t got; (got = ::recv(rx, datagram.data(), datagram.size(), MSG_DONTWAIT)) > 0;) {  // (keeps the queue short)
      ++received;
      const std::span<const std::uint8_t> d(datagram.data(), static_cast<std::size_t>(got));
      if (DecodeBlobs(d, &blobs) != MessageStatus::kOk) continue;
      ++blob_messages;
      if (blobs.frame_set == rec.frame_set) blobs_checked += CheckBlobsMatchThePose(rig, rec, blobs);
    }
    while (::recv(mav_rx, datagram.data(), datagram.size(), MSG_DONTWAIT) > 10) {
      const auto id = static_cast<std::uint32_t>(datagram[7] | datagram[8] << 8 | datagram[9] << 16);
      heartbeats += id == mavlink::kHeartbeatId;
      odometry += id == mavlink::kOdometryId;
    }
  }
  EXPECT_EQ(testing::AllocationCount() - before, 0u) << "heap allocations after start";
  ::close(rx);
  ::close(mav_rx);
  EXPECT_EQ(trigger.counters().pulses, static_cast<std::uint64_t>(sets));
  EXPECT_EQ(outputs.counters(0).send_errors, 0u);
  // A pose and a blobs datagram per frame set, and the health ones (health and a beacon page).
  EXPECT_EQ(outputs.counters(0).sent, static_cast<std::uint64_t>(2 * sets + 2 * (sets / Config().health_every)));
  EXPECT_GE(received, sets / 2) << "datagrams reached the socket";
  EXPECT_GE(blob_messages, sets / 4) << "blobs datagrams decoded";
  EXPECT_GE(blobs_checked, sets / 8) << "blobs datagrams checked against their frame set's pose";
  // MAVLink: an ODOMETRY per frame set with a pose, a HEARTBEAT per second of sample time.
  const double seconds = static_cast<double>(sets - 1) * static_cast<double>(kFrameNs) * 1e-9;
  EXPECT_EQ(outputs.counters(1).send_errors, 0u);
  EXPECT_EQ(odometry, posed);
  EXPECT_GE(heartbeats, static_cast<long>(seconds));
  EXPECT_LE(heartbeats, static_cast<long>(seconds) + 1);
  EXPECT_EQ(outputs.counters(1).sent, static_cast<std::uint64_t>(heartbeats + odometry));
  EXPECT_EQ(log.counters().log_rows, static_cast<std::uint64_t>(sets));
  ASSERT_EQ(log.Close(), PublishStatus::kOk);
  std::remove(path.c_str());
}

// Resident set size now (bytes), read without the heap (/proc/self/statm's second field).
long ResidentBytes() {
  const int fd = ::open("/proc/self/statm", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  std::array<char, 128> buf{};
  const ssize_t n = ::read(fd, buf.data(), buf.size() - 1);
  ::close(fd);
  if (n <= 0) return -1;
  long size = 0, resident = 0;
  if (std::sscanf(buf.data(), "%ld %ld", &size, &resident) != 2) return -1;
  return resident * ::sysconf(_SC_PAGESIZE);
}

// The faults of the soak, by frame set: which camera gives a blank (all-zero) or a saturated
// frame, times out, or stalls; and whether the frame set repeats the previous timestamp.
struct SoakFaults {
  int blank = -1, white = -1, timeout = -1;
  bool repeat_time = false;
};
SoakFaults FaultsAt(long n) {
  SoakFaults f;
  if (n % 97 == 50) f.blank = static_cast<int>((n / 97) % 3);
  if (n % 211 == 70) f.white = static_cast<int>((n / 211) % 3);
  if (n % 131 == 90) f.timeout = static_cast<int>((n / 131) % 3);
  if (n % 1009 >= 500 && n % 1009 < 530) f.timeout = 1;  // camera y stalls for 30 frame sets
  f.repeat_time = n % 173 == 100;
  // (No blank frame for y around its stall: while set aside its frames are not all read.)
  if (n % 1009 >= 490 && n % 1009 < 570) {
    if (f.blank == 1) f.blank = -1;
    if (f.white == 1) f.white = -1;
  }
  return f;
}

// Issue 14 item 4, the soak: frame sets through NavLoop with every output on (trigger, UDP,
// MAVLink, log) and faults mixed in (blank and saturated frames, timeouts, a camera stalled for 30 frame
// sets every 1009, repeated timestamps): no heap after start, resident memory flat, every
// fault counted as injected, never a wrong fix, and the sweep posed almost throughout. CI runs
// 3000 frame sets (fewer under qemu and the sanitizers); scripts/soak.sh runs 10^5
// (MFNS_SOAK_FRAME_SETS) and then also asserts no deadline slip (timing: the soak's machine).
TEST(NavLoop, SoakWithFaultsAndEveryOutput) {
  const char* env = std::getenv("MFNS_SOAK_FRAME_SETS");
  const bool soak = env != nullptr && std::atol(env) > 0;
  const long sets = soak ? std::atol(env) : testing::Trials(3000, 400);
  const Rig rig = SmallRig();
  SweepRenderer sweep(rig);
  InProcessSource source(rig.num_cameras);
  ASSERT_EQ(source.Start(), SourceStatus::kOk);
  FakeGpioLineIo gpio;
  // (Written once so that its pages are resident before the RSS is measured.)
  gpio.calls.resize(static_cast<std::size_t>(8 * sets + 16));
  gpio.calls.clear();
  TriggerConfig tc;
  tc.enabled = true;
  tc.chip = "gpiochip0";
  GpioTrigger trigger(&gpio, tc);
  ASSERT_EQ(trigger.Start(), TriggerStatus::kOk);
  Outputs outputs;  // discard port: sent, not read
  ASSERT_EQ(outputs.Add("udp://127.0.0.1:9"), PublishStatus::kOk);
  ASSERT_EQ(outputs.Add("mavlink+udp://127.0.0.1:9"), PublishStatus::kOk);
  const std::string path = ::testing::TempDir() + "nav_loop_soak.csv";
  PoseLog log;
  ASSERT_EQ(log.Open(path.c_str()), PublishStatus::kOk);
  NavLoopConfig c = Config();
  c.has_initial_pose = true;
  auto loop = std::make_unique<NavLoop>(rig, &source, &trigger, &outputs, &log);
  ASSERT_TRUE(loop->Configure(c, nullptr));
  std::vector<std::uint8_t> black(static_cast<std::size_t>(320 * 256), 0), white(black.size(), 255);

  const std::uint64_t allocs_before = testing::AllocationCount();
  long rss_early = 0, wrong = 0, posed = 0, injected_blank = 0, injected_repeat = 0;
  std::uint64_t t = 1'000'000'000ull;
  PoseRecord rec;
  long clean_3plus = 0, clean_posed = 0;  // frame sets without a fault, >= 3 beacons in view
  for (long n = 0; n < sets; ++n) {
    const int visible = sweep.Render(n);
    const SoakFaults f = FaultsAt(n);
    // A repeated stamp: this frame set carries the previous one's (the stamps after it are
    // right again; a clock that stays one period behind after it:
    // AClockThatStaysOnePeriodBehindAfterARepeatKeepsTheTrack).
    t += kFrameNs;
    const std::uint64_t stamp = f.repeat_time && n > 0 ? t - kFrameNs : t;
    injected_repeat += f.repeat_time && n > 0;
    for (int k = 0; k < rig.num_cameras; ++k) {
      if (k == f.timeout) {
        source.PushStatus(k, SourceStatus::kTimeout);
        continue;
      }
      FrameView v = sweep.View(k, stamp, static_cast<std::uint32_t>(n));
      if (k == f.blank) v.data = black.data();
      if (k == f.white) v.data = white.data();
      injected_blank += k == f.blank || k == f.white;
      ASSERT_TRUE(source.Push(k, v));
    }
    ASSERT_EQ(loop->Step(&rec), StepStatus::kOk);
    wrong += rec.status != NavStatus::kLost && !FixIsRight(rec, sweep.pose());
    posed += rec.status != NavStatus::kLost;
    if (visible >= 3 && f.blank < 0 && f.white < 0 && f.timeout < 0 && !f.repeat_time) {
      ++clean_3plus;
      clean_posed += rec.status != NavStatus::kLost;
    }
    if (n == sets / 10) rss_early = ResidentBytes();
  }
  const long rss_end = ResidentBytes();
  const std::uint64_t allocs = testing::AllocationCount() - allocs_before;
  const HealthRecord h = loop->Health();
  std::uint64_t bad_frames = 0;
  for (int k = 0; k < rig.num_cameras; ++k) bad_frames += h.cameras[static_cast<std::size_t>(k)].bad_frames;
  std::printf("soak: %ld frame sets with >= 3 beacons and no fault: %ld posed\n", clean_3plus, clean_posed);
  std::printf("soak: %ld frame sets, posed %ld, wrong %ld, allocations %llu, RSS %ld -> %ld kB, slips %llu, "
              "worst frame set %.2f ms, clock faults %u, bad frames %llu\n",
              sets, posed, wrong, static_cast<unsigned long long>(allocs), rss_early / 1024, rss_end / 1024,
              static_cast<unsigned long long>(loop->counters().deadline_slips),
              static_cast<double>(loop->counters().worst_frame_set_ns) * 1e-6, h.clock_faults,
              static_cast<unsigned long long>(bad_frames));
  EXPECT_EQ(allocs, 0u) << "heap allocations after start";
  EXPECT_EQ(wrong, 0);
  EXPECT_LE(rss_end - rss_early, 256 * 1024) << "resident memory grew";
  EXPECT_EQ(h.clock_faults, static_cast<std::uint32_t>(injected_repeat));
  EXPECT_EQ(bad_frames, static_cast<std::uint64_t>(injected_blank));
  EXPECT_EQ(trigger.counters().pulses, static_cast<std::uint64_t>(sets));
  EXPECT_EQ(log.counters().log_rows, static_cast<std::uint64_t>(sets));
  // (Measured: 95-98 %, as without faults; see docs/reliability.md.)
  EXPECT_GE(clean_posed, clean_3plus * 9 / 10);
  if (soak) {
    EXPECT_EQ(loop->counters().deadline_slips, 0u);
  }
  ASSERT_EQ(log.Close(), PublishStatus::kOk);
  std::remove(path.c_str());
}

TEST(NavLoop, ACameraThatStopsIsSetAsideRetriedAndTheOthersGoOn) {
  const Rig rig = SmallRig();
  SweepRenderer sweep(rig);
  InProcessSource source(rig.num_cameras);
  ASSERT_EQ(source.Start(), SourceStatus::kOk);
  auto loop = std::make_unique<NavLoop>(rig, &source, nullptr, nullptr, nullptr);
  ASSERT_TRUE(loop->Configure(Config(), nullptr));
  PoseRecord rec;
  int degraded_camera_down = 0, wrong = 0;
  constexpr int kStop = 60, kBack = 100;  // camera y silent in [kStop, kBack)
  for (int n = 0; n < 140; ++n) {
    sweep.Render(n);
    for (int k = 0; k < rig.num_cameras; ++k) {
      if (k == 1 && n >= kStop && n < kBack) {
        source.PushStatus(k, SourceStatus::kTimeout);  // camera y stops delivering
        continue;
      }
      source.Push(k, sweep.View(k, 1'000'000'000ull + static_cast<std::uint64_t>(n) * kFrameNs,
                                static_cast<std::uint32_t>(n)));
    }
    ASSERT_EQ(loop->Step(&rec), StepStatus::kOk);
    if (n == kStop + 2) {
      EXPECT_TRUE(loop->supervision(1).set_aside);  // 3 timeouts in a row
      EXPECT_FALSE(loop->supervision(0).set_aside);
    }
    if (n >= kStop + 2 && n < kBack) {
      EXPECT_NE(rec.status, NavStatus::kFix) << "frame set " << n << ": a fix with a camera set aside is degraded";
    }
    degraded_camera_down += rec.status == NavStatus::kDegraded && rec.reason == NavReason::kCameraDown;
    wrong += rec.status != NavStatus::kLost && !FixIsRight(rec, sweep.pose());
  }
  EXPECT_GT(degraded_camera_down, 10);  // the others still navigate
  EXPECT_EQ(wrong, 0);
  EXPECT_GE(loop->supervision(1).set_asides, 1u);  // retried, set aside again while it stays silent
  EXPECT_GT(loop->supervision(1).resets, 0u);
  EXPECT_FALSE(loop->supervision(1).set_aside);  // back after frames came again
}

// Frame sets [from, to) of the sweep through the loop; counts frame sets with >= 3 beacons in
// view, those with a fix, and wrong fixes.
struct SweepRun {
  int sets_3plus = 0, fixes_3plus = 0, wrong = 0;
};
SweepRun Drive(NavLoop* loop, SweepRenderer* sweep, InProcessSource* source, int from, int to) {
  SweepRun run;
  PoseRecord rec;
  for (int n = from; n < to; ++n) {
    const int visible = sweep->Render(n);
    for (int k = 0; k < source->num_cameras(); ++k)
      EXPECT_TRUE(source->Push(k, sweep->View(k, 1'000'000'000ull + static_cast<std::uint64_t>(n) * kFrameNs,
                                              static_cast<std::uint32_t>(n))));
    EXPECT_EQ(loop->Step(&rec), StepStatus::kOk);
    run.wrong += rec.status != NavStatus::kLost && !FixIsRight(rec, sweep->pose());
    if (visible >= 3) {
      ++run.sets_3plus;
      run.fixes_3plus += rec.status == NavStatus::kFix;
    }
  }
  return run;
}

// Two loops on the same frames: one with windowed detection, one on full frames (issue 20).
class WindowedAndFull {
 public:
  WindowedAndFull(const Rig& rig, NavLoopConfig c) : rig_(rig), windowed_source_(rig.num_cameras), full_source_(rig.num_cameras) {
    const char* why = nullptr;
    ok_ = windowed_source_.Start() == SourceStatus::kOk && full_source_.Start() == SourceStatus::kOk &&
          windowed_->Configure(c, &why);
    c.windowed_detection = false;
    ok_ = ok_ && full_->Configure(c, &why);
  }
  bool ok() const { return ok_; }
  // Frame set n of the sweep (already rendered) to both loops, one step each.
  bool Step(const SweepRenderer& sweep, int n, PoseRecord* windowed, PoseRecord* full) {
    for (int k = 0; k < rig_.num_cameras; ++k) {
      const FrameView v =
          sweep.View(k, 1'000'000'000ull + static_cast<std::uint64_t>(n) * kFrameNs, static_cast<std::uint32_t>(n));
      if (!windowed_source_.Push(k, v) || !full_source_.Push(k, v)) return false;
    }
    return windowed_->Step(windowed) == StepStatus::kOk && full_->Step(full) == StepStatus::kOk;
  }
  const NavLoop& windowed() const { return *windowed_; }
  const NavLoop& full() const { return *full_; }

 private:
  const Rig& rig_;
  InProcessSource windowed_source_, full_source_;
  std::unique_ptr<NavLoop> windowed_ = std::make_unique<NavLoop>(rig_, &windowed_source_, nullptr, nullptr, nullptr);
  std::unique_ptr<NavLoop> full_ = std::make_unique<NavLoop>(rig_, &full_source_, nullptr, nullptr, nullptr);
  bool ok_ = false;
};

// Issue 20 item 1: windowed detection while tracking gives the track of full-frame detection
// on the same frames: the same status and the same pose, bit for bit, in every frame set of a
// 400-step sweep, and the same blobs in every camera (beacons enter and leave the cameras' views
// all along the sweep: each entering beacon is detected, in its window, in the frame set it
// enters). And windows are really used: in nearly every camera frame after the acquisition.
TEST(NavLoop, WindowedDetectionGivesTheFullFrameTrack) {
  const Rig rig = SmallRig();
  SweepRenderer sweep(rig);
  WindowedAndFull loops(rig, Config());
  ASSERT_TRUE(loops.ok());
  const NavLoop& windowed = loops.windowed();
  const NavLoop& full = loops.full();
  const int sets = static_cast<int>(testing::Trials(400, 120));
  int fixes = 0, entries = 0, after_two_poses = 0;  // frame sets whose previous two had a pose
  bool had_pose = false, had_two = false;
  std::array<int, limits::kMaxCameras> in_view_before{};
  PoseRecord a, b;
  for (int n = 0; n < sets; ++n) {
    sweep.Render(n);
    ASSERT_TRUE(loops.Step(sweep, n, &a, &b));
    ASSERT_EQ(a.status, b.status) << "frame set " << n;
    fixes += a.status == NavStatus::kFix ? 1 : 0;
    after_two_poses += had_two ? 1 : 0;
    had_two = had_pose && a.status != NavStatus::kLost;
    had_pose = a.status != NavStatus::kLost;
    if (a.status != NavStatus::kLost) {
      EXPECT_EQ(a.r_w_wb, b.r_w_wb) << "frame set " << n;
      EXPECT_EQ(a.q_w_b.coeffs(), b.q_w_b.coeffs()) << "frame set " << n;
    }
    for (int k = 0; k < rig.num_cameras; ++k) {
      const BlobList& x = windowed.blobs(k);
      const BlobList& y = full.blobs(k);
      ASSERT_EQ(x.count, y.count) << "frame set " << n << " camera " << k;
      for (std::size_t i = 0; i < static_cast<std::size_t>(x.count); ++i)
        EXPECT_EQ(x.blobs[i].uv_px, y.blobs[i].uv_px) << "frame set " << n << " camera " << k;
      entries += y.count > in_view_before[static_cast<std::size_t>(k)] && n > 0 ? 1 : 0;
      in_view_before[static_cast<std::size_t>(k)] = y.count;
    }
  }
  EXPECT_GT(fixes, sets / 2);
  EXPECT_GT(entries, sets / 40);  // beacons entered a camera's view while tracking
  EXPECT_EQ(full.counters().windowed_frames, 0u);
  EXPECT_EQ(windowed.counters().windowed_frames,
            static_cast<std::uint64_t>(rig.num_cameras) * static_cast<std::uint64_t>(after_two_poses));
  EXPECT_EQ(windowed.counters().windowed_fallbacks, 0u);
}

// A flyer turning at 0.97 rad/s (3 deg a frame set at 18.6 Hz) with the paper's 1600 px
// cameras: its beacons move ~84 px a frame set, beyond window_half_px. The windows follow the
// velocity of the last two poses (NavLoop::WindowPose), so the windowed track is the full-frame
// one, frame set by frame set (centred on the last pose alone it lost the beacons and the track).
TEST(NavLoop, WindowsFollowAFastTurn) {
  const Rig rig = PaperRig();
  SweepRenderer sweep(rig);
  NavLoopConfig c = Config();
  c.has_initial_pose = true;  // (the start: the sweep's first pose, as the dock would give it)
  WindowedAndFull loops(rig, c);
  ASSERT_TRUE(loops.ok());
  const int sets = static_cast<int>(testing::Trials(120, 60));
  int posed = 0;
  PoseRecord a, b;
  for (int n = 0; n < sets; ++n) {
    sweep.Render(n, 3.0);
    ASSERT_TRUE(loops.Step(sweep, n, &a, &b));
    ASSERT_EQ(a.status, b.status) << "frame set " << n;
    posed += a.status != NavStatus::kLost ? 1 : 0;
    if (a.status != NavStatus::kLost) {
      EXPECT_EQ(a.r_w_wb, b.r_w_wb) << "frame set " << n;
    }
  }
  EXPECT_GT(posed, sets / 2);
  EXPECT_GT(loops.windowed().counters().windowed_frames, static_cast<std::uint64_t>(sets));
}

// A spot the map does not predict (a reflection) that appears mid-track, away from every
// beacon's window, is in the camera's blob list within detection_stripes frame sets (it lies
// still in the image: NavLoopConfig, detect.h DetectionStripe), and not before the stripe
// reaches it: the windows alone do not see it.
TEST(NavLoop, AnUnpredictedSpotIsFoundWithinTheStripes) {
  const Rig rig = SmallRig();
  SweepRenderer sweep(rig);
  InProcessSource source(rig.num_cameras);
  ASSERT_EQ(source.Start(), SourceStatus::kOk);
  auto loop_ptr = std::make_unique<NavLoop>(rig, &source, nullptr, nullptr, nullptr);
  NavLoop& loop = *loop_ptr;
  NavLoopConfig c = Config();
  c.has_initial_pose = true;  // tracking from the first frame set
  const char* why = nullptr;
  sweep.Render(0);
  c.initial_pose = sweep.pose();
  ASSERT_TRUE(loop.Configure(c, &why)) << why;
  const int n0 = 20;
  int found_at = -1;
  int missed_before = 0;
  PoseRecord rec;
  for (int n = 0; n < n0 + 2 * c.detection_stripes && found_at < 0; ++n) {
    sweep.Render(n);
    // Camera 0, a fixed pixel more than window_half_px from every beacon's image.
    const Eigen::Vector2d spot(40.5, 230.5);
    bool clear = true;
    for (int m = 0; m < rig.num_beacons; ++m) {
      Eigen::Vector2d uv;
      if (ProjectBeacon(rig.cameras[0], sweep.pose(), rig.beacons_w[static_cast<std::size_t>(m)], &uv) ==
          ProjectStatus::kOk)
        clear = clear && (uv - spot).cwiseAbs().maxCoeff() > c.window_half_px + 8;
    }
    ASSERT_TRUE(clear) << "frame set " << n << ": choose another pixel";
    if (n >= n0) sweep.AddReflection(0, spot);
    for (int k = 0; k < rig.num_cameras; ++k)
      ASSERT_TRUE(source.Push(k, sweep.View(k, 1'000'000'000ull + static_cast<std::uint64_t>(n) * kFrameNs,
                                            static_cast<std::uint32_t>(n))));
    ASSERT_EQ(loop.Step(&rec), StepStatus::kOk);
    if (n < n0) continue;
    ASSERT_NE(rec.status, NavStatus::kLost) << "frame set " << n << ": the test needs a track";
    const BlobList& list = loop.blobs(0);
    for (int i = 0; i < list.count; ++i)
      if ((list.blobs[static_cast<std::size_t>(i)].uv_px - spot).norm() < 0.5) found_at = n;
    missed_before += found_at < 0 ? 1 : 0;
  }
  ASSERT_GE(found_at, n0);
  EXPECT_LE(found_at - n0, c.detection_stripes - 1);
  EXPECT_GT(missed_before, 0);  // the windows alone did not find it: the stripe did
  EXPECT_GT(loop.counters().windowed_frames, 0u);
}

// A known start pose gives a fix from the first frame set with >= 3 beacons (without it the
// first ~20 are the acquisition); a parameter reload keeps the track (the last pose seeds the
// new rig's), so the frame sets right after it are fixes too.
TEST(NavLoop, InitialPoseAndReloadKeepTheTrack) {
  const Rig rig = SmallRig();
  SweepRenderer sweep(rig);
  InProcessSource source(rig.num_cameras);
  ASSERT_EQ(source.Start(), SourceStatus::kOk);
  {
    auto cold = std::make_unique<NavLoop>(rig, &source, nullptr, nullptr, nullptr);
    ASSERT_TRUE(cold->Configure(Config(), nullptr));
    const SweepRun r = Drive(cold.get(), &sweep, &source, 0, 10);
    EXPECT_EQ(r.fixes_3plus, 0) << "no prior: frame sets 1-9 are the acquisition";
  }
  NavLoopConfig c = Config();
  c.has_initial_pose = true;
  c.initial_pose.r_w_wb = Eigen::Vector3d(0.004, 0.003, -0.005);  // the dock, known to ~5 mm, 0.5 deg
  c.initial_pose.C_w_b = ExpSO3(Eigen::Vector3d(0.0, 0.005, -0.008));
  auto loop = std::make_unique<NavLoop>(rig, &source, nullptr, nullptr, nullptr);
  const char* why = nullptr;
  ASSERT_TRUE(loop->Configure(c, &why)) << why;
  const SweepRun start = Drive(loop.get(), &sweep, &source, 0, 60);
  EXPECT_GT(start.sets_3plus, 50);
  // (At most one miss, measured: frame set 2, the first with 3 beacons 3 px inside these small
  // images, is refused because the previous frame set shows a blob the pose does not explain,
  // a beacon cut by the border; frame set 3 is a fix. The full-size images fix from the first:
  // navigator_test and the must-show test.)
  EXPECT_GE(start.fixes_3plus, start.sets_3plus - 1);
  EXPECT_EQ(start.wrong, 0);
  // A recalibration: camera x moved by 0.3 mm. The loop keeps the rig by reference.
  Rig recalibrated = rig;
  recalibrated.cameras[0].r_b_bk.x() += 0.0003;
  ASSERT_TRUE(loop->Reload(recalibrated, 2, &why)) << why;
  const SweepRun after = Drive(loop.get(), &sweep, &source, 60, 70);
  EXPECT_GT(after.sets_3plus, 5);
  EXPECT_EQ(after.fixes_3plus, after.sets_3plus);
  EXPECT_EQ(after.wrong, 0);
  NavLoopConfig bad = c;
  bad.initial_sigma_m = -1.0;
  EXPECT_FALSE(loop->Configure(bad, &why));
}

// A parameter reload carries the track's verification (NavLoop::Reload passes
// Navigator::LastVerified to SetInitialPose): a track found on three beacons (cold, the default
// verify_three_beacons) stays unverified across a reload until a pose on four beacons, and a
// verified track stays a fix across the next one.
TEST(NavLoop, AReloadKeepsTheTracksVerification) {
  TrackedSweep s;
  NavLoopConfig c = Config();
  c.navigator.track.verify_three_beacons = true;
  ASSERT_EQ(s.source.Start(), SourceStatus::kOk);
  ASSERT_TRUE(s.loop.Configure(c, nullptr));
  const auto stamp = [](int n) { return 1'000'000'000ull + static_cast<std::uint64_t>(n) * kFrameNs; };
  PoseRecord rec;
  int wrong = 0, n = 0;
  const auto unverified = [&] { return rec.status == NavStatus::kDegraded && rec.reason == NavReason::kUnverified; };
  for (; n < 200 && !unverified(); ++n) s.StepStamped(n, stamp(n), &rec, &wrong);
  ASSERT_TRUE(unverified()) << "no unverified track within 200 frame sets";
  Rig recalibrated = s.rig;  // (the loop keeps the rig by reference)
  recalibrated.cameras[0].r_b_bk.x() += 0.0003;
  const char* why = nullptr;
  ASSERT_TRUE(s.loop.Reload(recalibrated, 2, &why)) << why;
  // Until a pose on four beacons: no fix, and the poses are unverified.
  int after_reload = 0, fixes_on_three = 0;
  for (; n < 400; ++n) {
    s.StepStamped(n, stamp(n), &rec, &wrong);
    if (rec.status != NavStatus::kLost && rec.num_beacons >= 4) break;
    after_reload += unverified() ? 1 : 0;
    fixes_on_three += rec.status == NavStatus::kFix ? 1 : 0;
  }
  EXPECT_GT(after_reload, 0);
  EXPECT_EQ(fixes_on_three, 0);
  ASSERT_EQ(rec.status, NavStatus::kFix) << "the first pose on four beacons verifies the track (frame set " << n << ")";
  // Verified now: on to a frame set on three beacons, reload there, and the track goes on as fixes.
  for (++n; n < 600 && !(rec.status == NavStatus::kFix && rec.num_beacons == 3); ++n)
    s.StepStamped(n, stamp(n), &rec, &wrong);
  ASSERT_EQ(rec.num_beacons, 3);
  Rig again = recalibrated;
  again.cameras[0].r_b_bk.x() -= 0.0003;
  ASSERT_TRUE(s.loop.Reload(again, 3, &why)) << why;
  int posed = 0, fixes = 0;
  for (const int end = n + 10; n < end; ++n) {
    s.StepStamped(n, stamp(n), &rec, &wrong);
    posed += rec.status != NavStatus::kLost ? 1 : 0;
    fixes += rec.status == NavStatus::kFix ? 1 : 0;
  }
  EXPECT_GT(posed, 5);
  EXPECT_EQ(fixes, posed);
  EXPECT_EQ(wrong, 0);
}

// A lost frame set after a fix carries no pose numbers (NaN in the record, the datagram and
// the CSV), so a reader that skips the status cannot take the last pose for a new one.
TEST(NavLoop, ALostFrameSetPublishesNaNNotTheLastPose) {
  const std::string path = ::testing::TempDir() + "nav_loop_lost.csv";
  PoseLog log;
  ASSERT_EQ(log.Open(path.c_str()), PublishStatus::kOk);
  TrackedSweep s(nullptr, nullptr, &log);
  ASSERT_TRUE(s.Start());
  const SweepRun run = Drive(&s.loop, &s.sweep, &s.source, 0, 10);
  ASSERT_GT(run.fixes_3plus, 0);
  // Then every camera sees only background.
  std::vector<std::uint8_t> dark(static_cast<std::size_t>(320 * 256), 10);
  for (int k = 0; k < s.rig.num_cameras; ++k) {
    FrameView v = s.sweep.View(k, 1'000'000'000ull + 10 * kFrameNs, 10);
    v.data = dark.data();
    ASSERT_TRUE(s.source.Push(k, v));
  }
  PoseRecord rec;
  ASSERT_EQ(s.loop.Step(&rec), StepStatus::kOk);
  EXPECT_EQ(rec.status, NavStatus::kLost);
  EXPECT_TRUE(rec.r_w_wb.array().isNaN().all());
  EXPECT_TRUE(rec.q_w_b.coeffs().array().isNaN().all());
  EXPECT_TRUE(rec.euler_deg.array().isNaN().all());
  EXPECT_TRUE(rec.covariance.array().isNaN().all());
  ASSERT_EQ(log.Close(), PublishStatus::kOk);
  std::FILE* f = std::fopen(path.c_str(), "r");
  ASSERT_NE(f, nullptr);
  char line[256];
  std::string last;
  while (std::fgets(line, sizeof(line), f) != nullptr) last = line;
  std::fclose(f);
  std::remove(path.c_str());
  EXPECT_NE(last.find(",lost,nan,nan,nan,nan,nan,nan,"), std::string::npos) << last;
}

// Issue 14 defect 8: a frame set stamped no later than the previous one (a repeated or a
// backward driver timestamp) lost the track for 23 frame sets. Now it is counted (health), its
// pose degraded with reason "clock fault" and stamped one period on, and the track goes on; a
// clock that went back for good (three faults in a row) is taken as it is, the track seeded
// again from the last pose.
TEST(NavLoop, ARepeatedOrBackwardTimestampKeepsTheTrack) {
  TrackedSweep s;
  ASSERT_TRUE(s.Start());
  // Frame set n's stamp: n periods on, except a repeat (20), one step back (30), and from 40
  // on a clock 10 s behind.
  const auto stamp = [](int n) -> std::uint64_t {
    const std::uint64_t t = 20'000'000'000ull + static_cast<std::uint64_t>(n) * kFrameNs;
    if (n == 20) return t - kFrameNs;
    if (n == 30) return t - 5 * kFrameNs;
    return n >= 40 ? t - 10'000'000'000ull : t;
  };
  PoseRecord rec;
  int wrong = 0, sets_3plus = 0, posed_3plus = 0;
  std::uint64_t last_t = 0;
  for (int n = 0; n < 70; ++n) {
    const int visible = s.StepStamped(n, stamp(n), &rec, &wrong);
    if (n == 20 || n == 30 || n == 40 || n == 41) {
      EXPECT_EQ(rec.reason, NavReason::kClockFault) << n;
      EXPECT_NE(rec.status, NavStatus::kFix) << n;
      EXPECT_EQ(rec.t_capture_ns, last_t + static_cast<std::uint64_t>(Config().deadline_ms * 1e6))
          << n << ": one period after the last";
    }
    if (n != 42 && visible >= 3 && n >= 3) {  // (42: the track seeded again, see below)
      ++sets_3plus;
      posed_3plus += rec.status != NavStatus::kLost;
    }
    last_t = rec.t_capture_ns;
  }
  EXPECT_EQ(s.loop.counters().clock_faults, 5u);  // 20, 30, 40, 41, 42
  EXPECT_EQ(s.loop.Health().clock_faults, 5u);
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(posed_3plus, sets_3plus) << "the track is kept through every clock fault";
}

// Found by the soak (docs/reliability.md): after a repeated stamp the driver clock stays one
// period behind (every later stamp one period early). CheckClock kept those frame sets 1 ns
// after its estimate, so the navigator saw no motion across one frame set and lost the track
// (22 of 56 frame sets here before the fix). Now the first good stamp after the fault is
// compared with the frame sets since the last good one and the missing period is carried as
// a clock offset: only the repeat is a clock fault, every later frame set is a fix stamped one
// period after the last.
//
// silent_after: frame set 21, right after the repeat, delivers no frame at all (every camera
// times out); its time passed all the same, so the periods are counted by frame-set index.
void ClockOnePeriodBehind(bool silent_after) {
  TrackedSweep s;
  ASSERT_TRUE(s.Start());
  const auto stamp = [](int n) -> std::uint64_t {
    const int periods = n >= 20 ? n - 1 : n;  // 20 repeats 19's stamp, the clock stays behind
    return 20'000'000'000ull + static_cast<std::uint64_t>(periods) * kFrameNs;
  };
  PoseRecord rec;
  int wrong = 0, sets_3plus = 0, fixes_3plus = 0;
  std::uint64_t last_t = 0;
  for (int n = 0; n < 60; ++n) {
    const bool silent = silent_after && n == 21;
    int visible = 0;
    if (silent) {
      for (int k = 0; k < s.rig.num_cameras; ++k) s.source.PushStatus(k, SourceStatus::kTimeout);
      ASSERT_EQ(s.loop.Step(&rec), StepStatus::kOk);
    } else {
      visible = s.StepStamped(n, stamp(n), &rec, &wrong);
    }
    if (n > 20 && !silent && !(silent_after && n == 22)) {
      const double dt_ms = static_cast<double>(rec.t_capture_ns - last_t) * 1e-6;
      EXPECT_NEAR(dt_ms, kFrameNs * 1e-6, 0.1) << n << ": one period after the last frame set";
    }
    if (n >= 3 && n != 20 && visible >= 3) {  // (20: the repeat itself, degraded)
      ++sets_3plus;
      fixes_3plus += rec.status == NavStatus::kFix;
    }
    if (!silent) last_t = rec.t_capture_ns;
  }
  EXPECT_EQ(s.loop.counters().clock_faults, 1u);
  EXPECT_EQ(s.loop.counters().clock_offsets, 1u);
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(fixes_3plus, sets_3plus) << "the track is kept: a fix in every frame set with >= 3 beacons";
}

// Issue 14: a clock that steps forward moved no counter (mfns-sim faults, time-forward). A
// stamp 1 s ahead of the frame sets since, with no frame lost, is a stamp jump, reported in the
// health message's clock_faults; the same gap with the frames counted dropped (a sequence gap)
// is real time and no fault. Never a wrong pose either way.
void StampJumpsAhead(bool frames_dropped) {
  TrackedSweep s;
  ASSERT_TRUE(s.Start());
  constexpr int kJumpAt = 30;
  constexpr std::uint64_t kJumpNs = 1'000'000'000ull;
  const int skipped = static_cast<int>(kJumpNs / kFrameNs);  // frames a real 1 s gap drops
  PoseRecord rec;
  int wrong = 0;
  for (int n = 0; n < 50; ++n) {
    const std::uint64_t t = 20'000'000'000ull + static_cast<std::uint64_t>(n) * kFrameNs + (n >= kJumpAt ? kJumpNs : 0);
    const int sequence = frames_dropped && n >= kJumpAt ? n + skipped : n;
    s.StepStamped(n, t, &rec, &wrong, sequence);
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(s.loop.counters().clock_faults, 0u);
  EXPECT_EQ(s.loop.counters().stamp_jumps, frames_dropped ? 0u : 1u);
  EXPECT_EQ(s.loop.Health().clock_faults, frames_dropped ? 0u : 1u);
  std::uint64_t drops = 0;
  for (int k = 0; k < s.rig.num_cameras; ++k) drops += s.source.counters(k).drops;
  EXPECT_EQ(drops, frames_dropped ? static_cast<std::uint64_t>(skipped * s.rig.num_cameras) : 0u);
}

// Issue 14: one camera delivering an old frame (stamped as the previous frame set) made the
// whole frame set a clock fault (its stamp was the minimum over the cameras). Now that camera's
// frame is dropped for the frame set (stale_frames, in its health bad_frames), the others are
// tracked at their own time; only when every camera is stale is it the clock's fault.
TEST(NavLoop, OneCamerasStaleFrameIsDroppedNotAClockFault) {
  TrackedSweep s;
  ASSERT_TRUE(s.Start());
  constexpr int kAllStaleAt = 60;
  const auto stamp = [](int n) { return 20'000'000'000ull + static_cast<std::uint64_t>(n) * kFrameNs; };
  PoseRecord rec;
  int wrong = 0, stale_camera = -1, stale_at = -1;
  for (int n = 0; n < 75; ++n) {
    s.sweep.Render(n);
    for (int k = 0; k < s.rig.num_cameras; ++k) {
      const bool stale = (n == stale_at && k == stale_camera) || n == kAllStaleAt;
      ASSERT_TRUE(s.source.Push(k, s.sweep.View(k, stale ? stamp(n - 1) : stamp(n), static_cast<std::uint32_t>(n))));
    }
    ASSERT_EQ(s.loop.Step(&rec), StepStatus::kOk);
    wrong += rec.status != NavStatus::kLost && !FixIsRight(rec, s.sweep.pose());
    if (n >= 10 && stale_at < 0 && rec.status == NavStatus::kFix) {
      // The stale camera: one that sees a beacon while the others see three more (the sweep
      // turns slowly: the same beacons at the next frame set).
      for (int k = 0; k < s.rig.num_cameras && stale_camera < 0; ++k) {
        const int own = rec.beacons_per_camera[static_cast<std::size_t>(k)];
        if (own > 0 && rec.num_beacons - own >= 3) stale_camera = k;
      }
      if (stale_camera >= 0) stale_at = n + 1;
    }
    if (n == stale_at) {
      EXPECT_EQ(rec.t_capture_ns, stamp(n)) << "the fresh cameras' time";
      EXPECT_NE(rec.reason, NavReason::kClockFault);
      EXPECT_NE(rec.status, NavStatus::kLost) << ToString(rec.reason);
      EXPECT_EQ(rec.beacons_per_camera[static_cast<std::size_t>(stale_camera)], 0) << "its blobs are not used";
    }
    if (n == kAllStaleAt) {
      EXPECT_EQ(rec.reason, NavReason::kClockFault);
    }
  }
  ASSERT_GE(stale_at, 0) << "the sweep never had such a frame set";
  ASSERT_LT(stale_at, kAllStaleAt);
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(s.loop.counters().clock_faults, 1u) << "only the frame set every camera repeated";
  for (int k = 0; k < s.rig.num_cameras; ++k) {
    EXPECT_EQ(s.loop.supervision(k).stale_frames, k == stale_camera ? 1u : 0u) << k;
    EXPECT_EQ(s.loop.Health().cameras[static_cast<std::size_t>(k)].bad_frames, k == stale_camera ? 1u : 0u) << k;
  }
}

TEST(NavLoop, AStampThatJumpsAheadWithNoFrameLostIsCounted) { StampJumpsAhead(false); }
TEST(NavLoop, AStampGapWithFramesDroppedIsNoFault) { StampJumpsAhead(true); }

TEST(NavLoop, AClockThatStaysOnePeriodBehindAfterARepeatKeepsTheTrack) {
  ClockOnePeriodBehind(false);
  ClockOnePeriodBehind(true);
}

// A 60-frame-set sweep from the start pose in which camera 0's frame of frame set n is replaced
// where corrupt(n, &pixels) returns true (pixels: a copy of the rendered frame, to change). Counts
// wrong poses, and frame sets with >= 3 beacons in view (truth) and those of them with a pose,
// apart for the corrupted ones and the others from frame set 3 on.
struct CorruptSweep {
  int wrong = 0;
  int sets_3plus = 0, posed_3plus = 0;  // frame sets not corrupted
  int corrupt_3plus = 0, corrupt_posed = 0;
};
CorruptSweep SweepCorruptingCameraZero(TrackedSweep* s, const std::function<bool(int, std::vector<std::uint8_t>*)>& corrupt) {
  CorruptSweep out;
  PoseRecord rec;
  std::vector<std::uint8_t> pixels;
  for (int n = 0; n < 60; ++n) {
    const int visible = s->sweep.Render(n);
    bool corrupted = false;
    for (int k = 0; k < s->rig.num_cameras; ++k) {
      FrameView v = s->sweep.View(k, 1'000'000'000ull + static_cast<std::uint64_t>(n) * kFrameNs, static_cast<std::uint32_t>(n));
      if (k == 0) {
        pixels.assign(v.data, v.data + static_cast<std::size_t>(v.stride_bytes) * static_cast<std::size_t>(v.height));
        corrupted = corrupt(n, &pixels);
        if (corrupted) v.data = pixels.data();
      }
      EXPECT_TRUE(s->source.Push(k, v));
    }
    EXPECT_EQ(s->loop.Step(&rec), StepStatus::kOk);
    out.wrong += rec.status != NavStatus::kLost && !FixIsRight(rec, s->sweep.pose());
    if (n < 3 || visible < 3) continue;
    (corrupted ? out.corrupt_3plus : out.sets_3plus) += 1;
    (corrupted ? out.corrupt_posed : out.posed_3plus) += rec.status != NavStatus::kLost;
  }
  return out;
}

// Issue 14 defect 8: one all-zero or all-white frame from one camera lost the track for ~1.2 s
// (its missing beacons refuted the right pose). A blank frame counts as the camera's silence
// (health: bad_frames), so the others keep the track. (In frame sets 20 and 30 the other cameras
// may see fewer than 3 beacons.)
TEST(NavLoop, ABlankFrameFromOneCameraKeepsTheTrack) {
  TrackedSweep s;
  ASSERT_TRUE(s.Start());
  const CorruptSweep r = SweepCorruptingCameraZero(&s, [](int n, std::vector<std::uint8_t>* pixels) {
    if (n == 20 || n == 30) std::fill(pixels->begin(), pixels->end(), n == 20 ? 0 : 255);
    return n == 20 || n == 30;
  });
  EXPECT_EQ(s.loop.Health().cameras[0].bad_frames, 2u);
  EXPECT_EQ(s.loop.Health().cameras[1].bad_frames, 0u);
  EXPECT_EQ(r.wrong, 0);
  EXPECT_EQ(r.posed_3plus, r.sets_3plus);
}

// Issue 14: a frame whose lower rows were never written (here the lower half zero, three frame
// sets) reached health as nothing; it is a bad frame of its camera now (supervision:
// truncated_frames), its upper half's blobs used, and no wrong pose.
TEST(NavLoop, ATruncatedFrameIsABadFrameInHealth) {
  TrackedSweep s;
  ASSERT_TRUE(s.Start());
  const CorruptSweep r = SweepCorruptingCameraZero(&s, [](int n, std::vector<std::uint8_t>* pixels) {
    if (n < 20 || n > 22) return false;
    std::fill(pixels->begin() + static_cast<std::ptrdiff_t>(pixels->size() / 2), pixels->end(), 0);
    return true;
  });
  EXPECT_EQ(s.loop.supervision(0).truncated_frames, 3u);
  EXPECT_EQ(s.loop.Health().cameras[0].bad_frames, 3u);
  EXPECT_EQ(s.loop.Health().cameras[1].bad_frames, 0u);
  EXPECT_EQ(s.loop.Health().cameras[0].detect_errors, 0u);
  EXPECT_EQ(r.wrong, 0);
}

// Issue 14: a camera half saturated (a lamp, the sun in a window: the left half of camera 0's
// image at 255 for frame sets 20-39) refuted the track: the beacon its saturated half hides was
// found missing. The detector reports that half blind and the tracking matcher does not miss it
// there: frame sets 20 and 21 (3 beacons left outside the glare) keep the fix, and the fix is back
// at frame set 40, as the glare ends (before: posed in 0 of the 20, lost until frame set 43,
// 34 of the 37 others posed). In 22-39 two beacons are left: too few.
TEST(NavLoop, AHalfSaturatedCameraKeepsTheTrack) {
  TrackedSweep s;
  ASSERT_TRUE(s.Start());
  const CorruptSweep r = SweepCorruptingCameraZero(&s, [](int n, std::vector<std::uint8_t>* pixels) {
    if (n < 20 || n >= 40) return false;
    for (std::size_t y = 0; y < 256; ++y) std::fill_n(pixels->begin() + static_cast<std::ptrdiff_t>(y * 320), 160, 255);
    return true;
  });
  EXPECT_EQ(s.loop.supervision(0).saturated_frames, 20u);
  EXPECT_EQ(s.loop.Health().cameras[0].bad_frames, 0u);  // the scene, not a bad frame
  EXPECT_EQ(r.wrong, 0);
  EXPECT_EQ(r.corrupt_posed, 2);
  EXPECT_EQ(r.posed_3plus, r.sets_3plus);
}

TEST(NavLoop, EndOfStreamAndNoFrames) {
  const Rig rig = SmallRig();
  InProcessSource source(rig.num_cameras);
  ASSERT_EQ(source.Start(), SourceStatus::kOk);
  NavLoop loop(rig, &source, nullptr, nullptr, nullptr);
  ASSERT_TRUE(loop.Configure(Config(), nullptr));
  for (int k = 0; k < rig.num_cameras; ++k) source.PushStatus(k, SourceStatus::kTimeout);
  PoseRecord rec;
  ASSERT_EQ(loop.Step(&rec), StepStatus::kOk);
  EXPECT_EQ(rec.status, NavStatus::kLost);
  EXPECT_EQ(rec.reason, NavReason::kNoFrames);
  source.Close();
  EXPECT_EQ(loop.Step(&rec), StepStatus::kEndOfStream);
  // A configuration that does not fit is refused with a reason.
  NavLoopConfig bad = Config();
  bad.deadline_ms = 0;
  const char* why = nullptr;
  EXPECT_FALSE(loop.Configure(bad, &why));
  EXPECT_NE(why, nullptr);
}

}  // namespace
}  // namespace mfns::fw
