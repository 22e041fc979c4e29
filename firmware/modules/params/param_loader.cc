#include "firmware/modules/params/param_loader.h"

#include <fcntl.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace mfns::fw {

ParamLoader::ParamLoader(StoreIo* io) : io_(io != nullptr ? io : DefaultStoreIo()), store_(io_) {}

StoreStatus ParamLoader::Open(const char* path, const char* expected_rig_id, Rig* rig, BlobInfo* info,
                              bool force_stat_watch) {
  watcher_.Stop();
  is_store_ = false;
  snapshot_ = StoreSnapshot{};
  last_errno_ = 0;
  path_[0] = '\0';
  const std::size_t len = path != nullptr ? strnlen(path, path_.size()) : 0;
  if (len == 0 || len >= path_.size()) return last_ = StoreStatus::kBadPath;
  std::memcpy(path_.data(), path, len + 1);
  ExpectRigId(expected_rig_id);

  const int fd = io_->Open(path_.data(), O_RDONLY | O_DIRECTORY | O_NONBLOCK | O_CLOEXEC, 0);
  if (fd >= 0) {
    io_->Close(fd);
    is_store_ = true;
    store_.SetDirectory(path_.data());
    // Watch first, load second: a change in between is seen by the next Changed().
    const char* names[kNumSlots] = {SlotFileName(0), SlotFileName(1)};
    watcher_.Start(path_.data(), names, kNumSlots, force_stat_watch);
    return Reload(rig, info);
  }
  if (errno != ENOTDIR) {
    last_errno_ = errno;
    return last_ = (errno == ENOENT ? StoreStatus::kNotFound : StoreStatus::kIoError);
  }
  // A blob file: watch its name in its directory.
  std::array<char, limits::kMaxPathChars + 1> dir{};
  std::memcpy(dir.data(), path_.data(), len + 1);
  char* slash = std::strrchr(dir.data(), '/');
  const char* base = path_.data();
  if (slash == nullptr) {
    std::snprintf(dir.data(), dir.size(), ".");
  } else {
    base = path_.data() + (slash - dir.data()) + 1;
    if (slash == dir.data()) slash[1] = '\0'; else *slash = '\0';
  }
  watcher_.Start(dir.data(), &base, 1, force_stat_watch);
  return Reload(rig, info);
}

void ParamLoader::ExpectRigId(const char* id) {
  has_expected_ = id != nullptr;
  expected_.fill('\0');
  // An id longer than any valid one stays longer after truncation here, so it still matches
  // no blob (the decoder compares whole strings).
  if (has_expected_) std::strncpy(expected_.data(), id, expected_.size() - 1);
}

StoreStatus ParamLoader::Reload(Rig* rig, BlobInfo* info) {
  const char* expected = has_expected_ ? expected_.data() : nullptr;
  if (path_[0] == '\0') return last_ = StoreStatus::kBadPath;
  if (is_store_) {
    last_ = store_.Load(expected, rig, info, &snapshot_);
    return last_;
  }
  return last_ = LoadFile(rig, info);
}

StoreStatus ParamLoader::LoadFile(Rig* rig, BlobInfo* info) {
  snapshot_ = StoreSnapshot{};
  SlotReport& r = snapshot_.slots[0];
  bool not_regular = false;
  const int fd = OpenRegularForRead(io_, path_.data(), &not_regular);  // never blocks on a FIFO
  if (fd < 0) {
    if (not_regular) {
      r.state = SlotState::kNotRegular;
      return StoreStatus::kNoValidBlob;
    }
    last_errno_ = errno;
    if (errno == ENOENT) return StoreStatus::kNotFound;
    r.state = SlotState::kUnreadable;
    r.error = errno;
    return StoreStatus::kIoError;
  }
  const ssize_t got = ReadAll(io_, fd, file_bytes_.data(), file_bytes_.size());
  const int read_errno = errno;
  io_->Close(fd);
  if (got < 0) {
    r.state = SlotState::kUnreadable;
    r.error = last_errno_ = read_errno;
    return StoreStatus::kIoError;
  }
  r.bytes = static_cast<std::size_t>(got);
  if (r.bytes > limits::kMaxBlobBytes) {
    r.state = SlotState::kTooLarge;
    r.blob_status = BlobStatus::kTooLarge;
    return StoreStatus::kNoValidBlob;
  }
  const std::span<const std::uint8_t> bytes(file_bytes_.data(), r.bytes);
  r.header_valid = DecodeBlobHeader(bytes, &r.info) == BlobStatus::kOk;
  BlobInfo decoded_info;
  r.blob_status = DecodeParamBlob(bytes, has_expected_ ? expected_.data() : nullptr, rig, &decoded_info);
  if (r.header_valid) r.info = decoded_info;
  if (r.blob_status != BlobStatus::kOk) {
    r.state = SlotState::kInvalid;
    return StoreStatus::kNoValidBlob;
  }
  r.state = SlotState::kValid;
  snapshot_.active = 0;
  if (info != nullptr) *info = decoded_info;
  return StoreStatus::kOk;
}

void ParamLoader::Describe(char* buf, std::size_t n) const {
  if (buf == nullptr || n == 0) return;
  buf[0] = '\0';
  if (last_ == StoreStatus::kBadPath) {
    std::snprintf(buf, n, "--params path empty or longer than %d characters", limits::kMaxPathChars);
    return;
  }
  if (last_ == StoreStatus::kNotFound || (last_ == StoreStatus::kIoError && last_errno_ != 0)) {
    std::snprintf(buf, n, "%s: %s", path_.data(), std::strerror(last_errno_));
    return;
  }
  if (is_store_ && store_.scan_error().step != StoreStep::kNone) {
    std::snprintf(buf, n, "store %s: %s: %s", path_.data(), ToString(store_.scan_error().step),
                  std::strerror(store_.scan_error().error));
    return;
  }
  if (is_store_) {
    const int w = std::snprintf(buf, n, "store %s: ", path_.data());
    if (w > 0 && static_cast<std::size_t>(w) < n) DescribeSnapshot(snapshot_, buf + w, n - static_cast<std::size_t>(w));
    return;
  }
  const SlotReport& r = snapshot_.slots[0];
  switch (r.state) {
    case SlotState::kValid:
      std::snprintf(buf, n, "%s: generation %llu, rig %s", path_.data(),
                    static_cast<unsigned long long>(r.info.generation), r.info.rig_id.data());
      return;
    case SlotState::kInvalid:
      std::snprintf(buf, n, "%s: %s", path_.data(), ToString(r.blob_status));
      return;
    case SlotState::kUnreadable:
      std::snprintf(buf, n, "%s: unreadable: %s", path_.data(), std::strerror(r.error));
      return;
    case SlotState::kNotRegular:
      std::snprintf(buf, n, "%s: not a regular file", path_.data());
      return;
    case SlotState::kMissing:
    case SlotState::kTooLarge:
      std::snprintf(buf, n, "%s: %s", path_.data(), ToString(r.state));
      return;
  }
}

}  // namespace mfns::fw
