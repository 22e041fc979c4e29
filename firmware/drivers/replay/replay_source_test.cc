// Replay through real files in a temporary directory: pixels and timestamps against what the
// test wrote, and every broken or missing file as a typed status and counter.
#include "firmware/drivers/replay/replay_source.h"

#include <gtest/gtest.h>
#include <time.h>
#include <sys/stat.h>

#include <string>
#include <vector>

#include "common/rig/paper_rig.h"
#include "firmware/drivers/replay/test_files.h"
#include "firmware/lib/testing/alloc_counter.h"
#include "firmware/lib/testing/print_status.h"
#include "firmware/lib/testing/returns_without_blocking.h"

namespace mfns::fw {
namespace {

using testing::FramePath;
using testing::Pgm;
using testing::TestPixel;
using testing::WriteFile;

constexpr int kW = 12;
constexpr int kH = 9;
const char* const kNames[] = {"x", "y", "z"};

// Seed of camera k's frame f, so every image differs.
int Seed(int k, int f) { return 100 * k + f; }

class ReplayTest : public ::testing::Test {
 protected:
  // Frames 0..n-1 for every camera, plus truth.csv unless told otherwise.
  void WriteSequence(int n, bool mono16 = false, bool truth = true) {
    for (int k = 0; k < 3; ++k) {
      for (int f = 0; f < n; ++f) {
        WriteFile(FramePath(dir_.path(), kNames[k], f), Pgm(kW, kH, Seed(k, f), mono16));
      }
    }
    if (truth) {
      std::string csv = "frame,t_ns,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n";
      for (int f = 0; f < n; ++f) csv += std::to_string(f) + "," + std::to_string(TruthNs(f)) + ",0,0,0,0,0,0\n";
      WriteFile(dir_.path() + "/truth.csv", csv);
    }
  }
  static std::uint64_t TruthNs(int f) { return 5000000000ULL + 33333333ULL * static_cast<unsigned>(f) + 7; }

  ReplayConfig Config(double rate_hz = 0.0) const {
    ReplayConfig c;
    c.dir = dir_.path().c_str();
    c.num_cameras = 3;
    for (int k = 0; k < 3; ++k) c.camera_names[static_cast<unsigned>(k)] = kNames[k];
    c.frame_rate_hz = rate_hz;
    return c;
  }

  // Pixels of view against the image the test wrote.
  static int WrongPixels(const FrameView& v, int seed) {
    int wrong = 0;
    const bool mono16 = v.format == PixelFormat::kMono16;
    for (int y = 0; y < v.height; ++y) {
      for (int x = 0; x < v.width; ++x) wrong += v.At(x, y) != TestPixel(seed, x, y, mono16);
    }
    return wrong;
  }

  testing::TempDir dir_;
};

TEST_F(ReplayTest, ReplaysEveryCameraWithTruthTimestampsThenEnds) {
  WriteSequence(4);
  ReplaySource src(Config());
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  EXPECT_EQ(src.num_frames(), 4);
  EXPECT_TRUE(src.timestamps_from_truth());
  for (int f = 0; f < 4; ++f) {
    for (int k = 0; k < 3; ++k) {
      FrameView v;
      ASSERT_EQ(src.Acquire(k, 50, &v), SourceStatus::kOk) << k << " " << f;
      EXPECT_EQ(v.width, kW);
      EXPECT_EQ(v.height, kH);
      EXPECT_EQ(v.stride_bytes, kW);
      EXPECT_EQ(v.format, PixelFormat::kMono8);
      EXPECT_EQ(v.camera, k);
      EXPECT_EQ(v.sequence, static_cast<std::uint32_t>(f));
      EXPECT_EQ(v.t_capture_ns, TruthNs(f));
      EXPECT_EQ(v.t_source, TimestampSource::kTruth);
      EXPECT_EQ(WrongPixels(v, Seed(k, f)), 0);
      src.Release(k);
    }
  }
  FrameView v;
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(src.Acquire(k, 50, &v), SourceStatus::kEndOfStream);
    EXPECT_EQ(src.counters(k).frames, 4U);
  }
}

TEST_F(ReplayTest, Mono16FramesAreLittleEndianInMemory) {
  WriteSequence(2, /*mono16=*/true);
  ReplaySource src(Config());
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  ASSERT_EQ(src.Acquire(1, 50, &v), SourceStatus::kOk);
  EXPECT_EQ(v.format, PixelFormat::kMono16);
  EXPECT_EQ(v.stride_bytes, 2 * kW);
  EXPECT_EQ(WrongPixels(v, Seed(1, 0)), 0);
  src.Release(1);
}

TEST_F(ReplayTest, TimestampsFromTheRateWithoutTruth) {
  WriteSequence(3, false, /*truth=*/false);
  ReplaySource no_rate(Config());
  EXPECT_EQ(no_rate.Start(), SourceStatus::kBadConfig);
  ReplaySource src(Config(/*rate_hz=*/30.0));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  EXPECT_FALSE(src.timestamps_from_truth());
  for (int f = 0; f < 3; ++f) {
    FrameView v;
    ASSERT_EQ(src.Acquire(0, 50, &v), SourceStatus::kOk);
    // round(f * 1e9 / 30) in integer arithmetic: (2 f 1e9 + 30) / 60.
    const std::uint64_t expected = (2 * static_cast<std::uint64_t>(f) * 1000000000 + 30) / 60;
    EXPECT_EQ(v.t_capture_ns, expected);
    src.Release(0);
  }
}

// --realtime: frame f of every camera is delivered no earlier than f periods after frame 0
// (a lower bound only: a loaded machine may be later, never earlier).
TEST_F(ReplayTest, RealtimeDeliversEachFrameSetAtItsRecordedTime) {
  WriteSequence(4, false, /*truth=*/false);
  ReplayConfig c = Config(/*rate_hz=*/25.0);  // 40 ms apart
  c.realtime = true;
  ReplaySource src(c);
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  const auto now_ns = [] {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
  };
  std::int64_t t0 = 0;
  for (int f = 0; f < 4; ++f)
    for (int k = 0; k < 3; ++k) {
      FrameView v;
      ASSERT_EQ(src.Acquire(k, 50, &v), SourceStatus::kOk);
      if (f == 0 && k == 0) t0 = now_ns();
      EXPECT_GE(now_ns() - t0, f * 40000000 - 1000000) << "frame " << f << " camera " << k << " early";
      src.Release(k);
    }
}

TEST_F(ReplayTest, AMissingFrameOfOneCameraDoesNotStopTheOthers) {
  WriteSequence(4);
  std::filesystem::remove(FramePath(dir_.path(), "y", 2));
  ReplaySource src(Config());
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  for (int f = 0; f < 4; ++f) {
    for (int k = 0; k < 3; ++k) {
      FrameView v;
      const SourceStatus s = src.Acquire(k, 50, &v);
      if (k == 1 && f == 2) {
        EXPECT_EQ(s, SourceStatus::kMissingFrame);
      } else {
        ASSERT_EQ(s, SourceStatus::kOk) << k << " " << f;
        EXPECT_EQ(v.sequence, static_cast<std::uint32_t>(f));  // y stays in step after the gap
        EXPECT_EQ(WrongPixels(v, Seed(k, f)), 0);
      }
      src.Release(k);
    }
  }
  EXPECT_EQ(src.counters(1).missing_files, 1U);
  EXPECT_EQ(src.counters(1).frames, 3U);
  EXPECT_EQ(src.counters(0).missing_files, 0U);
  EXPECT_EQ(src.counters(0).frames, 4U);
}

TEST_F(ReplayTest, TheLongestCameraSetsTheSequenceLength) {
  WriteSequence(2);
  WriteFile(FramePath(dir_.path(), "z", 4), Pgm(kW, kH, 1));  // z has frame 4 too
  ReplaySource src(Config(10.0));  // truth.csv lacks frames 2..4
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  EXPECT_EQ(src.num_frames(), 5);
  FrameView v;
  for (int f = 0; f < 2; ++f) {
    ASSERT_EQ(src.Acquire(0, 50, &v), SourceStatus::kOk);
    src.Release(0);
  }
  EXPECT_EQ(src.Acquire(0, 50, &v), SourceStatus::kMissingFrame);  // frames 2, 3, 4 of x
  EXPECT_EQ(src.Acquire(0, 50, &v), SourceStatus::kMissingFrame);
  EXPECT_EQ(src.Acquire(0, 50, &v), SourceStatus::kMissingFrame);
  EXPECT_EQ(src.Acquire(0, 50, &v), SourceStatus::kEndOfStream);
  // z's frame 4 has an image but no truth row: cannot be timed.
  for (int f = 0; f < 4; ++f) {
    src.Acquire(2, 50, &v);
    src.Release(2);
  }
  EXPECT_EQ(src.Acquire(2, 50, &v), SourceStatus::kDropped);
  EXPECT_EQ(src.counters(2).unknown_clock, 1U);
}

TEST_F(ReplayTest, MalformedFilesAreBadFramesAndTheLoopGoesOn) {
  WriteSequence(7);
  std::string truncated = Pgm(kW, kH, 0);
  truncated.resize(truncated.size() - 5);
  WriteFile(FramePath(dir_.path(), "x", 1), truncated);
  WriteFile(FramePath(dir_.path(), "x", 2), "P2\n12 9\n255\n" + std::string(kW * kH, '1'));
  WriteFile(FramePath(dir_.path(), "x", 3), "P5\n100000 100000\n255\n" + std::string(kW * kH, 'a'));
  WriteFile(FramePath(dir_.path(), "x", 4), "P5\n12 9\n1023\n" + std::string(2 * kW * kH, 'a'));
  WriteFile(FramePath(dir_.path(), "x", 5), Pgm(kW + 1, kH, 5));  // the size changed
  WriteFile(FramePath(dir_.path(), "x", 6),                       // comments are fine
            Pgm(kW, kH, Seed(0, 6), false, "P5\n# made by a test\n12 # w\n9\n# maxval next\n255\n"));
  ReplaySource src(Config());
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  const SourceStatus expected[] = {SourceStatus::kOk,       SourceStatus::kBadFrame,
                                   SourceStatus::kBadFrame, SourceStatus::kBadFrame,
                                   SourceStatus::kBadFrame, SourceStatus::kBadFrame,
                                   SourceStatus::kOk};
  for (int f = 0; f < 7; ++f) {
    FrameView v;
    EXPECT_EQ(src.Acquire(0, 50, &v), expected[f]) << f;
    if (expected[f] == SourceStatus::kOk) {
      EXPECT_EQ(WrongPixels(v, Seed(0, f)), 0);
    }
    src.Release(0);
    ASSERT_EQ(src.Acquire(1, 50, &v), SourceStatus::kOk);  // y unaffected
    src.Release(1);
  }
  EXPECT_EQ(src.counters(0).bad_files, 5U);
  EXPECT_EQ(src.counters(0).frames, 2U);
}

TEST_F(ReplayTest, BadTruthCsvIsABadConfig) {
  WriteSequence(2, false, /*truth=*/false);
  const std::string truth = dir_.path() + "/truth.csv";
  const std::string bad[] = {
      "frame,time\n0,1\n1,2\n",          // no t_ns column
      "t_ns,x\n1,2\n",                    // no frame column
      "frame,t_ns\n0,12abc\n1,2\n",       // not a number
      "frame,t_ns\n0,-5\n1,2\n",          // negative
      "frame,t_ns\n0,1\n0,2\n",           // frame 0 twice
      "frame,t_ns\n0\n",                  // missing field
      "frame,t_ns\n0,99999999999999999999999\n",  // overflows 64 bits
      "",                                 // empty
  };
  for (const std::string& text : bad) {
    WriteFile(truth, text);
    ReplaySource src(Config(30.0));  // a rate does not rescue a broken truth.csv
    EXPECT_EQ(src.Start(), SourceStatus::kBadConfig) << text;
  }
  // Columns in another order, CRLF line ends, a blank line: fine.
  WriteFile(truth, "x_mm,t_ns,frame\r\n0,777,1\r\n\r\n0,555,0\r\n");
  ReplaySource src(Config());
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  ASSERT_EQ(src.Acquire(0, 50, &v), SourceStatus::kOk);
  EXPECT_EQ(v.t_capture_ns, 555U);
  src.Release(0);
  ASSERT_EQ(src.Acquire(0, 50, &v), SourceStatus::kOk);
  EXPECT_EQ(v.t_capture_ns, 777U);
  src.Release(0);
}

TEST_F(ReplayTest, StartFailuresAreTyped) {
  {
    ReplaySource src(Config(30.0));  // nothing written yet: no camera folders
    EXPECT_EQ(src.Start(), SourceStatus::kOpenFailed);
  }
  WriteSequence(2);
  {
    std::filesystem::create_directories(dir_.path() + "/frames/w");
    ReplayConfig c = Config();
    c.camera_names[2] = "w";  // a folder with no frames
    EXPECT_EQ(ReplaySource(c).Start(), SourceStatus::kOpenFailed);
  }
  {
    ReplayConfig c = Config();
    c.camera_names[1] = "../x";
    EXPECT_EQ(ReplaySource(c).Start(), SourceStatus::kBadConfig);
    c.camera_names[1] = nullptr;
    EXPECT_EQ(ReplaySource(c).Start(), SourceStatus::kBadConfig);
    c = Config();
    c.num_cameras = 0;
    EXPECT_EQ(ReplaySource(c).Start(), SourceStatus::kBadConfig);
    c = Config();
    c.dir = nullptr;
    EXPECT_EQ(ReplaySource(c).Start(), SourceStatus::kBadConfig);
    const std::string long_dir(limits::kMaxPathChars, 'd');
    c.dir = long_dir.c_str();
    EXPECT_EQ(ReplaySource(c).Start(), SourceStatus::kBadConfig);
  }
  {
    ReplayConfig c = Config();
    c.width[0] = kW + 1;  // the rig says another size
    EXPECT_EQ(ReplaySource(c).Start(), SourceStatus::kFormatRefused);
  }
  {
    WriteFile(FramePath(dir_.path(), "z", 0), "garbage");
    EXPECT_EQ(ReplaySource(Config()).Start(), SourceStatus::kBadFrame);  // cannot size z
  }
}

// Issue 14, defect 10: a start that fails says which folder or file and why (navd printed a
// bare "open failed" or "bad configuration").
TEST_F(ReplayTest, StartFailuresNameTheFolderOrFile) {
  const std::string d = dir_.path();
  {
    ReplaySource src(Config(30.0));  // no camera folders
    EXPECT_EQ(src.Start(), SourceStatus::kOpenFailed);
    EXPECT_STREQ(src.problem(), (d + "/frames/x: No such file or directory").c_str());
  }
  WriteSequence(2, false, /*truth=*/false);
  {
    std::filesystem::create_directories(d + "/frames/w");
    ReplayConfig c = Config(30.0);
    c.camera_names[2] = "w";
    ReplaySource src(c);
    EXPECT_EQ(src.Start(), SourceStatus::kOpenFailed);
    EXPECT_STREQ(src.problem(), (d + "/frames/w: no frames (NNNNNN.pgm) in this camera's folder").c_str());
  }
  {
    ReplaySource src(Config(0.0));  // no truth.csv, no rate
    EXPECT_EQ(src.Start(), SourceStatus::kBadConfig);
    EXPECT_STREQ(src.problem(), (d + "/truth.csv: missing, and no frame rate to time the frames by").c_str());
  }
  {
    WriteFile(d + "/truth.csv", "frame,time\n0,1\n");
    ReplaySource src(Config(30.0));
    EXPECT_EQ(src.Start(), SourceStatus::kBadConfig);
    EXPECT_STREQ(src.problem(), (d + "/truth.csv: the header has no frame or no t_ns column").c_str());
  }
  {
    WriteFile(d + "/truth.csv", "frame,t_ns\n0,1\n1,2\n");
    ReplayConfig c = Config();
    c.width[0] = kW + 1;
    ReplaySource src(c);
    EXPECT_EQ(src.Start(), SourceStatus::kFormatRefused);
    EXPECT_NE(std::string(src.problem()).find("/frames/x/000000.pgm: 12x9, the rig's camera is 13x0"), std::string::npos)
        << src.problem();
  }
}

TEST_F(ReplayTest, FirstFrameMaySitLaterInTheSequence) {
  WriteSequence(3);
  std::filesystem::remove(FramePath(dir_.path(), "z", 0));
  ReplaySource src(Config());
  ASSERT_EQ(src.Start(), SourceStatus::kOk);  // z's buffer sized from its frame 1
  FrameView v;
  EXPECT_EQ(src.Acquire(2, 50, &v), SourceStatus::kMissingFrame);
  ASSERT_EQ(src.Acquire(2, 50, &v), SourceStatus::kOk);
  EXPECT_EQ(v.sequence, 1U);
  src.Release(2);
}

TEST_F(ReplayTest, MisuseIsTyped) {
  WriteSequence(2);
  ReplaySource src(Config());
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 50, &v), SourceStatus::kNotStarted);
  EXPECT_EQ(src.Reset(0), SourceStatus::kNotStarted);
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  EXPECT_EQ(src.Acquire(3, 50, &v), SourceStatus::kBadCamera);
  ASSERT_EQ(src.Acquire(0, 50, &v), SourceStatus::kOk);
  FrameView w;
  EXPECT_EQ(src.Acquire(0, 50, &w), SourceStatus::kBusy);
  EXPECT_EQ(src.Reset(0), SourceStatus::kOk);  // lets go of the held frame
  ASSERT_EQ(src.Acquire(0, 50, &w), SourceStatus::kOk);
  EXPECT_EQ(w.sequence, 1U);
  src.Stop();
  EXPECT_EQ(src.Acquire(0, 50, &v), SourceStatus::kNotStarted);
  ASSERT_EQ(src.Start(), SourceStatus::kOk);  // restart from frame 0
  ASSERT_EQ(src.Acquire(0, 50, &v), SourceStatus::kOk);
  EXPECT_EQ(v.sequence, 0U);
}

TEST_F(ReplayTest, ConfigFromThePaperRigUsesItsCameraNamesAndSizes) {
  const Rig rig = PaperRig();
  const ReplayConfig c = ReplayConfigFromRig(rig, "/data/run", 15.0);
  EXPECT_STREQ(c.dir, "/data/run");
  EXPECT_EQ(c.num_cameras, rig.num_cameras);
  EXPECT_EQ(c.frame_rate_hz, 15.0);
  for (int k = 0; k < rig.num_cameras; ++k) {
    EXPECT_STREQ(c.camera_names[static_cast<unsigned>(k)], rig.cameras[static_cast<unsigned>(k)].name.data());
    EXPECT_EQ(c.width[static_cast<unsigned>(k)], rig.cameras[static_cast<unsigned>(k)].intrinsics.width);
    EXPECT_EQ(c.height[static_cast<unsigned>(k)], rig.cameras[static_cast<unsigned>(k)].intrinsics.height);
  }
}

TEST_F(ReplayTest, NoHeapAfterStart) {
  constexpr int kFrames = 300;
  WriteSequence(kFrames);
  std::filesystem::remove(FramePath(dir_.path(), "x", 17));
  WriteFile(FramePath(dir_.path(), "y", 30), "P5\n1 1\n7\n");
  ReplaySource src(Config());
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  int ok = 0;
  int other = 0;
  const std::uint64_t before = testing::AllocationCount();
  for (int f = 0; f < kFrames + 1; ++f) {
    for (int k = 0; k < 3; ++k) {
      FrameView v;
      const SourceStatus s = src.Acquire(k, 50, &v);
      if (s == SourceStatus::kOk) ++ok;
      if (s != SourceStatus::kOk && s != SourceStatus::kEndOfStream) ++other;
      src.Release(k);
    }
  }
  EXPECT_EQ(testing::AllocationCount(), before);
  EXPECT_EQ(ok, 3 * kFrames - 2);
  EXPECT_EQ(other, 2);
}

// Issue 14: a FIFO named like a frame (or like truth.csv) hung the replay in open(2): navd's
// start, or its frame loop mid-flight. Now a FIFO frame is a bad frame at once and the loop
// goes on; at Start it is refused at once.
TEST_F(ReplayTest, AFifoNamedLikeAFrameOrTheTruthNeverBlocks) {
  WriteSequence(4);
  const std::string mid = FramePath(dir_.path(), "x", 2);
  std::filesystem::remove(mid);
  ASSERT_EQ(::mkfifo(mid.c_str(), 0644), 0);
  ReplaySource src(Config());
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  std::vector<SourceStatus> got;
  ASSERT_TRUE(testing::ReturnsWithoutBlocking(
      [&] {
        for (int f = 0; f < 4; ++f) {
          FrameView v;
          got.push_back(src.Acquire(0, 50, &v));
          src.Release(0);
        }
      },
      {mid}))
      << "Acquire blocked on a FIFO frame";
  EXPECT_EQ(got, (std::vector<SourceStatus>{SourceStatus::kOk, SourceStatus::kOk, SourceStatus::kBadFrame,
                                             SourceStatus::kOk}));
  EXPECT_EQ(src.counters(0).bad_files, 1U);
  EXPECT_EQ(std::string(src.problem()), mid + ": not a regular file");

  const std::string first = FramePath(dir_.path(), "z", 0);
  std::filesystem::remove(first);
  ASSERT_EQ(::mkfifo(first.c_str(), 0644), 0);
  SourceStatus start = SourceStatus::kOk;
  std::string problem;
  ASSERT_TRUE(testing::ReturnsWithoutBlocking(
      [&] {
        ReplaySource s(Config());
        start = s.Start();
        problem = s.problem();
      },
      {first}))
      << "Start blocked on a FIFO as a camera's first frame";
  EXPECT_EQ(start, SourceStatus::kBadFrame);
  EXPECT_EQ(problem, first + ": not a regular file");  // navd prints it
  std::filesystem::remove(first);
  WriteFile(first, Pgm(kW, kH, Seed(2, 0)));

  const std::string truth = dir_.path() + "/truth.csv";
  std::filesystem::remove(truth);
  ASSERT_EQ(::mkfifo(truth.c_str(), 0644), 0);
  ASSERT_TRUE(testing::ReturnsWithoutBlocking(
      [&] {
        ReplaySource s(Config());
        start = s.Start();
        problem = s.problem();
      },
      {truth}))
      << "Start blocked on a FIFO as truth.csv";
  EXPECT_EQ(start, SourceStatus::kBadConfig);
  EXPECT_EQ(problem, truth + ": not a regular file");
}

}  // namespace
}  // namespace mfns::fw
