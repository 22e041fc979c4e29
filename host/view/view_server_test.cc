#include "host/view/view_server.h"

#include <gtest/gtest.h>
#include <httplib.h>

#include <array>
#include <chrono>
#include <thread>

#include "common/rig/paper_rig.h"
#include "firmware/modules/publish/publishers.h"
#include "host/util/cli_parse.h"
#include "host/util/user_error.h"
#include "host/view/view_cli.h"

namespace mfns::host {
namespace {

using nlohmann::json;

std::string ParseError(const std::string& text, const std::string& scheme) {
  try {
    ParseHostPort(text, "--listen", scheme);
  } catch (const UserError& e) {
    return e.what();
  }
  return "";
}

TEST(ViewServer, HostPortParsing) {
  const HostPort a = ParseHostPort("udp://127.0.0.1:5600", "--listen", "udp://");
  EXPECT_EQ(a.host, "127.0.0.1");
  EXPECT_EQ(a.port, 5600);
  EXPECT_EQ(ParseHostPort("localhost:0", "--http", "").port, 0);
  for (const char* bad : {"127.0.0.1:5600", "udp://:5600", "udp://a b:1", "udp://[::1]:5600", "udp://host:", "udp://host:-1", "udp://host:99999999",
                          "udp://host:65536", "udp://host:12a", "udp://host"}) {
    const std::string e = ParseError(bad, "udp://");
    EXPECT_EQ(e.rfind("--listen: ", 0), 0u) << bad << ": " << e;
  }
}

// Found by host_cli_fuzz: an argument holding a newline made CLI11's message two lines.
TEST(ViewServer, CommandLineErrorsAreOneLine) {
  for (const std::vector<std::string>& words : std::vector<std::vector<std::string>>{
           {"mfns-view", "--rig", "r.yaml", "--http\n7.0.0.1:8080"},
           {"mfns-view", "--rig", "r.yaml", "--speed", "fast\nest"},
           {"mfns-view", "--rig", "r.yaml", "--listen", "udp://a\nb:1"},
           {"mfns-view", "--rig", "r.yaml", "--speed", "0"},
           {"mfns-view", "--play", "p.csv"}}) {
    std::string what;
    try {
      ParseWords(ParseViewCommandLine, words);
    } catch (const CLI::ParseError& e) {
      what = e.what();
    } catch (const UserError& e) {
      what = e.what();
    }
    EXPECT_FALSE(what.empty()) << words.back();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
  const ViewCommandLine cl = ParseWords(ParseViewCommandLine, {"mfns-view", "--rig", "r.yaml"});
  EXPECT_EQ(cl.listen_at.host, "0.0.0.0");  // live by default, where navd's docs send
  EXPECT_EQ(cl.listen_at.port, 5600);
  EXPECT_EQ(cl.http_at.port, 8080);
}

template <typename Done>
bool WaitFor(Done done) {
  for (int i = 0; i < 200 && !done(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  return done();
}

// mfns-navd's sender (fw::UdpPublisher) to the listener: the pose shows; a datagram with a
// broken CRC is counted, and shown with its reason.
TEST(ViewServer, DatagramsFromTheFirmwaresSenderReachTheState) {
  ViewState state(PaperRig(), "test");
  DatagramListener listener(HostPort{"127.0.0.1", 0}, &state);
  listener.Start();
  fw::UdpPublisher out;
  ASSERT_EQ(out.Open(("udp://127.0.0.1:" + std::to_string(listener.port())).c_str()), fw::PublishStatus::kOk);
  fw::PoseRecord r;
  r.frame_set = 42;
  r.status = fw::NavStatus::kFix;
  r.r_w_wb = Eigen::Vector3d(0.25, 0.5, -0.125);
  std::array<std::uint8_t, fw::kPoseMessageBytes> bytes{};
  fw::EncodePose(r, bytes);
  ASSERT_EQ(out.Send(bytes), fw::PublishStatus::kOk);
  ASSERT_TRUE(WaitFor([&] { return state.poses_received() == 1; }));
  fw::HealthRecord h;
  h.fixes = 7;
  std::array<std::uint8_t, fw::kHealthMessageBytes> hb{};
  fw::EncodeHealth(h, hb);
  ASSERT_EQ(out.Send(hb), fw::PublishStatus::kOk);
  bytes[100] ^= 1;  // the CRC no longer matches
  ASSERT_EQ(out.Send(bytes), fw::PublishStatus::kOk);
  ASSERT_TRUE(WaitFor([&] { return state.Json()["counts"]["bad_datagrams"] == 1; }));
  const json j = state.Json();
  EXPECT_EQ(j["pose"]["frame_set"], 42);
  EXPECT_DOUBLE_EQ(j["pose"]["r_w_wb"][2].get<double>(), -0.125);
  EXPECT_EQ(j["health"]["fixes"], 7);
  EXPECT_EQ(j["counts"]["last_bad"], fw::ToString(fw::MessageStatus::kBadCrc));
  listener.Stop();
}

TEST(ViewServer, ThePageAndItsStateAreServed) {
  ViewState state(PaperRig(), "test");
  PageServer page(HostPort{"127.0.0.1", 0}, &state);
  page.Start();
  httplib::Client client("127.0.0.1", page.port());
  const auto html = client.Get("/");
  ASSERT_TRUE(html);
  EXPECT_EQ(html->status, 200);
  EXPECT_NE(html->body.find("<canvas id=\"top\""), std::string::npos);
  const auto st = client.Get("/state.json");
  ASSERT_TRUE(st);
  EXPECT_EQ(json::parse(st->body), state.Json());
  const auto rig = client.Get("/rig.json");
  ASSERT_TRUE(rig);
  EXPECT_EQ(json::parse(rig->body)["beacons_w"].size(), static_cast<std::size_t>(PaperRig().num_beacons));
  EXPECT_EQ(client.Get("/nothing")->status, 404);
  // A second server on the same port is refused in one line naming --http.
  try {
    PageServer again(HostPort{"127.0.0.1", page.port()}, &state);
    ADD_FAILURE() << "bound twice";
  } catch (const UserError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--http: cannot serve on 127.0.0.1:", 0), 0u) << e.what();
  }
  page.Stop();
}

}  // namespace
}  // namespace mfns::host
