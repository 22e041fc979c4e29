// libFuzzer target for the parameter store's directory scan (firmware/modules/params): whatever
// the slot files hold, Scan and Load give a typed status and never crash; what Load takes is a
// valid rig from the newest valid slot, the one Scan names; and a newer valid blob installed
// into that store becomes active without touching the slot that was active (the store's
// promise that a bad or hostile slot never costs the good one).
//
// The store lives in the power-cut model's in-memory directory (testing/sim_fs.h): no disk,
// thousands of stores a second. Input: byte 0 = flags (bit 0/1: slot a/b present, bit 2/3:
// repair its length and CRCs first, bit 4: a stale slot-b.bin.1.tmp, bit 5: a
// slot-a.bin.rolled-back), bytes 1-2 = length of slot a's bytes, then slot a's bytes, then
// slot b's.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "common/blob/param_blob.h"
#include "common/rig/paper_rig.h"
#include "firmware/modules/params/param_store.h"
#include "firmware/modules/params/testing/sim_fs.h"
#include "tests/fuzz/blob_repair.h"

namespace {

using mfns::fw::ParamStore;
using mfns::fw::StoreStatus;

constexpr char kDir[] = "/store";

std::vector<std::uint8_t> PaperBlob(std::uint64_t generation) {
  std::vector<std::uint8_t> out(mfns::limits::kMaxBlobBytes);
  std::size_t written = 0;
  if (mfns::EncodeParamBlob(mfns::PaperRig(), generation, out, &written) != mfns::BlobStatus::kOk) __builtin_trap();
  out.resize(written);
  return out;
}

void Check(bool ok) {
  if (!ok) __builtin_trap();
}

// Load agrees with Scan and takes a valid rig from the newest valid slot.
void CheckLoad(ParamStore& store, StoreStatus loaded, const mfns::Rig& rig, const mfns::BlobInfo& info,
               const mfns::fw::StoreSnapshot& snap) {
  Check(mfns::fw::ToString(loaded) != nullptr);
  if (loaded != StoreStatus::kOk) {
    Check(snap.active < 0);
    return;
  }
  Check(snap.active >= 0 && snap.active < mfns::fw::kNumSlots);
  Check(mfns::ValidateRig(rig) == mfns::RigStatus::kOk);
  Check(snap.slots[static_cast<std::size_t>(snap.active)].state == mfns::fw::SlotState::kValid);
  Check(info.generation == snap.slots[static_cast<std::size_t>(snap.active)].info.generation);
  for (const auto& slot : snap.slots)
    if (slot.state == mfns::fw::SlotState::kValid) Check(slot.info.generation <= info.generation);
  mfns::fw::StoreSnapshot scanned;
  Check(store.Scan(nullptr, &scanned) == StoreStatus::kOk && scanned.active == snap.active);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 3) return 0;
  const std::uint8_t flags = data[0];
  const std::size_t rest = size - 3;
  const std::size_t len_a = std::min<std::size_t>(rest, data[1] | (static_cast<std::size_t>(data[2]) << 8));
  std::vector<std::uint8_t> a(data + 3, data + 3 + len_a), b(data + 3 + len_a, data + size);
  if ((flags & 4u) != 0) mfns::fuzz::RepairBlob(a);
  if ((flags & 8u) != 0) mfns::fuzz::RepairBlob(b);

  mfns::fw::testing::SimFs fs(kDir);
  if ((flags & 1u) != 0) fs.PutFile("slot-a.bin", a);
  if ((flags & 2u) != 0) fs.PutFile("slot-b.bin", b);
  if ((flags & 16u) != 0) fs.PutFile("slot-b.bin.1.tmp", a);
  if ((flags & 32u) != 0) fs.PutFile("slot-a.bin.rolled-back", b);

  ParamStore store(&fs);
  Check(store.SetDirectory(kDir) == StoreStatus::kOk);
  static mfns::Rig rig;
  mfns::BlobInfo info;
  mfns::fw::StoreSnapshot snap;
  const StoreStatus loaded = store.Load(nullptr, &rig, &info, &snap);
  CheckLoad(store, loaded, rig, info, snap);

  // A newer valid blob (any rig id may follow: allow_rig_change) goes in beside the active one.
  const bool had = loaded == StoreStatus::kOk;
  if (had && info.generation == UINT64_MAX) return 0;
  const std::uint64_t gen = had ? info.generation + 1 : 1;
  const char* old_name = had ? mfns::fw::SlotFileName(snap.active) : nullptr;
  const std::vector<std::uint8_t> old_bytes = had ? fs.FileBytes(old_name) : std::vector<std::uint8_t>{};
  const std::vector<std::uint8_t> blob = PaperBlob(gen);
  mfns::fw::InstallOptions options;
  options.allow_rig_change = true;
  mfns::fw::InstallReport report;
  Check(store.Install(blob, options, &report) == StoreStatus::kOk);
  if (had) Check(fs.FileBytes(old_name) == old_bytes);
  const StoreStatus again = store.Load(nullptr, &rig, &info, &snap);
  CheckLoad(store, again, rig, info, snap);
  Check(again == StoreStatus::kOk && info.generation == gen);
  return 0;
}
