// mfns-view: serves a page of the flyer on localhost (README.md "mfns-view", host/view/README.md).
// Live from mfns-navd's datagrams (--listen), or the playback of a poses CSV (--play). Runs until
// SIGINT or SIGTERM; exit 0 then, 1 with one line on stderr for a bad option, file or address.
#include <CLI/CLI.hpp>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <thread>

#include "host/rigio/rig_yaml.h"
#include "host/util/user_error.h"
#include "host/view/frame_blobs.h"
#include "host/view/playback.h"
#include "host/view/view_cli.h"
#include "host/view/view_server.h"
#include "host/view/view_state.h"

namespace mfns::host {
namespace {

namespace fs = std::filesystem;

// Plays the poses into the state at their sample rate times `speed` (with each frame set's
// blobs when the frames directory is given), then marks it finished.
void Play(const std::vector<ViewPose>& poses, double speed, FrameBlobs* frames, ViewState* state,
          const std::atomic<bool>* stop) {
  for (std::size_t i = 0; i < poses.size() && !*stop; ++i) {
    std::this_thread::sleep_for(std::chrono::duration<double>(PlaybackDelayS(poses, i, speed)));
    if (frames != nullptr) state->SetBlobs(frames->Detect(poses[i]));
    state->AddPose(poses[i]);
  }
  state->SetFinished();
  std::cerr << "mfns-view: played " << poses.size() << " frame sets";
  if (frames != nullptr && frames->unreadable_frames() > 0)
    std::cerr << " (" << frames->unreadable_frames() << " frames missing or unreadable)";
  std::cerr << "\n";
}

int Serve(const ViewCommandLine& cl) {
  const fs::path rig_path = cl.rig_path.empty() ? fs::path(cl.frames) / "rig.yaml" : fs::path(cl.rig_path);
  const Rig rig = ReadRigYaml(rig_path);
  std::vector<ViewPose> poses;
  if (!cl.play.empty()) poses = ReadPosesCsv(cl.play);
  const std::string source = cl.play.empty() ? cl.listen : "playback of " + cl.play;
  ViewState state(rig, source);
  if (!cl.frames.empty() && fs::exists(fs::path(cl.frames) / "truth.csv"))
    state.SetTruthTrail(ReadTruthTrail(fs::path(cl.frames) / "truth.csv"));
  // Signals are taken by sigwait below: blocked before any thread starts, so every thread inherits it.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  std::unique_ptr<DatagramListener> listener;
  if (!cl.listen.empty()) listener = std::make_unique<DatagramListener>(cl.listen_at, &state);
  PageServer page(cl.http_at, &state);
  std::cerr << "mfns-view: http://" << cl.http_at.host << ":" << page.port() << "/";
  if (listener) std::cerr << " (datagrams on udp://" << cl.listen_at.host << ":" << listener->port() << ")";
  std::cerr << std::endl;
  page.Start();
  if (listener) listener->Start();
  std::atomic<bool> stop{false};
  std::thread player;
  std::unique_ptr<FrameBlobs> frames;
  if (!cl.frames.empty()) frames = std::make_unique<FrameBlobs>(rig, cl.frames);
  if (!poses.empty()) player = std::thread([&] { Play(poses, cl.speed, frames.get(), &state, &stop); });
  int sig = 0;
  sigwait(&signals, &sig);
  stop = true;
  if (player.joinable()) player.join();
  return 0;
}

int Run(int argc, char** argv) {
  CLI::App app;
  ViewCommandLine cl;
  try {
    ParseViewCommandLine(app, argc, argv, &cl);
    return Serve(cl);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    std::cerr << "mfns-view: " << e.what() << " (--help for usage)\n";
    return 1;
  } catch (const UserError& e) {
    std::cerr << "mfns-view: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace
}  // namespace mfns::host

int main(int argc, char** argv) { return mfns::host::Run(argc, argv); }
