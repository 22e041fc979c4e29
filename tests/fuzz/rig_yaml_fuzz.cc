// libFuzzer target for the rig file reader (host/rigio): whatever the text, ParseRigYaml returns
// a rig or throws UserError with a one-line message naming the source (rig.yaml:LINE: field:
// why); any other exception, a crash, ASan or UBSan report is a finding. A rig that parses is
// valid (ValidateRig), and the file written from it reads back as the same rig (within 1e-12:
// the writer's 15 digits; euler_deg is derived from C_k_b for people and may move in its last
// digit near phi = 90 deg, so the rig is compared, not the text).
#include <cstddef>
#include <cstdint>
#include <algorithm>
#include <cmath>
#include <string>

#include "common/rig/rig.h"
#include "host/rigio/rig_yaml.h"

namespace {

bool Near(double a, double b) { return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(a)); }

template <typename A, typename B>
bool AllNear(const A& a, const B& b) {
  for (Eigen::Index i = 0; i < a.size(); ++i)
    if (!Near(a.data()[i], b.data()[i])) return false;
  return true;
}

bool SameRig(const mfns::Rig& a, const mfns::Rig& b) {
  if (a.rig_id != b.rig_id || a.num_cameras != b.num_cameras || a.num_beacons != b.num_beacons ||
      a.has_facing != b.has_facing || a.has_sigma != b.has_sigma || !Near(a.beacon_sigma, b.beacon_sigma))
    return false;
  for (int k = 0; k < a.num_cameras; ++k) {
    const mfns::RigCamera& x = a.cameras[static_cast<std::size_t>(k)];
    const mfns::RigCamera& y = b.cameras[static_cast<std::size_t>(k)];
    if (x.intrinsics.width != y.intrinsics.width || x.intrinsics.height != y.intrinsics.height ||
        !AllNear(x.intrinsics.ToVector(), y.intrinsics.ToVector()) || !AllNear(x.C_k_b, y.C_k_b) ||
        !AllNear(x.r_b_bk, y.r_b_bk))
      return false;
  }
  for (int m = 0; m < a.num_beacons; ++m)
    if (!AllNear(a.beacons_w[static_cast<std::size_t>(m)], b.beacons_w[static_cast<std::size_t>(m)])) return false;
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mfns::Rig rig;
  try {
    rig = mfns::host::ParseRigYaml(text, "rig.yaml");
  } catch (const mfns::host::UserError& e) {
    const std::string what = e.what();
    if (what.rfind("rig.yaml", 0) != 0 || what.find('\n') != std::string::npos) __builtin_trap();
    return 0;
  }
  if (mfns::ValidateRig(rig) != mfns::RigStatus::kOk) __builtin_trap();
  if (!SameRig(rig, mfns::host::ParseRigYaml(mfns::host::FormatRigYaml(rig), "written.yaml"))) __builtin_trap();
  return 0;
}
