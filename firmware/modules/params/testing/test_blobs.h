// Test support: blobs made from the paper rig with a chosen generation and rig id, a temporary
// directory that removes itself, and whole-file helpers. Test code: allocates freely.
#pragma once

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "common/blob/param_blob.h"
#include "common/rig/paper_rig.h"
#include "firmware/modules/params/param_store.h"

namespace mfns::fw {
inline void PrintTo(StoreStatus s, std::ostream* os) { *os << ToString(s); }
inline void PrintTo(SlotState s, std::ostream* os) { *os << ToString(s); }
}  // namespace mfns::fw

namespace mfns::fw::testing {

// The paper rig as a blob; rig_id replaces the paper rig's id; beacons trims the beacon map
// (so blobs of one generation can differ in content and size).
inline std::vector<std::uint8_t> MakeBlob(std::uint64_t generation, const char* rig_id = kPaperRigId,
                                          int beacons = -1) {
  Rig rig = PaperRig();
  rig.rig_id.fill('\0');
  for (std::size_t i = 0; rig_id[i] != '\0' && i + 1 < rig.rig_id.size(); ++i) rig.rig_id[i] = rig_id[i];
  if (beacons >= 0 && beacons < rig.num_beacons) rig.num_beacons = beacons;
  std::vector<std::uint8_t> out(limits::kMaxBlobBytes);
  std::size_t written = 0;
  const BlobStatus s = EncodeParamBlob(rig, generation, out, &written);
  EXPECT_EQ(s, BlobStatus::kOk) << ToString(s);
  out.resize(written);
  return out;
}

// The generation of the blob a store opens to (0 when none is valid).
inline std::uint64_t ActiveGeneration(const StoreSnapshot& snap) {
  return snap.active < 0 ? 0 : snap.slots[static_cast<std::size_t>(snap.active)].info.generation;
}

// A directory on a RAM file system when there is one (/dev/shm): real syscalls without the
// disk's fsync latency, for tests that repeat an install hundreds of times.
inline std::string FastTempBase() {
  return ::access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "";
}

class TempDir {
 public:
  // base: parent directory; "" = $TMPDIR or /tmp.
  explicit TempDir(const std::string& base = "") {
    const char* env = std::getenv("TMPDIR");
    const std::string parent = !base.empty() ? base : (env != nullptr && env[0] != '\0' ? env : "/tmp");
    std::string templ = parent + "/mfns-params-XXXXXX";
    std::vector<char> buf(templ.begin(), templ.end());
    buf.push_back('\0');
    const char* made = ::mkdtemp(buf.data());
    EXPECT_NE(made, nullptr);
    path_ = made != nullptr ? made : "";
  }
  ~TempDir() {
    std::error_code ec;
    if (!path_.empty()) std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  std::string operator/(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

inline void WriteBytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

inline std::vector<std::uint8_t> ReadBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

}  // namespace mfns::fw::testing
