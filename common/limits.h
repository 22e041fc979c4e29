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
inline constexpr int kMaxBeacons = 256;
// The fewest beacons a rig must have for mfns-navd to navigate with it (a pose needs 3); the
// calibration tool refuses to make a blob with fewer.
inline constexpr int kMinNavBeacons = 3;
inline constexpr int kMaxCameraNameChars = 7;   // "x", "y", "z", ... plus NUL in 8 bytes
inline constexpr int kMaxRigIdChars = 31;       // plus NUL in 32 bytes
// Physically sensible ranges of a rig's numbers (ValidateRig; rig files and blobs alike). A
// value outside is a typo, a unit error or an attack, never a rig: refusing it at the parser
// keeps absurd-but-finite numbers (1e300) out of every solver (README, "Rig file").
inline constexpr double kMaxBeaconCoordinateM = 1000.0;  // |x|, |y|, |z| of a beacon (a station is ~100 m)
inline constexpr double kMinBeaconSeparationM = 1e-3;    // two beacons closer than 1 mm are one position twice
inline constexpr double kMaxBeaconSigmaM = 1.0;          // 1-sigma of the beacon map
inline constexpr double kMaxCameraOffsetM = 10.0;        // |x|, |y|, |z| of r_b_bk (camera from body origin)
inline constexpr double kMinFocalPx = 1.0;               // alpha_x, alpha_y
inline constexpr double kMaxFocalPx = 1e6;
inline constexpr double kMaxDistortion = 1000.0;         // |kc1..kc5|

// Images.
inline constexpr int kMaxImageWidth = 2048;
inline constexpr int kMaxImageHeight = 2048;
inline constexpr std::size_t kMaxImageBytes =
    static_cast<std::size_t>(kMaxImageWidth) * kMaxImageHeight * 2;  // mono16 worst case
// Blind cells (issue 14): the coarse grid, row-major, on which the detector reports where it could
// not have seen a blob (a saturated region, rows never written; firmware/lib/frame.h BlindCellOf).
// Coarse because it travels to the matcher beside each camera's "delivered" bit in one 32-bit
// camera set (firmware/modules/identify/match.h), which the tracker passes through unchanged.
inline constexpr int kBlindCellsX = 3;
inline constexpr int kBlindCellsY = 2;
inline constexpr int kBlindCells = kBlindCellsX * kBlindCellsY;
static_assert(kMaxCameras * (1 + kBlindCells) <= 32, "delivered bits and blind cells share 32 bits");

// Parameter blob (common/blob): the whole encoded blob never exceeds this.
inline constexpr std::size_t kMaxBlobBytes = 32768;
// Parameter store (firmware/modules/params): inotify reads drained per Changed() poll; a
// queue still not empty after this many reads counts as "changed" anyway.
inline constexpr int kMaxStoreEventReads = 16;

// Detection and identification (firmware).
inline constexpr int kMaxBlobsPerFrame = 256;
inline constexpr int kMaxObservations = kMaxCameras * kMaxBlobsPerFrame;
// Streaming connected components (firmware/modules/detect) keep two rows of runs and the labels
// they reference: a row has at most ceil(width / 2) runs and each run opens at most one label,
// so this label table can never overflow for frames within kMaxImageWidth.
inline constexpr int kMaxRunsPerRow = (kMaxImageWidth + 1) / 2;
inline constexpr int kMaxBlobLabels = 2 * kMaxRunsPerRow;
// Windowed detection (issue 20 item 1): windows of one BlobDetector::Detect call.
inline constexpr int kMaxDetectWindows = 64;
// Adaptive background mesh of the detector: tiles per axis and sparse samples per tile.
inline constexpr int kMaxBackgroundTilesPerAxis = 64;
inline constexpr int kMaxBackgroundSamplesPerTile = 1024;

// Capture.
inline constexpr int kMinCaptureBuffers = 4;
inline constexpr int kMaxCaptureBuffers = 8;
inline constexpr int kMaxEintrRetries = 8;        // a syscall interrupted more often fails
inline constexpr int kMaxPathChars = 255;         // device paths, replay file paths (plus NUL)
inline constexpr int kMaxReplayFrames = 1000000;  // <frame:06d>.pgm: six digits
inline constexpr int kMaxPgmHeaderBytes = 1024;   // PGM magic, size, maxval and comments
inline constexpr std::int64_t kMaxTriggerPulseNs = 100000000;  // 100 ms exposure trigger pulse

// Outputs (firmware/modules/publish): --output destinations of mfns-navd at once (e.g. the
// MFNS datagrams to the ground and MAVLink to the autopilot).
inline constexpr int kMaxOutputs = 4;
// Blobs carried by one blobs datagram (firmware/modules/publish/pose_message.h): the matched
// ones first; 128 x 12 bytes keeps it near one Ethernet frame.
inline constexpr int kMaxBlobsInMessage = 128;
// Beacon health (firmware/modules/health): the last in-view observations of each beacon judged
// at once, and the beacons one beacon-health datagram carries (one page; 8 pages for 256).
inline constexpr int kBeaconHealthWindow = 16;
inline constexpr int kBeaconHealthPerMessage = 32;

// Iterative solvers: every loop has one of these as its bound.
inline constexpr int kMaxUnprojectIterations = 20;
inline constexpr int kMaxSolverIterations = 30;

// Identification and pose solve (firmware/modules/identify, firmware/modules/solve).
// One beacon may be seen by several cameras, so a frame set has at most this many matches.
inline constexpr int kMaxMatches = kMaxCameras * kMaxBeacons;
inline constexpr int kMaxOutlierRounds = 8;      // solver: drop-worst-and-re-solve rounds
inline constexpr int kMaxLisBlobs = 16;          // lost-in-space: brightest blobs used for triples
inline constexpr int kMaxLisHypotheses = 40000;  // lost-in-space: work units of one search (LisOptions::max_hypotheses 20 000; a seeded search spread over frame sets, TrackOptions::seeded_max_hypotheses)
inline constexpr int kMaxLisCandidates = 256;    // lost-in-space: distinct poses kept (and tracked when ambiguous)
inline constexpr int kMaxLisCandidateMatches = 32;  // lost-in-space: matches kept per candidate pose
inline constexpr int kMaxLisDeferred = 256;  // lost-in-space: poses deferred by the steady-fourth rule, scored last
inline constexpr int kMaxP3pScanSteps = 512;     // P3pOptions::scan_steps (validated; the former 1-D scan, kept as the tests' reference)
inline constexpr int kMaxP3pSolutions = 16;      // P3P: the octic's 8 roots and the twins sought beside them
inline constexpr int kMaxBisectionIterations = 64;
inline constexpr int kMaxAmbiguousMatches = 8;   // tracker: beacons with two blobs in their gate, resolved by trial
inline constexpr int kMaxTrackHistory = 16;      // tracker: recent poses kept for the velocity

}  // namespace mfns::limits
