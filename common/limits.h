// The one place for every fixed limit of MFNS (DESIGN.md, "Firmware rules").
//
// Every buffer on the flyer is sized from these at start; the parameter blob refuses counts
// above them. Changing a value here changes the blob's maximum size (static_asserts in
// common/blob) and the firmware's memory budget (docs/firmware-memory.md).
#pragma once

#include <cstddef>
#include <cstdint>

namespace mfns::limits {

// Rig and world.
inline constexpr int kMaxCameras = 4;
inline constexpr int kMaxBeacons = 64;
inline constexpr int kMaxCameraNameChars = 7;   // "x", "y", "z", ... plus NUL in 8 bytes
inline constexpr int kMaxRigIdChars = 31;       // plus NUL in 32 bytes

// Images.
inline constexpr int kMaxImageWidth = 2048;
inline constexpr int kMaxImageHeight = 2048;
inline constexpr std::size_t kMaxImageBytes =
    static_cast<std::size_t>(kMaxImageWidth) * kMaxImageHeight * 2;  // mono16 worst case

// Parameter blob (common/blob): the whole encoded blob never exceeds this.
inline constexpr std::size_t kMaxBlobBytes = 16384;

// Detection and identification (firmware).
inline constexpr int kMaxBlobsPerFrame = 256;
inline constexpr int kMaxObservations = kMaxCameras * kMaxBlobsPerFrame;

// Capture.
inline constexpr int kMinCaptureBuffers = 4;
inline constexpr int kMaxCaptureBuffers = 8;

// Iterative solvers: every loop has one of these as its bound.
inline constexpr int kMaxUnprojectIterations = 20;
inline constexpr int kMaxSolverIterations = 30;

}  // namespace mfns::limits
