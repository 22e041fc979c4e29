// mfns-view's page in headless Chromium (issue 17 item 3): fed live by mfns-navd replaying a
// rendered sweep, and by the playback of that run's poses CSV, the page shows the last pose
// of the run (the DOM's values equal the poses CSV's) and draws the flyer (a screenshot with
// its red marker). Runs the built binaries; skipped without chromium.
#include <gtest/gtest.h>
#include <httplib.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <thread>

#include "host/util/csv_table.h"

extern char** environ;

namespace mfns::host {
namespace {

namespace fs = std::filesystem;

std::string Slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

int Shell(const std::string& cmd) { return std::system(("bash -c '" + cmd + "'").c_str()); }

// A child process (mfns-view) with stderr to a file; SIGTERM and reaped on destruction.
class Child {
 public:
  Child(const std::vector<std::string>& argv, const fs::path& err) : err_(err) {
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    if (posix_spawn(&pid_, args[0], &fa, nullptr, args.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&fa);
  }
  ~Child() { Stop(); }
  // Stops it; its exit status (-1: not a normal exit).
  int Stop() {
    if (pid_ <= 0) return status_;
    ::kill(pid_, SIGTERM);
    int st = 0;
    ::waitpid(pid_, &st, 0);
    pid_ = -1;
    status_ = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return status_;
  }
  // The port after `prefix` ("http://127.0.0.1:") in its stderr, once printed (-1 after 10 s).
  int Port(const std::string& prefix) const {
    for (int i = 0; i < 1000; ++i) {
      const std::string text = Slurp(err_);
      const std::size_t at = text.find(prefix);
      if (at != std::string::npos && text.find('\n', at) != std::string::npos)
        return std::atoi(text.c_str() + at + prefix.size());
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return -1;
  }

 private:
  pid_t pid_ = -1;
  int status_ = -1;
  fs::path err_;
};

class ViewChromiumTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::string tmpl = (fs::temp_directory_path() / "mfns-view-chromium-XXXXXX").string();
    ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
    dir_ = new fs::path(tmpl);
    const std::string d = dir_->string();
    // The paper turntable sweep at 5 Hz from 238 deg in 2 deg steps (as tests/mavlink): a
    // track, a lost stretch in the sweep's gap, a second track to the end.
    const std::string make =
        std::string(MFNS_SIM_PATH) + " preset paper-turntable | sed -e \"s/^frame_rate_hz: .*/frame_rate_hz: 5/\" "
        "-e \"s/^frames: .*/frames: 50/\" -e \"s/main_start_deg: .*/main_start_deg: 238/\" "
        "-e \"s/main_step_deg: .*/main_step_deg: 2/\" > " + d + "/scenario.yaml && " + MFNS_SIM_PATH +
        " render --scenario " + d + "/scenario.yaml --out " + d + "/render > " + d + "/render.log 2>&1 && " +
        MFNS_CALIB_PATH + " blob " + d + "/render/rig.yaml --out " + d + "/true.bin > /dev/null 2>&1";
    ASSERT_EQ(Shell(make), 0) << Slurp(*dir_ / "render.log");
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  void SetUp() override {
    if (std::system("command -v chromium > /dev/null 2>&1") != 0) GTEST_SKIP() << "chromium not installed";
  }
  static std::string Chromium(const std::string& what, const std::string& url) {
    return "timeout 60 chromium --headless --no-sandbox --disable-gpu --hide-scrollbars --disable-background-networking "
           "--disable-component-update --disable-sync --no-first-run --user-data-dir=" + (*dir_ / "profile").string() +
           " --window-size=1400,1000 --virtual-time-budget=3000 " + what + " " + url;
  }
  // The page's DOM once it has drawn the state (the body's data-frame is set).
  static std::string Dom(int port) {
    const fs::path dom = *dir_ / "dom.html";
    const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/";
    EXPECT_EQ(std::system((Chromium("--dump-dom", url) + " > " + dom.string() + " 2> /dev/null").c_str()), 0);
    return Slurp(dom);
  }
  // The opening tag of the element with this id ("" when none). (No std::regex: GCC 12 warns
  // about its std::function under the sanitizers' -O1, an error with -Werror.)
  static std::string Tag(const std::string& dom, const std::string& id) {
    const std::size_t at = dom.find("id=\"" + id + "\"");
    const std::size_t open = at == std::string::npos ? at : dom.rfind('<', at);
    const std::size_t close = at == std::string::npos ? at : dom.find('>', at);
    return open == std::string::npos || close == std::string::npos ? "" : dom.substr(open, close + 1 - open);
  }
  // The text of the element with this id, up to its first child.
  static std::string Field(const std::string& dom, const std::string& id) {
    const std::string tag = Tag(dom, id);
    if (tag.empty()) return "(no #" + id + ")";
    const std::size_t from = dom.find(tag) + tag.size();
    return dom.substr(from, dom.find('<', from) - from);
  }
  // A number attribute of a tag (-1 when missing).
  static int Attribute(const std::string& tag, const std::string& name) {
    const std::size_t at = tag.find(name + "=\"");
    return at == std::string::npos ? -1 : std::atoi(tag.c_str() + at + name.size() + 2);
  }
  // mfns-navd replays the sweep from its first true pose (as tests/mavlink), logging to `log`.
  static int Navd(const std::string& output, const fs::path& log) {
    const fs::path d = *dir_;
    const std::string start =
        "$(awk -F, \"NR == 2 {printf \\\"%.4f,%.4f,%.4f,%.6f,%.6f,%.6f\\\", \\$3, \\$4, \\$5, \\$6, \\$7, \\$8}\" " +
        (d / "render/truth.csv").string() + ")";
    return Shell(std::string(MFNS_NAVD_PATH) + " --params " + (d / "true.bin").string() + " --source replay:" +
                 (d / "render").string() + " --rate-hz 5 --initial-pose " + start + " " + output + " --log " +
                 log.string() + " --pid-file \"\" --quiet");
  }
  static void ExpectTheLastRowShown(const std::string& dom, const fs::path& poses_csv);
  static void ExpectTheFlyerDrawn(int port);
  static void ExpectTheBlobsShown(const std::string& dom, const fs::path& poses_csv);
  static fs::path* dir_;
};

fs::path* ViewChromiumTest::dir_ = nullptr;

void ViewChromiumTest::ExpectTheLastRowShown(const std::string& dom, const fs::path& poses_csv) {
  const CsvTable t = CsvTable::Read(poses_csv);
  ASSERT_GT(t.size(), 0u);
  const std::size_t last = t.size() - 1;
  EXPECT_EQ(Field(dom, "frame"), t.Cell(last, t.Column("frame")));
  EXPECT_EQ(Field(dom, "status"), t.Cell(last, t.Column("status")));
  ASSERT_NE(t.Cell(last, t.Column("status")), "lost") << "the sweep should end in a track";
  char want[64];
  for (const char* c : {"x_mm", "y_mm", "z_mm"}) {
    std::snprintf(want, sizeof(want), "%.1f", t.Number(last, t.Column(c)));
    EXPECT_EQ(Field(dom, c), want) << c;
  }
  std::snprintf(want, sizeof(want), "%.2f", t.Number(last, t.Column("yaw_deg")));
  EXPECT_EQ(Field(dom, "yaw_deg"), want);
  int fix = 0, degraded = 0, lost = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const std::string& s = t.Cell(i, t.Column("status"));
    (s == "fix" ? fix : s == "degraded" ? degraded : lost) += 1;
  }
  EXPECT_GT(lost, 0);  // the sweep's gap: the page counted what the log holds
  EXPECT_EQ(Field(dom, "counts"), std::to_string(fix) + " / " + std::to_string(degraded) + " / " + std::to_string(lost));
}

// Each camera's image shows the last frame set's blobs, at least as many matched as the pose
// used beacons.
void ViewChromiumTest::ExpectTheBlobsShown(const std::string& dom, const fs::path& poses_csv) {
  const CsvTable rows = CsvTable::Read(poses_csv);
  const int used = static_cast<int>(rows.Number(rows.size() - 1, rows.Column("n_beacons")));
  int matched = 0, blobs = 0;
  for (int k = 0; k < 3; ++k) {
    const std::string tag = Tag(dom, "image-" + std::to_string(k));
    ASSERT_GE(Attribute(tag, "data-blobs"), 0) << "no image of camera " << k << ": " << tag;
    ASSERT_GE(Attribute(tag, "data-matched"), 0) << tag;
    blobs += Attribute(tag, "data-blobs");
    matched += Attribute(tag, "data-matched");
  }
  EXPECT_GE(matched, used);
  EXPECT_GT(matched, 0);
  EXPECT_GE(blobs, matched);
}

// A screenshot: the flyer's red marker is drawn in each of the three panels (about 110 px each).
void ViewChromiumTest::ExpectTheFlyerDrawn(int port) {
  const fs::path png = *dir_ / "page.png";
  const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/";
  ASSERT_EQ(std::system((Chromium("--screenshot=" + png.string(), url) + " > /dev/null 2>&1").c_str()), 0);
  const cv::Mat image = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  int red = 0;
  for (int v = 0; v < image.rows; ++v)
    for (int u = 0; u < image.cols; ++u) {
      const cv::Vec3b p = image.at<cv::Vec3b>(v, u);  // BGR
      red += p[2] > 220 && p[1] < 40 && p[0] < 40 ? 1 : 0;
    }
  std::printf("page.png: %d red pixels\n", red);
  EXPECT_GT(red, 3 * 80) << png;
  EXPECT_LT(red, 3 * 200) << png;
}

// Live: mfns-navd replays the sweep with --output udp:// to the view; the page then shows
// navd's last pose as its log has it, and its health message.
TEST_F(ViewChromiumTest, ThePageShowsNavdsPosesLive) {
  const fs::path d = *dir_;
  Child view({MFNS_VIEW_PATH, "--rig", (d / "render/rig.yaml").string(), "--listen", "udp://127.0.0.1:0", "--http",
              "127.0.0.1:0"},
             d / "live.err");
  const int http = view.Port("http://127.0.0.1:"), udp = view.Port("udp://127.0.0.1:");
  ASSERT_GT(http, 0) << Slurp(d / "live.err");
  ASSERT_GT(udp, 0) << Slurp(d / "live.err");
  ASSERT_EQ(Navd("--output udp://127.0.0.1:" + std::to_string(udp), d / "live.csv"), 0);
  const CsvTable rows = CsvTable::Read(d / "live.csv");
  httplib::Client client("127.0.0.1", http);
  bool all = false;  // UDP on loopback: every datagram arrives, but not at once (slow under ASan)
  for (int i = 0; i < 6000 && !all; ++i) {
    const auto r = client.Get("/state.json");
    all = r && nlohmann::json::parse(r->body)["counts"]["poses"] == rows.size();
    if (!all) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(all) << "the view did not count " << rows.size() << " poses within 120 s: " << Slurp(d / "live.err");
  const std::string dom = Dom(http);
  ExpectTheLastRowShown(dom, d / "live.csv");
  EXPECT_NE(dom.find("<td class=\"l\">frame sets</td>"), std::string::npos) << "no health shown";
  EXPECT_NE(Field(dom, "sigma_mm"), "-");  // the datagram carries the covariance
  ExpectTheBlobsShown(dom, d / "live.csv");
  ExpectTheFlyerDrawn(http);
  EXPECT_EQ(view.Stop(), 0);  // SIGTERM: a clean exit
}

// Playback: the same run's poses CSV with its frames directory (rig and truth trail).
TEST_F(ViewChromiumTest, ThePageShowsAPlayedBackRun) {
  const fs::path d = *dir_;
  ASSERT_EQ(Navd("", d / "played.csv"), 0);
  Child view({MFNS_VIEW_PATH, "--frames", (d / "render").string(), "--play", (d / "played.csv").string(), "--speed",
              "1000", "--http", "127.0.0.1:0"},
             d / "play.err");
  const int http = view.Port("http://127.0.0.1:");
  ASSERT_GT(http, 0) << Slurp(d / "play.err");
  httplib::Client client("127.0.0.1", http);
  // Playback detects the blobs of every frame set: seconds under the sanitizers with other
  // tests beside (CI's host-asan stage saw frame 29 of 49 after 4 s), so wait up to 120 s.
  bool finished = false;
  for (int i = 0; i < 6000 && !finished; ++i) {
    const auto r = client.Get("/state.json");
    finished = r && nlohmann::json::parse(r->body)["finished"] == true;
    if (!finished) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(finished) << "playback did not end within 120 s: " << Slurp(d / "play.err");
  const std::string dom = Dom(http);
  ExpectTheLastRowShown(dom, d / "played.csv");
  EXPECT_EQ(Field(dom, "finished"), "(playback ended)");
  EXPECT_EQ(Field(dom, "sigma_mm"), "-");  // the CSV has no covariance
  ExpectTheBlobsShown(dom, d / "played.csv");  // detected in the frames, matched by the pose
  ExpectTheFlyerDrawn(http);
  EXPECT_EQ(view.Stop(), 0);
}

TEST_F(ViewChromiumTest, BadArgumentsExitOneWithOneLine) {
  const fs::path d = *dir_;
  const std::string view = MFNS_VIEW_PATH;
  struct Case {
    std::string args, expect;
  } cases[] = {
      {"--listen udp://127.0.0.1:1", "--rig: needed"},
      {"--rig " + (d / "nothing.yaml").string(), "nothing.yaml"},
      {"--rig " + (d / "render/rig.yaml").string() + " --listen tcp://x:1", "--listen: expected udp://HOST:PORT"},
      {"--rig " + (d / "render/rig.yaml").string() + " --play " + (d / "render/truth.csv").string(), "no column 'status'"},
      {"--frames " + (d / "render").string(), "--frames: only with --play"},
      {"--rig " + (d / "render/rig.yaml").string() + " --listen udp://192.0.2.1:5600", "--listen: cannot bind"},
  };
  for (const Case& c : cases) {
    const fs::path err = d / "bad.err";
    const int rc = std::system((view + " " + c.args + " 2> " + err.string()).c_str());
    const std::string text = Slurp(err);
    EXPECT_EQ(WEXITSTATUS(rc), 1) << c.args;
    EXPECT_NE(text.find(c.expect), std::string::npos) << c.args << ": " << text;
    EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << text;
  }
}

}  // namespace
}  // namespace mfns::host
