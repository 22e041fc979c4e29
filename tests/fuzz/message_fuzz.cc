// libFuzzer target for the pose, health, blobs and beacon-health datagram decoders (firmware/modules/publish/
// pose_message.h), which receivers (ground tools, tests, a flight controller bridge) run on
// whatever arrives on a UDP port: a typed status for any bytes; a datagram that decodes kOk
// encodes again without fault.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "firmware/modules/publish/pose_message.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mfns::fw;
  const std::span<const std::uint8_t> in(data, size);
  PoseRecord pose;
  if (DecodePose(in, &pose) == MessageStatus::kOk) {
    std::array<std::uint8_t, kPoseMessageBytes> out{};
    EncodePose(pose, out);
    (void)ToString(pose.status);
    (void)ToString(pose.reason);  // any byte value: never out of a table
  }
  HealthRecord health;
  if (DecodeHealth(in, &health) == MessageStatus::kOk) {
    std::array<std::uint8_t, kHealthMessageBytes> out{};
    EncodeHealth(health, out);
  }
  BlobsRecord blobs;
  if (DecodeBlobs(in, &blobs) == MessageStatus::kOk) {
    // What decodes encodes to the same bytes (the layout has no slack).
    std::array<std::uint8_t, kMaxBlobsMessageBytes> out{};
    const std::size_t n = EncodeBlobs(blobs, out);
    if (n != size || !std::equal(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n), data)) __builtin_trap();
  }
  BeaconHealthRecord beacons;
  if (DecodeBeaconHealth(in, &beacons) == MessageStatus::kOk) {
    // The same: no slack, so what decodes encodes to the same bytes.
    std::array<std::uint8_t, kMaxBeaconHealthMessageBytes> out{};
    const std::size_t n = EncodeBeaconHealth(beacons, out);
    if (n != size || !std::equal(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n), data)) __builtin_trap();
  }
  return 0;
}
