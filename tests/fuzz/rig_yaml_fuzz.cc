// libFuzzer target for the rig file reader (host/rigio): whatever the text, ParseRigYaml returns
// a rig or throws UserError with a one-line message naming the source (rig.yaml:LINE: field:
// why); any other exception, a crash, ASan or UBSan report is a finding. A rig that parses is
// valid (ValidateRig), and writing it is a fixed point: write(read(write(rig))) == write(rig),
// but for each camera's euler_deg line, which is derived from C_k_b for people (near phi = 90 deg
// its 15th digit moves: the rotation read back, C_k_b, is what must not).
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "common/rig/rig.h"
#include "host/rigio/rig_yaml.h"

namespace {

// The text without the cameras' euler_deg lines (four spaces in; the sigma block's, six in, stay).
std::string WithoutCameraEuler(const std::string& yaml) {
  std::istringstream in(yaml);
  std::string line, out;
  while (std::getline(in, line))
    if (line.rfind("    euler_deg:", 0) != 0) out += line + '\n';
  return out;
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
  const std::string once = mfns::host::FormatRigYaml(rig);
  const std::string twice = mfns::host::FormatRigYaml(mfns::host::ParseRigYaml(once, "written.yaml"));
  if (WithoutCameraEuler(once) != WithoutCameraEuler(twice)) __builtin_trap();
  return 0;
}
