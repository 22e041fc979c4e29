#include "host/flash/flash.h"

#include <cctype>
#include <cstring>
#include <memory>
#include <sstream>

#include "firmware/modules/params/param_store.h"
#include "host/flash/process.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

constexpr char kScheme[] = "ssh://";

std::string LastLine(const std::string& text) {
  std::istringstream in(text);
  std::string last;
  for (std::string line; std::getline(in, line);) {
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  }
  return last;
}

// paramctl's "mfns-paramctl: refused: ..." without its tool prefix.
std::string WithoutToolPrefix(const std::string& line) {
  const std::string prefix = "mfns-paramctl: ";
  return line.rfind(prefix, 0) == 0 ? line.substr(prefix.size()) : line;
}

bool ValidHostChars(const std::string& h) {
  if (h.empty() || h[0] == '-') return false;
  for (char c : h) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_' || c == ':' || c == '%')) {
      return false;
    }
  }
  return true;
}

std::uint64_t ParseGeneration(const std::string& s) {
  if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos || s.size() > 20) return 0;
  return std::stoull(s);
}

// A local store: the flyer's own store code, in this process.
FlashResult FlashLocal(const std::vector<std::uint8_t>& blob, const FlashTarget& target, const FlashOptions& opt,
                       FlashResult r) {
  auto store = std::make_unique<fw::ParamStore>();  // ~40 KB: not on the stack
  if (store->SetDirectory(target.dir.c_str()) != fw::StoreStatus::kOk) {
    throw UserError(target.dir + ": store path empty or too long");
  }
  fw::StoreError mk;
  if (store->CreateDirectory(&mk) != fw::StoreStatus::kOk) {
    throw UserError(target.dir + ": cannot create the store: " + std::strerror(mk.error));
  }
  fw::InstallOptions io;
  io.force = opt.force;
  io.allow_rig_change = opt.allow_rig_change;
  fw::InstallReport rep;
  const fw::StoreStatus s = store->Install(blob, io, &rep);
  const std::string old_gen = std::to_string(rep.old_info.generation);
  const std::string new_gen = std::to_string(rep.new_info.generation);
  switch (s) {
    case fw::StoreStatus::kOk: break;
    case fw::StoreStatus::kRigIdMismatch:
      throw UserError(target.dir + ": refused: blob is for rig '" + rep.new_info.rig_id.data() +
                      "' but the active blob is for rig '" + rep.old_info.rig_id.data() +
                      "' (--allow-rig-change to replace it)");
    case fw::StoreStatus::kStaleGeneration:
      throw UserError(target.dir + ": refused: generation " + new_gen + " is not newer than the active generation " +
                      old_gen + " (--force to install it anyway)");
    case fw::StoreStatus::kIoError:
      throw UserError(target.dir + ": install failed: " + fw::ToString(rep.io.step) + ": " +
                      std::strerror(rep.io.error));
    default:
      throw UserError(target.dir + ": install failed: " + fw::ToString(s));
  }
  Rig rig;
  BlobInfo info;
  if (store->Load(nullptr, &rig, &info, nullptr) != fw::StoreStatus::kOk || !fw::SameBlob(info, r.blob)) {
    throw UserError(target.dir + ": installed, but the store does not open to it");
  }
  r.active_generation = info.generation;
  r.active_rig_id = info.rig_id.data();
  r.install_output = "installed generation " + new_gen + " in " + target.dir + "/" + fw::SlotFileName(rep.slot) + "\n";
  return r;
}

// Runs one remote command; maps ssh's and the remote shell's failures to one-line errors.
ProcessResult RunRemote(const FlashTarget& t, const FlashOptions& opt, const std::vector<std::string>& args,
                        const std::vector<std::uint8_t>& stdin_bytes) {
  const ProcessResult p = RunProcess(SshArgv(t, opt, RemoteCommand(opt, args)), stdin_bytes, opt.timeout_s);
  const std::string where = t.host + ":" + std::to_string(t.port);
  if (p.timed_out) {
    throw UserError("ssh to " + where + " timed out after " + std::to_string(opt.timeout_s) + " s");
  }
  if (p.signal != 0) throw UserError("ssh to " + where + " killed by signal " + std::to_string(p.signal));
  switch (p.exit_code) {
    case 0:
      return p;
    case 255:  // ssh's own failure: cannot connect, resolve or authenticate
      throw UserError("cannot reach " + where + ": " + LastLine(p.err));
    case 127:
      throw UserError("'" + opt.remote_paramctl + "' not found on " + t.host +
                      " (install the mfns package there, or give its path with --remote-paramctl)");
    case 126:
      throw UserError("'" + opt.remote_paramctl + "' is not executable on " + t.host + ": " + LastLine(p.err));
    default:
      throw UserError(t.Display() + ": " + WithoutToolPrefix(LastLine(p.err.empty() ? p.out : p.err)));
  }
}

FlashResult FlashSsh(const std::vector<std::uint8_t>& blob, const FlashTarget& t, const FlashOptions& opt,
                     FlashResult r) {
  std::vector<std::string> install = {"install", "--store", t.dir};
  if (opt.force) install.push_back("--force");
  if (opt.allow_rig_change) install.push_back("--allow-rig-change");
  if (!opt.signal_navd) install.push_back("--no-signal");
  install.push_back("-");
  r.install_output = RunRemote(t, opt, install, blob).out;

  const ProcessResult show = RunRemote(t, opt, {"show", "--store", t.dir}, {});
  r.active_rig_id = ShowField(show.out, "rig_id");
  r.active_generation = ParseGeneration(ShowField(show.out, "generation"));
  if (r.active_generation != r.blob.generation || r.active_rig_id != r.blob.rig_id.data()) {
    throw UserError(t.Display() + ": installed, but show reports generation " + ShowField(show.out, "generation") +
                    " rig '" + r.active_rig_id + "' active, not generation " + std::to_string(r.blob.generation));
  }
  return r;
}

}  // namespace

std::string FlashTarget::Display() const {
  if (kind == Kind::kLocal) return dir;
  return (user.empty() ? "" : user + "@") + host + ":" + std::to_string(port) + ":" + dir;
}

FlashTarget ParseTarget(const std::string& text) {
  FlashTarget t;
  if (text.empty()) throw UserError("empty TARGET");
  const std::string named = "TARGET " + OneLine(text);  // what an error names
  if (text.rfind(kScheme, 0) != 0) {
    if (text.find("://") != std::string::npos) {
      throw UserError(named + ": unsupported scheme (a directory, or ssh://[user@]host[:port]/dir)");
    }
    t.kind = FlashTarget::Kind::kLocal;
    t.dir = text;
    return t;
  }
  t.kind = FlashTarget::Kind::kSsh;
  const std::string rest = text.substr(std::strlen(kScheme));
  const std::size_t slash = rest.find('/');
  if (slash == std::string::npos || slash + 1 >= rest.size()) {
    throw UserError(named + ": no store directory (ssh://[user@]host[:port]/dir)");
  }
  t.dir = rest.substr(slash);
  std::string authority = rest.substr(0, slash);
  const std::size_t at = authority.rfind('@');
  if (at != std::string::npos) {
    t.user = authority.substr(0, at);
    authority = authority.substr(at + 1);
    if (t.user.empty() || t.user[0] == '-') throw UserError(named + ": bad user name");
  }
  std::string port;
  if (!authority.empty() && authority[0] == '[') {  // [IPv6]:port
    const std::size_t close = authority.find(']');
    if (close == std::string::npos) throw UserError(named + ": unterminated [address]");
    t.host = authority.substr(1, close - 1);
    const std::string after = authority.substr(close + 1);
    if (!after.empty()) {
      if (after[0] != ':') throw UserError(named + ": expected :port after ]");
      port = after.substr(1);
    }
  } else {
    const std::size_t colon = authority.find(':');
    t.host = authority.substr(0, colon);
    if (colon != std::string::npos) port = authority.substr(colon + 1);
  }
  if (!ValidHostChars(t.host)) throw UserError(named + ": bad or missing host name");
  if (!port.empty() || authority.find(':') != std::string::npos) {
    if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
        std::stoi(port) < 1 || std::stoi(port) > 65535) {
      throw UserError(named + ": port must be 1..65535");
    }
    t.port = std::stoi(port);
  }
  return t;
}

std::string ShellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') {
      out += "'\\''";
    } else {
      out += c;
    }
  }
  return out + "'";
}

std::string RemoteCommand(const FlashOptions& options, const std::vector<std::string>& args) {
  std::istringstream words(options.remote_paramctl);
  std::string cmd;
  for (std::string w; words >> w;) cmd += (cmd.empty() ? "" : " ") + ShellQuote(w);
  if (cmd.empty()) throw UserError("empty --remote-paramctl");
  for (const auto& a : args) cmd += " " + ShellQuote(a);
  return cmd;
}

std::vector<std::string> SshArgv(const FlashTarget& t, const FlashOptions& o, const std::string& remote_command) {
  std::vector<std::string> argv = {o.ssh_program, "-T", "-p", std::to_string(t.port), "-o", "BatchMode=yes",
                                   "-o", "ConnectTimeout=" + std::to_string(o.connect_timeout_s)};
  if (!o.ssh_config.empty()) {
    argv.push_back("-F");
    argv.push_back(o.ssh_config);
  }
  if (!o.identity_file.empty()) {
    argv.push_back("-i");
    argv.push_back(o.identity_file);
    argv.push_back("-o");
    argv.push_back("IdentitiesOnly=yes");
  }
  for (const auto& opt : o.ssh_options) {
    argv.push_back("-o");
    argv.push_back(opt);
  }
  argv.push_back(t.user.empty() ? t.host : t.user + "@" + t.host);
  argv.push_back(remote_command);
  return argv;
}

std::string ShowField(const std::string& show_output, const std::string& key) {
  std::istringstream in(show_output);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(key + ": ", 0) == 0) return line.substr(key.size() + 2);
  }
  return "";
}

FlashResult Flash(const std::vector<std::uint8_t>& blob, const FlashTarget& target, const FlashOptions& options) {
  FlashResult r;
  auto rig = std::make_unique<Rig>();
  const BlobStatus s = DecodeParamBlob(blob, nullptr, rig.get(), &r.blob);
  if (s != BlobStatus::kOk) throw UserError(std::string("invalid blob: ") + ToString(s));
  return target.kind == FlashTarget::Kind::kLocal ? FlashLocal(blob, target, options, r)
                                                  : FlashSsh(blob, target, options, r);
}

}  // namespace mfns::host
