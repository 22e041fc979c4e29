#include "host/view/view_cli.h"

#include <cmath>

#include "host/util/cli_parse.h"
#include "host/util/user_error.h"

namespace mfns::host {

HostPort ParseHostPort(const std::string& text, const std::string& option, const std::string& scheme) {
  const std::string expected = option + ": expected " + scheme + "HOST:PORT, got '" + OneLine(text) + "'";
  if (text.compare(0, scheme.size(), scheme) != 0) throw UserError(expected);
  const std::string rest = text.substr(scheme.size());
  const std::size_t colon = rest.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == rest.size()) throw UserError(expected);
  HostPort hp{rest.substr(0, colon), 0};
  // A host name or an IPv4 literal (letters, digits, '.', '-'): anything else would only fail
  // later, at the lookup.
  if (hp.host.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789.-") != std::string::npos)
    throw UserError(option + ": '" + OneLine(hp.host) + "' is not a host name or an IPv4 address");
  const std::string port = rest.substr(colon + 1);
  if (port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos) throw UserError(expected);
  hp.port = std::stoi(port);
  if (hp.port > 65535) throw UserError(option + ": port " + port + " is above 65535");
  return hp;
}

void ParseViewCommandLine(CLI::App& app, int argc, char** argv, ViewCommandLine* cl) {
  app.description(
      "mfns-view: a live page of the flyer (pose, trail, view cones, status and health) from mfns-navd's "
      "datagrams, or the playback of a poses CSV");
  app.add_option("--rig", cl->rig_path, "Rig file (YAML) of the cameras and the beacon map drawn (default: FRAMES/rig.yaml)");
  app.add_option("--listen", cl->listen,
                 "Where mfns-navd's datagrams arrive (its --output udp://...); default udp://0.0.0.0:5600 without --play");
  app.add_option("--http", cl->http, "Address of the page (HOST:PORT; port 0: any free port, printed)")->capture_default_str();
  app.add_option("--play", cl->play, "Play back this poses CSV (mfns-navd --log) instead of listening");
  app.add_option("--frames", cl->frames, "The frames directory of the recording: its rig.yaml and truth.csv (drawn beside)");
  app.add_option("--speed", cl->speed, "Playback speed, times the sample rate")->capture_default_str();
  ParseOneLine(app, argc, argv);
  if (cl->rig_path.empty() && cl->frames.empty()) throw UserError("--rig: needed (or --frames DIR holding rig.yaml)");
  if (!cl->frames.empty() && cl->play.empty()) throw UserError("--frames: only with --play POSES.csv");
  if (!(cl->speed > 0.0) || !std::isfinite(cl->speed) || cl->speed > 1e6)
    throw UserError("--speed: expected a number above 0 and at most 1e6, got " + std::to_string(cl->speed));
  if (cl->listen.empty() && cl->play.empty()) cl->listen = "udp://0.0.0.0:5600";
  if (!cl->listen.empty()) cl->listen_at = ParseHostPort(cl->listen, "--listen", "udp://");
  cl->http_at = ParseHostPort(cl->http, "--http", "");
}

}  // namespace mfns::host
