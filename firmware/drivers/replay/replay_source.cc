#include "firmware/drivers/replay/replay_source.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string_view>

#include "firmware/drivers/replay/pgm.h"
#include "firmware/lib/monotonic_clock.h"

namespace mfns::fw {
namespace {

constexpr std::uint64_t kNoTime = ~std::uint64_t{0};
constexpr int kFrameDigits = 6;
constexpr std::size_t kFrameFileChars = kFrameDigits + 4;  // "000123.pgm"

// "000123.pgm" -> 123; -1 for any other name.
int FrameNumber(const char* name) {
  if (std::strlen(name) != kFrameFileChars || std::strcmp(name + kFrameDigits, ".pgm") != 0) {
    return -1;
  }
  int v = 0;
  for (int i = 0; i < kFrameDigits; ++i) {
    if (name[i] < '0' || name[i] > '9') return -1;
    v = v * 10 + (name[i] - '0');
  }
  return v;
}

bool ValidName(const char* name) {
  if (name == nullptr || name[0] == '\0') return false;
  if (std::strcmp(name, ".") == 0 || std::strcmp(name, "..") == 0) return false;
  return std::strchr(name, '/') == nullptr;
}

// Appends src to dst[*len]; false when it would not fit (with the NUL) in dst.
template <std::size_t N>
bool Append(std::array<char, N>* dst, int* len, const char* src) {
  const std::size_t n = std::strlen(src);
  if (static_cast<std::size_t>(*len) + n + 1 > N) return false;
  std::memcpy(dst->data() + *len, src, n + 1);
  *len += static_cast<int>(n);
  return true;
}

// Parses an unsigned decimal field; false on empty, non-digit or overflow.
bool ParseU64(std::string_view s, std::uint64_t* v) {
  if (s.empty() || s.size() > 20) return false;
  std::uint64_t r = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
    const std::uint64_t d = static_cast<std::uint64_t>(c - '0');
    if (r > (~std::uint64_t{0} - d) / 10) return false;
    r = r * 10 + d;
  }
  *v = r;
  return true;
}

// Field `index` of a comma-separated line (no quoting: truth.csv holds numbers and names).
std::string_view Field(std::string_view line, int index) {
  for (int i = 0; i < index; ++i) {
    const std::size_t comma = line.find(',');
    if (comma == std::string_view::npos) return {};
    line.remove_prefix(comma + 1);
  }
  return line.substr(0, line.find(','));
}

int ColumnOf(std::string_view header, std::string_view name) {
  for (int i = 0; i < 64; ++i) {  // truth.csv has a handful of columns
    const std::size_t comma = header.find(',');
    if (header.substr(0, comma) == name) return i;
    if (comma == std::string_view::npos) return -1;
    header.remove_prefix(comma + 1);
  }
  return -1;
}

}  // namespace

ReplayConfig ReplayConfigFromRig(const Rig& rig, const char* dir, double frame_rate_hz) {
  ReplayConfig c;
  c.dir = dir;
  c.num_cameras = rig.num_cameras;
  c.frame_rate_hz = frame_rate_hz;
  for (int k = 0; k < limits::kMaxCameras && k < rig.num_cameras; ++k) {
    const RigCamera& cam = rig.cameras[static_cast<unsigned>(k)];
    c.camera_names[static_cast<unsigned>(k)] = cam.name.data();
    c.width[static_cast<unsigned>(k)] = cam.intrinsics.width;
    c.height[static_cast<unsigned>(k)] = cam.intrinsics.height;
  }
  return c;
}

ReplaySource::ReplaySource(const ReplayConfig& config)
    : FrameSource(config.num_cameras), config_(config) {}

void ReplaySource::SetFrameName(Camera* cam, int frame) const {
  char* p = cam->path.data() + cam->name_at;
  for (int i = kFrameDigits - 1; i >= 0; --i) {
    p[i] = static_cast<char>('0' + frame % 10);
    frame /= 10;
  }
  std::memcpy(p + kFrameDigits, ".pgm", 5);
}

SourceStatus ReplaySource::ScanCamera(int k, int* first_frame, int* last_frame) {
  Camera& cam = cams_[static_cast<unsigned>(k)];
  const char* name = config_.camera_names[static_cast<unsigned>(k)];
  if (!ValidName(name)) {
    SetProblem(name != nullptr ? name : "(none)", "camera name empty, too long or with a '/' or '..'");
    return SourceStatus::kBadConfig;
  }
  int len = 0;
  if (!Append(&cam.path, &len, config_.dir) || !Append(&cam.path, &len, "/frames/") ||
      !Append(&cam.path, &len, name)) {
    SetProblem(config_.dir, "path too long");
    return SourceStatus::kBadConfig;
  }
  DIR* d = ::opendir(cam.path.data());
  if (d == nullptr) {
    SetProblem(cam.path.data(), std::strerror(errno));  // camera name and folder: "DIR/frames/x: No such file..."
    return SourceStatus::kOpenFailed;
  }
  *first_frame = -1;
  *last_frame = -1;
  // A folder holds at most kMaxReplayFrames frame files; allow as many other entries.
  for (int i = 0; i < 2 * limits::kMaxReplayFrames; ++i) {
    const dirent* e = ::readdir(d);
    if (e == nullptr) break;
    const int f = FrameNumber(e->d_name);
    if (f < 0) continue;
    if (*first_frame < 0 || f < *first_frame) *first_frame = f;
    if (f > *last_frame) *last_frame = f;
  }
  ::closedir(d);
  if (*first_frame < 0) {  // nothing to replay
    SetProblem(cam.path.data(), "no frames (NNNNNN.pgm) in this camera's folder");
    return SourceStatus::kOpenFailed;
  }
  if (!Append(&cam.path, &len, "/") ||
      static_cast<std::size_t>(len) + kFrameFileChars + 1 > cam.path.size()) {
    SetProblem(cam.path.data(), "path too long");
    return SourceStatus::kBadConfig;
  }
  cam.name_at = len;
  return SourceStatus::kOk;
}

SourceStatus ReplaySource::ReadTruth() {
  std::array<char, limits::kMaxPathChars + 1> path{};
  int len = 0;
  if (!Append(&path, &len, config_.dir) || !Append(&path, &len, "/truth.csv")) {
    SetProblem(config_.dir, "path too long");
    return SourceStatus::kBadConfig;
  }
  t_ns_.assign(static_cast<std::size_t>(num_frames_), kNoTime);
  const int fd = ::open(path.data(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);  // a FIFO must not hang Start
  if (fd < 0) {
    if (errno != ENOENT) {
      SetProblem(path.data(), std::strerror(errno));
      return SourceStatus::kBadConfig;
    }
    if (!(config_.frame_rate_hz > 0.0) || !std::isfinite(config_.frame_rate_hz)) {
      SetProblem(path.data(), "missing, and no frame rate to time the frames by");
      return SourceStatus::kBadConfig;
    }
    has_truth_ = false;
    for (int f = 0; f < num_frames_; ++f) {
      t_ns_[static_cast<std::size_t>(f)] =
          static_cast<std::uint64_t>(std::llround(f * 1e9 / config_.frame_rate_hz));
    }
    return SourceStatus::kOk;
  }
  // Start may allocate: read the whole file, then parse it line by line.
  std::vector<char> text;
  struct stat st {};
  bool ok = ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode);
  if (!ok) SetProblem(path.data(), "not a regular file");
  if (ok) {
    text.resize(static_cast<std::size_t>(st.st_size));
    std::size_t done = 0;
    for (int pass = 0; pass < 1024 && done < text.size(); ++pass) {
      const ssize_t r = ::read(fd, text.data() + done, text.size() - done);
      if (r < 0 && errno == EINTR) continue;
      if (r <= 0) break;
      done += static_cast<std::size_t>(r);
    }
    ok = done == text.size();
  }
  ::close(fd);
  if (!ok && problem_[0] == '\0') SetProblem(path.data(), "read failed");
  if (!ok) return SourceStatus::kBadConfig;

  std::string_view rest(text.data(), text.size());
  int frame_col = -1;
  int t_col = -1;
  bool header = true;
  while (!rest.empty()) {  // every pass consumes at least one character
    const std::size_t nl = rest.find('\n');
    std::string_view line = rest.substr(0, nl);
    rest.remove_prefix(nl == std::string_view::npos ? rest.size() : nl + 1);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty()) continue;
    if (header) {
      frame_col = ColumnOf(line, "frame");
      t_col = ColumnOf(line, "t_ns");
      if (frame_col < 0 || t_col < 0) {
        SetProblem(path.data(), "the header has no frame or no t_ns column");
        return SourceStatus::kBadConfig;
      }
      header = false;
      continue;
    }
    std::uint64_t frame = 0;
    std::uint64_t t = 0;
    if (!ParseU64(Field(line, frame_col), &frame) || !ParseU64(Field(line, t_col), &t) ||
        t == kNoTime) {
      SetProblem(path.data(), "a frame or t_ns that is not a whole number");
      return SourceStatus::kBadConfig;
    }
    if (frame >= static_cast<std::uint64_t>(num_frames_)) continue;  // no images for it
    std::uint64_t& slot = t_ns_[static_cast<std::size_t>(frame)];
    if (slot != kNoTime) {
      SetProblem(path.data(), "a frame listed twice");
      return SourceStatus::kBadConfig;
    }
    slot = t;
  }
  if (header) {
    SetProblem(path.data(), "empty");
    return SourceStatus::kBadConfig;
  }
  has_truth_ = true;
  return SourceStatus::kOk;
}

void ReplaySource::SetProblem(const char* path, const char* why) {
  std::snprintf(problem_.data(), problem_.size(), "%s: %s", path, why);
}

SourceStatus ReplaySource::SizeBuffer(int k, int first_frame) {
  Camera& cam = cams_[static_cast<unsigned>(k)];
  SetFrameName(&cam, first_frame);
  PgmHeader h;
  const PgmStatus ps = ReadPgmHeader(cam.path.data(), &h);
  if (ps != PgmStatus::kOk) {
    SetProblem(cam.path.data(), ToString(ps));
    return SourceStatus::kBadFrame;
  }
  const int want_w = config_.width[static_cast<unsigned>(k)];
  const int want_h = config_.height[static_cast<unsigned>(k)];
  if ((want_w != 0 && h.width != want_w) || (want_h != 0 && h.height != want_h) ||
      h.raster_bytes > limits::kMaxImageBytes) {
    char why[96];
    if (h.raster_bytes > limits::kMaxImageBytes)
      std::snprintf(why, sizeof(why), "%dx%d, above the %zu-byte image limit", h.width, h.height,
                    static_cast<std::size_t>(limits::kMaxImageBytes));
    else
      std::snprintf(why, sizeof(why), "%dx%d, the rig's camera is %dx%d", h.width, h.height, want_w, want_h);
    SetProblem(cam.path.data(), why);
    return SourceStatus::kFormatRefused;
  }
  cam.buffer.assign(h.raster_bytes, 0);
  cam.width = h.width;
  cam.height = h.height;
  cam.format = h.format;
  return SourceStatus::kOk;
}

SourceStatus ReplaySource::Start() {
  Stop();
  problem_[0] = '\0';
  ResetCounters();
  pace_t0_ = pace_wall0_ = 0;
  has_truth_ = false;
  num_frames_ = 0;
  if (config_.dir == nullptr || config_.dir[0] == '\0' || config_.num_cameras < 1 ||
      config_.num_cameras > limits::kMaxCameras) {
    char why[64];
    std::snprintf(why, sizeof(why), "no replay folder, or a camera count outside 1..%d", limits::kMaxCameras);
    SetProblem(config_.dir != nullptr && config_.dir[0] != '\0' ? config_.dir : "(no folder)", why);
    return SourceStatus::kBadConfig;
  }
  std::array<int, limits::kMaxCameras> first{};
  for (int k = 0; k < num_cameras(); ++k) {
    cams_[static_cast<unsigned>(k)] = Camera{};
    int last = -1;
    const SourceStatus s = ScanCamera(k, &first[static_cast<unsigned>(k)], &last);
    if (s != SourceStatus::kOk) return s;
    if (last + 1 > num_frames_) num_frames_ = last + 1;
  }
  SourceStatus s = ReadTruth();
  if (s != SourceStatus::kOk) return s;
  for (int k = 0; k < num_cameras(); ++k) {
    s = SizeBuffer(k, first[static_cast<unsigned>(k)]);
    if (s != SourceStatus::kOk) return s;
  }
  started_ = true;
  return SourceStatus::kOk;
}

SourceStatus ReplaySource::Acquire(int camera, int /*timeout_ms*/, FrameView* out) {
  if (!started_) return SourceStatus::kNotStarted;
  if (!ValidCamera(camera)) return SourceStatus::kBadCamera;
  Camera& cam = cams_[static_cast<unsigned>(camera)];
  if (cam.held) return SourceStatus::kBusy;
  if (cam.next >= num_frames_) return SourceStatus::kEndOfStream;
  SourceCounters& c = mutable_counters(camera);
  const int frame = cam.next++;

  SetFrameName(&cam, frame);
  PgmHeader h;
  const PgmStatus ps = ReadPgm(cam.path.data(), cam.buffer.data(), cam.buffer.size(), &h);
  if (ps == PgmStatus::kNotFound) {
    ++c.missing_files;
    return SourceStatus::kMissingFrame;
  }
  if (ps != PgmStatus::kOk || h.width != cam.width || h.height != cam.height ||
      h.format != cam.format) {
    ++c.bad_files;
    SetProblem(cam.path.data(), ps != PgmStatus::kOk ? ToString(ps) : "size or format differs from the first frame's");
    return SourceStatus::kBadFrame;
  }
  const std::uint64_t t = t_ns_[static_cast<std::size_t>(frame)];
  if (t == kNoTime) {
    ++c.unknown_clock;
    return SourceStatus::kDropped;
  }
  if (config_.realtime) Pace(t);
  out->data = cam.buffer.data();
  out->width = cam.width;
  out->height = cam.height;
  out->stride_bytes = cam.width * BytesPerPixel(cam.format);
  out->format = cam.format;
  out->t_capture_ns = t;
  out->t_source = TimestampSource::kTruth;
  out->sequence = static_cast<std::uint32_t>(frame);
  out->camera = camera;
  cam.held = true;
  ++c.frames;
  return SourceStatus::kOk;
}

// Sleeps until the wall clock has advanced from the first paced frame as much as the recorded
// time has (the other cameras of a frame set find that time passed: no second sleep). A
// recorded time before the first is not waited for.
void ReplaySource::Pace(std::uint64_t t_ns) {
  const std::uint64_t wall = MonotonicNs();
  if (pace_wall0_ == 0) {
    pace_t0_ = t_ns;
    pace_wall0_ = wall;
    return;
  }
  if (t_ns <= pace_t0_) return;
  const std::uint64_t due = pace_wall0_ + (t_ns - pace_t0_);
  if (due > wall) SleepUntilMonotonicNs(due);
}

void ReplaySource::Release(int camera) {
  if (ValidCamera(camera)) cams_[static_cast<unsigned>(camera)].held = false;
}

SourceStatus ReplaySource::Reset(int camera) {
  if (!started_) return SourceStatus::kNotStarted;
  if (!ValidCamera(camera)) return SourceStatus::kBadCamera;
  cams_[static_cast<unsigned>(camera)].held = false;
  return SourceStatus::kOk;
}

void ReplaySource::Stop() {
  started_ = false;
  for (Camera& cam : cams_) cam.held = false;
}

}  // namespace mfns::fw
