#include "firmware/app/paramctl/paramctl.h"

#include <fcntl.h>
#include <getopt.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>

#include "common/blob/param_blob.h"
#include "common/limits.h"
#include "firmware/modules/params/param_store.h"
#include "firmware/modules/params/reload_signal.h"

namespace mfns::fw {
namespace {

constexpr char kTool[] = "mfns-paramctl";

const char* Usage() {
  return "usage: mfns-paramctl COMMAND [options]\n"
         "  install BLOB|-     install a parameter blob (from a file, or stdin with -) in the inactive slot\n"
         "  show               print the active blob (generation, rig id, size, CRC, cameras, beacons) and the other slot\n"
         "  verify             check both slots; exit 1 if none is valid or the newest one is corrupt\n"
         "  rollback           make the other valid slot active\n"
         "options:\n"
         "  --store DIR        parameter store directory (default /var/lib/mfns/params)\n"
         "  --force            install: accept a generation not newer than the active one\n"
         "  --allow-rig-change install: accept a blob for another rig id than the active one\n"
         "  --pid-file FILE    install/rollback: signal the mfns-navd named there (default /run/mfns-navd.pid)\n"
         "  --no-signal        install/rollback: do not signal mfns-navd (it still reloads by inotify)\n"
         "  --rig-id ID        verify: the active blob must be for this rig id\n"
         "  --help             this text\n";
}

enum : int { kStore = 1000, kForce, kAllowRig, kPidFile, kNoSignal, kRigId, kHelp };

const option kLongOptions[] = {
    {"store", required_argument, nullptr, kStore},   {"force", no_argument, nullptr, kForce},
    {"allow-rig-change", no_argument, nullptr, kAllowRig},
    {"pid-file", required_argument, nullptr, kPidFile}, {"no-signal", no_argument, nullptr, kNoSignal},
    {"rig-id", required_argument, nullptr, kRigId},  {"help", no_argument, nullptr, kHelp},
    {nullptr, 0, nullptr, 0},
};

// Static storage: no heap, and no 40 KB on the stack.
ParamStore g_store;
std::array<std::uint8_t, limits::kMaxBlobBytes + 1> g_blob;
Rig g_rig;

// Text a user gave (an argument) on f, control characters escaped (a newline as \n, others as
// \xHH) so that a message stays one line (found by host_cli_fuzz).
void PutOneLine(std::FILE* f, const char* text) {
  for (const char* p = text; *p != '\0'; ++p) {
    const auto c = static_cast<unsigned char>(*p);
    if (c == '\n') {
      std::fputs("\\n", f);
    } else if (c < 0x20 || c == 0x7f) {
      std::fprintf(f, "\\x%02x", c);
    } else {
      std::fputc(c, f);
    }
  }
}

// One line "mfns-paramctl: <what> <detail>" on err (detail through PutOneLine); returns the
// exit code 1.
int Fail(std::FILE* err, const char* what, const char* detail = "") {
  std::fprintf(err, "%s: %s", kTool, what);
  PutOneLine(err, detail);
  std::fputc('\n', err);
  return 1;
}

}  // namespace

bool ParseParamctlArgs(int argc, char** argv, ParamctlOptions* o, std::FILE* err) {
  if (argc < 2) {
    Fail(err, "missing command (install, show, verify, rollback; --help)");
    return false;
  }
  if (std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0) {
    o->help = true;
    return true;
  }
  o->command = argv[1];
  if (std::strcmp(o->command, "install") != 0 && std::strcmp(o->command, "show") != 0 &&
      std::strcmp(o->command, "verify") != 0 && std::strcmp(o->command, "rollback") != 0) {
    std::fprintf(err, "%s: unknown command '", kTool);
    PutOneLine(err, o->command);
    std::fputs("' (install, show, verify, rollback; --help)\n", err);
    return false;
  }
  optind = 0;  // glibc: full re-initialisation (RunParamctl may run more than once)
  opterr = 0;
  const int sub_argc = argc - 1;
  char** sub_argv = argv + 1;
  for (int guard = 0; guard <= sub_argc; ++guard) {
    const int c = getopt_long(sub_argc, sub_argv, "h", kLongOptions, nullptr);
    if (c == -1) break;
    switch (c) {
      case kStore: o->store = optarg; break;
      case kForce: o->force = true; break;
      case kAllowRig: o->allow_rig_change = true; break;
      case kPidFile: o->pid_file = optarg; break;
      case kNoSignal: o->signal = false; break;
      case kRigId: o->rig_id = optarg; break;
      case 'h':
      case kHelp: o->help = true; return true;
      default:
        Fail(err, "unknown option or missing value: ", sub_argv[optind - 1]);
        return false;
    }
  }
  for (; optind < sub_argc; ++optind) {
    const char* arg = sub_argv[optind];
    if (std::strcmp(o->command, "install") == 0 && o->blob == nullptr) {
      o->blob = arg;
    } else {
      Fail(err, "unexpected argument: ", arg);
      return false;
    }
  }
  if (std::strcmp(o->command, "install") == 0 && o->blob == nullptr) {
    Fail(err, "install: missing BLOB argument (a file, or - for stdin)");
    return false;
  }
  return true;
}

namespace {

// Reads the blob into g_blob; returns its size, or -1 after a one-line error.
long ReadBlob(const char* path, int stdin_fd, std::FILE* err) {  // NOLINT(runtime/int)
  const bool from_stdin = std::strcmp(path, "-") == 0;
  // A named blob must be a regular file: a FIFO would block the install (stdin is "-").
  bool not_regular = false;
  const int fd = from_stdin ? stdin_fd : OpenRegularForRead(DefaultStoreIo(), path, &not_regular);
  if (fd < 0) {
    std::fprintf(err, "%s: cannot read blob %s: %s\n", kTool, path,
                 not_regular ? "not a regular file (use - for stdin)" : std::strerror(errno));
    return -1;
  }
  const ssize_t got = ReadAll(DefaultStoreIo(), fd, g_blob.data(), g_blob.size());
  const int saved = errno;
  if (!from_stdin) ::close(fd);
  if (got < 0) {
    std::fprintf(err, "%s: cannot read blob %s: %s\n", kTool, from_stdin ? "from stdin" : path, std::strerror(saved));
    return -1;
  }
  if (static_cast<std::size_t>(got) > limits::kMaxBlobBytes) {
    std::fprintf(err, "%s: refused: blob larger than %zu bytes (limits::kMaxBlobBytes)\n", kTool,
                 limits::kMaxBlobBytes);
    return -1;
  }
  return static_cast<long>(got);  // NOLINT(runtime/int)
}

const char* ActiveSuffix(const StoreSnapshot& snap, char* buf, std::size_t n) {
  if (snap.active < 0) {
    std::snprintf(buf, n, "no valid blob is active");
  } else {
    const SlotReport& r = snap.slots[static_cast<std::size_t>(snap.active)];
    std::snprintf(buf, n, "generation %llu (%s) still active", static_cast<unsigned long long>(r.info.generation),
                  SlotFileName(snap.active));
  }
  return buf;
}

void TellNavd(const ParamctlOptions& o, std::FILE* out, std::FILE* err) {
  if (!o.signal) return;
  int pid = 0;
  const SignalStatus s = SignalReload(o.pid_file, kNavdProcessName, &pid);
  switch (s) {
    case SignalStatus::kSignalled:
      std::fprintf(out, "reload: signalled mfns-navd (pid %d)\n", pid);
      return;
    case SignalStatus::kNoPidFile:
      std::fprintf(out, "reload: no %s (mfns-navd not running; it loads the newest blob at start)\n", o.pid_file);
      return;
    case SignalStatus::kBadPidFile:
    case SignalStatus::kNotRunning:
    case SignalStatus::kNotNavd:
    case SignalStatus::kKillFailed:
      std::fprintf(err, "%s: warning: did not signal mfns-navd: %s: %s (pid %d); a running navd still reloads by inotify\n",
                   kTool, o.pid_file, ToString(s), pid);
      return;
  }
}

int Install(const ParamctlOptions& o, int stdin_fd, std::FILE* out, std::FILE* err) {
  const long size = ReadBlob(o.blob, stdin_fd, err);  // NOLINT(runtime/int)
  if (size < 0) return 1;
  StoreError mkdir_err;
  if (g_store.CreateDirectory(&mkdir_err) != StoreStatus::kOk) {
    std::fprintf(err, "%s: cannot create store %s: %s\n", kTool, o.store, std::strerror(mkdir_err.error));
    return 1;
  }
  InstallOptions opt;
  opt.force = o.force;
  opt.allow_rig_change = o.allow_rig_change;
  InstallReport rep;
  const StoreStatus s = g_store.Install({g_blob.data(), static_cast<std::size_t>(size)}, opt, &rep);
  char active[128];
  const unsigned long long new_gen = rep.new_info.generation;  // NOLINT(runtime/int)
  const unsigned long long old_gen = rep.old_info.generation;  // NOLINT(runtime/int)
  switch (s) {
    case StoreStatus::kOk:
      std::fprintf(out, "installed generation %llu (rig %s, %ld bytes) in %s", new_gen, rep.new_info.rig_id.data(),
                   size, SlotFileName(rep.slot));
      if (rep.had_active) {
        std::fprintf(out, "; previous generation %llu in %s", old_gen, SlotFileName(rep.old_slot));
      }
      std::fputc('\n', out);
      TellNavd(o, out, err);
      return 0;
    case StoreStatus::kBlobTooLarge:
    case StoreStatus::kCorruptBlob:
      std::fprintf(err, "%s: refused: corrupt blob: %s; %s\n", kTool, ToString(rep.blob_status),
                   ActiveSuffix(rep.after, active, sizeof active));
      return 1;
    case StoreStatus::kRigIdMismatch:
      std::fprintf(err, "%s: refused: blob is for rig '%s' but the active blob is for rig '%s' (--allow-rig-change to replace it); %s\n",
                   kTool, rep.new_info.rig_id.data(), rep.old_info.rig_id.data(),
                   ActiveSuffix(rep.after, active, sizeof active));
      return 1;
    case StoreStatus::kStaleGeneration:
      std::fprintf(err, "%s: refused: generation %llu is not newer than the active generation %llu (--force to install it anyway); %s\n",
                   kTool, new_gen, old_gen, ActiveSuffix(rep.after, active, sizeof active));
      return 1;
    case StoreStatus::kNotFound:
      std::fprintf(err, "%s: no store directory %s\n", kTool, o.store);
      return 1;
    case StoreStatus::kVerifyFailed:
      std::fprintf(err, "%s: install failed: %s read back differs from the blob; %s\n", kTool,
                   SlotFileName(rep.slot), ActiveSuffix(rep.after, active, sizeof active));
      return 1;
    case StoreStatus::kIoError:
      std::fprintf(err, "%s: install failed: %s: %s; %s\n", kTool, ToString(rep.io.step), std::strerror(rep.io.error),
                   ActiveSuffix(rep.after, active, sizeof active));
      return 1;
    case StoreStatus::kBusy:
      std::fprintf(err, "%s: install failed: %s (%s); %s\n", kTool, ToString(s), o.store,
                   ActiveSuffix(rep.after, active, sizeof active));
      return 1;
    case StoreStatus::kTooFewBeacons:
      std::fprintf(err, "%s: refused: the blob maps %d beacons, mfns-navd needs at least %d; %s\n", kTool,
                   rep.new_beacons, limits::kMinNavBeacons, ActiveSuffix(rep.after, active, sizeof active));
      return 1;
    case StoreStatus::kBadPath:
    case StoreStatus::kNoValidBlob:
    case StoreStatus::kNoRollbackTarget:
    case StoreStatus::kCount:
      break;
  }
  std::fprintf(err, "%s: install failed: %s\n", kTool, ToString(s));
  return 1;
}

void PrintSlotLine(std::FILE* out, const char* key, int slot, const SlotReport& r) {
  std::fprintf(out, "%s: %s %s", key, SlotFileName(slot), ToString(r.state));
  switch (r.state) {
    case SlotState::kValid:
      std::fprintf(out, " generation %llu rig %s bytes %zu payload_crc32 0x%08x", 
                   static_cast<unsigned long long>(r.info.generation), r.info.rig_id.data(), r.bytes,
                   r.info.payload_crc32);
      break;
    case SlotState::kInvalid:
      std::fprintf(out, " (%s)", ToString(r.blob_status));
      if (r.header_valid) {
        std::fprintf(out, " header generation %llu", static_cast<unsigned long long>(r.info.generation));
      }
      break;
    case SlotState::kUnreadable:
      std::fprintf(out, " (%s)", std::strerror(r.error));
      break;
    case SlotState::kMissing:
    case SlotState::kTooLarge:
    case SlotState::kNotRegular:
      break;
  }
  std::fputc('\n', out);
}

int Show(const ParamctlOptions& o, std::FILE* out, std::FILE* err) {
  StoreSnapshot snap;
  BlobInfo info;
  const StoreStatus s = g_store.Load(nullptr, &g_rig, &info, &snap);
  std::fprintf(out, "store: %s\n", o.store);
  if (s == StoreStatus::kNotFound || s == StoreStatus::kIoError || s == StoreStatus::kBadPath) {
    std::fprintf(err, "%s: cannot open store %s: %s\n", kTool, o.store,
                 g_store.scan_error().error != 0 ? std::strerror(g_store.scan_error().error) : ToString(s));
    return 1;
  }
  if (s != StoreStatus::kOk) {
    std::fprintf(out, "active: none\n");
    for (int i = 0; i < kNumSlots; ++i) PrintSlotLine(out, "slot", i, snap.slots[static_cast<std::size_t>(i)]);
    char why[256];
    DescribeSnapshot(snap, why, sizeof why);
    std::fprintf(err, "%s: no valid blob in %s: %s\n", kTool, o.store, why);
    return 1;
  }
  const SlotReport& a = snap.slots[static_cast<std::size_t>(snap.active)];
  std::fprintf(out, "active: %s\n", SlotFileName(snap.active));
  std::fprintf(out, "generation: %llu\n", static_cast<unsigned long long>(info.generation));
  std::fprintf(out, "rig_id: %s\n", info.rig_id.data());
  std::fprintf(out, "format_version: %u\n", static_cast<unsigned>(info.format_version));
  std::fprintf(out, "bytes: %zu\n", a.bytes);
  std::fprintf(out, "payload_crc32: 0x%08x\n", info.payload_crc32);
  std::fprintf(out, "cameras: %d (", g_rig.num_cameras);
  for (int k = 0; k < g_rig.num_cameras; ++k) {
    const RigCamera& c = g_rig.cameras[static_cast<std::size_t>(k)];
    std::fprintf(out, "%s%s %dx%d", k == 0 ? "" : ", ", c.name.data(), c.intrinsics.width, c.intrinsics.height);
  }
  std::fprintf(out, ")\n");
  std::fprintf(out, "beacons: %d\n", g_rig.num_beacons);
  std::fprintf(out, "sigma: %s\n", g_rig.has_sigma ? "present" : "absent");
  const int other = 1 - snap.active;
  PrintSlotLine(out, "other", other, snap.slots[static_cast<std::size_t>(other)]);
  return 0;
}

int Verify(const ParamctlOptions& o, std::FILE* out, std::FILE* err) {
  StoreSnapshot snap;
  const StoreStatus s = g_store.Scan(o.rig_id, &snap);
  if (s == StoreStatus::kNotFound || s == StoreStatus::kIoError || s == StoreStatus::kBadPath) {
    std::fprintf(err, "%s: cannot open store %s: %s\n", kTool, o.store,
                 g_store.scan_error().error != 0 ? std::strerror(g_store.scan_error().error) : ToString(s));
    return 1;
  }
  for (int i = 0; i < kNumSlots; ++i) {
    PrintSlotLine(out, i == snap.active ? "active" : "slot", i, snap.slots[static_cast<std::size_t>(i)]);
  }
  char why[256];
  DescribeSnapshot(snap, why, sizeof why);
  if (s != StoreStatus::kOk) {
    std::fprintf(err, "%s: verify: no valid blob%s%s: %s\n", kTool, o.rig_id != nullptr ? " for rig " : "",
                 o.rig_id != nullptr ? o.rig_id : "", why);
    return 1;
  }
  const std::uint64_t active_gen = snap.slots[static_cast<std::size_t>(snap.active)].info.generation;
  for (int i = 0; i < kNumSlots; ++i) {
    const SlotReport& r = snap.slots[static_cast<std::size_t>(i)];
    if (r.state == SlotState::kUnreadable) {
      std::fprintf(err, "%s: verify: %s unreadable: %s\n", kTool, SlotFileName(i), std::strerror(r.error));
      return 1;
    }
    if (r.state == SlotState::kNotRegular) {  // in a slot's place: a store someone damaged
      std::fprintf(err, "%s: verify: %s/%s is not a regular file (skipped)\n", kTool, o.store, SlotFileName(i));
      return 1;
    }
    // The newest install is corrupt: the flyer runs an older calibration than intended.
    if (r.state == SlotState::kInvalid && r.header_valid && r.blob_status != BlobStatus::kRigIdMismatch &&
        r.info.generation > active_gen) {
      std::fprintf(err, "%s: verify: %s holds generation %llu but is corrupt (%s); generation %llu is active\n", kTool,
                   SlotFileName(i), static_cast<unsigned long long>(r.info.generation), ToString(r.blob_status),
                   static_cast<unsigned long long>(active_gen));
      return 1;
    }
  }
  std::fprintf(out, "ok: generation %llu active in %s\n", static_cast<unsigned long long>(active_gen),
               SlotFileName(snap.active));
  return 0;
}

int Rollback(const ParamctlOptions& o, std::FILE* out, std::FILE* err) {
  RollbackReport rep;
  const StoreStatus s = g_store.Rollback(&rep);
  char why[256];
  DescribeSnapshot(rep.before, why, sizeof why);
  switch (s) {
    case StoreStatus::kOk: {
      const SlotReport& to = rep.after.slots[static_cast<std::size_t>(rep.to_slot)];
      const SlotReport& from = rep.before.slots[static_cast<std::size_t>(rep.from_slot)];
      std::fprintf(out, "rolled back to generation %llu in %s (generation %llu set aside as %s.rolled-back)\n",
                   static_cast<unsigned long long>(to.info.generation), SlotFileName(rep.to_slot),
                   static_cast<unsigned long long>(from.info.generation), SlotFileName(rep.from_slot));
      TellNavd(o, out, err);
      return 0;
    }
    case StoreStatus::kNoValidBlob:
      std::fprintf(err, "%s: refused: nothing is active to roll back from: %s\n", kTool, why);
      return 1;
    case StoreStatus::kNoRollbackTarget:
      std::fprintf(err, "%s: refused: no other valid slot to roll back to: %s\n", kTool, why);
      return 1;
    case StoreStatus::kIoError:
      std::fprintf(err, "%s: rollback failed: %s: %s\n", kTool, ToString(rep.io.step), std::strerror(rep.io.error));
      return 1;
    default:
      std::fprintf(err, "%s: rollback failed: %s (%s)\n", kTool, ToString(s), o.store);
      return 1;
  }
}

}  // namespace

int RunParamctl(int argc, char** argv, int stdin_fd, std::FILE* out, std::FILE* err) {
  ParamctlOptions o;
  if (!ParseParamctlArgs(argc, argv, &o, err)) return 1;
  if (o.help) {
    std::fputs(Usage(), out);
    return 0;
  }
  if (g_store.SetDirectory(o.store) != StoreStatus::kOk) {
    return Fail(err, "--store path empty or longer than 255 characters");
  }
  int rc = 1;
  if (std::strcmp(o.command, "install") == 0) rc = Install(o, stdin_fd, out, err);
  if (std::strcmp(o.command, "show") == 0) rc = Show(o, out, err);
  if (std::strcmp(o.command, "verify") == 0) rc = Verify(o, out, err);
  if (std::strcmp(o.command, "rollback") == 0) rc = Rollback(o, out, err);
  std::fflush(out);
  std::fflush(err);
  return rc;
}

}  // namespace mfns::fw
