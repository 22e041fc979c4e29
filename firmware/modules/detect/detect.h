// LED-blob detection on the raw frame, in place (DESIGN.md "Firmware rules"; issue 4 item 4).
//
// One call per frame: threshold (fixed, or adaptive to a background mesh estimated from a
// sparse sample of the frame), streaming 8-connected components (runs + union-find over a
// label table that lives for two rows), per-component intensity-weighted sub-pixel centroid
// with background subtraction, gates on area, border, peak, saturation and shape, the brightest
// `max_blobs` kept sorted by flux, then undistortion of each centroid to normalised
// coordinates through mfns::Unproject.
//
// Pixel centres are at integer coordinates (DESIGN.md): pixel (x, y) covers
// [x - 0.5, x + 0.5] x [y - 0.5, y + 0.5]. Intensities are in DN (raw counts of the frame).
//
// Memory: every buffer is reserved when the detector is constructed (sized from
// common/limits.h); Detect() never allocates, never throws, and every loop is bounded by the
// frame size or a limit. The caller owns the output BlobList (about 40 kB; reserve it at start).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>

#include "common/camera/camera.h"
#include "common/limits.h"
#include "firmware/lib/frame.h"

namespace mfns::fw {

namespace detail {
struct DetectWorkspace;  // working memory of a BlobDetector (detect.cc)
}  // namespace detail

enum class ThresholdMode : unsigned char {
  kFixed = 0,     // foreground where pixel > fixed_threshold_dn
  kAdaptive = 1,  // foreground where pixel > local background + max(k_sigma * noise, min_contrast_dn)
};

enum class SaturationPolicy : unsigned char {
  kAccept = 0,  // count saturated pixels only
  kFlag = 1,    // keep the blob, set Blob::saturated when it has > max_saturated_px
  kReject = 2,  // reject the blob when it has > max_saturated_px
};

// What each pixel of a component weighs in its centroid (b: background under the pixel,
// t: threshold under the pixel, both in DN).
enum class CentroidWeights : unsigned char {
  kRaw = 0,              // w = pixel
  kAboveBackground = 1,  // w = max(pixel - b, 0): the classic background-subtracted centroid
  kAboveThreshold = 2,   // w = max(pixel - t, 0): zero at the footprint's edge, so pixels that
                         // noise pushes across the threshold barely move the centroid
};

const char* ToString(ThresholdMode m);
const char* ToString(SaturationPolicy p);
const char* ToString(CentroidWeights w);

struct DetectOptions {
  // --- Threshold.
  ThresholdMode threshold_mode = ThresholdMode::kAdaptive;
  int fixed_threshold_dn = 40;       // kFixed: foreground where pixel > this
  double fixed_background_dn = 0.0;  // kFixed: background under the blobs (weights, peak gate)

  // kAdaptive: the frame is cut into tile_px x tile_px tiles; in each, every sample_step_px-th
  // pixel of every sample_step_px-th row is sampled; the tile's background is the mean of the
  // samples within 3.5 sigma of their median (sigma from the MAD); its noise is the clipped RMS
  // of the differences between each sample and its right neighbour, over sqrt(2) (blind to a
  // background slope). The frame's noise is the median of the tiles' noise. A 3x3 median filter over the
  // mesh (interior tiles) removes tiles dominated by a bright object. The background under a
  // pixel is the bilinear interpolation of the mesh between tile centres (extrapolated beyond
  // the outer centres); the threshold follows it, held constant over 16-pixel row segments.
  // Until issue 20 item 2: tile_px 64, sample_step_px 4 (320 tiles of 256 samples on 1280x1024);
  // now 80 tiles of 256 samples, a quarter of the samples and of the per-tile work (README
  // "Background sampling"; the old values remain valid options).
  int tile_px = 128;       // >= kMaxImageWidth / kMaxBackgroundTilesPerAxis (32)
  int sample_step_px = 8;  // (tile_px / sample_step_px)^2 <= kMaxBackgroundSamplesPerTile
  bool mesh_median_filter = true;
  double k_sigma = 6.0;          // threshold above background, in noise sigmas
  double min_contrast_dn = 4.0;  // lower bound of the threshold above background (DN)

  // --- Centroid weights (CentroidWeights). The flux used for sorting is always the sum of
  // max(pixel - background, 0).
  CentroidWeights centroid_weights = CentroidWeights::kAboveThreshold;

  // --- Gates, applied in this order; each rejection has its own counter.
  int min_area_px = 3;                       // fewer pixels: a speck (hot pixel, noise)
  int max_area_px = 4000;                    // more: a lamp, a window, a reflection
  bool reject_border = true;                 // bounding box within border_margin_px of the edge
  int border_margin_px = 0;                  // 0: touching the outermost pixel row/column
  double min_peak_above_background_dn = 10.0;
  int saturation_dn = 0;  // a pixel >= this is saturated; 0: full scale (255, 65535)
  SaturationPolicy saturation_policy = SaturationPolicy::kFlag;
  int max_saturated_px = 0;       // the policy applies above this many saturated pixels
  double max_elongation = 3.0;    // sqrt(major / minor) of the second moments (>= 1)

  // --- Output: at most this many blobs, the brightest (largest flux) first.
  int max_blobs = limits::kMaxBlobsPerFrame;

  // --- Implementation (issue 20 item 2). false: the fast path (a row is skipped 128 pixels at a
  // time against a lower bound of its thresholds, exact thresholds only where a pixel may be
  // foreground; tile statistics from a histogram). true: the per-pixel path of the first version
  // (every row's thresholds, statistics by the clipped-sample loops), kept as the reference the
  // fast path must equal bit for bit (detect_test "FastPathEqualsReference") and for benchmarks.
  bool reference_path = false;
  // x86-64 only: the fast path's row skip runs on 32-byte AVX2 vectors when the CPU has AVX2
  // (chosen at construction; the same BlobList bit for bit). false: the baseline 16-byte vectors
  // (SSE2) everywhere; tests run both. No effect on other targets (aarch64: NEON, 16 bytes).
  bool use_avx2 = true;

  // True when every field is usable; otherwise *why (optional) names the first bad field in a
  // static string. No heap.
  bool IsValid(const char** why = nullptr) const;
};

struct Blob {
  Eigen::Vector2d uv_px = Eigen::Vector2d::Zero();  // weighted centroid, pixel centres integer
  Eigen::Vector2d x_n = Eigen::Vector2d::Zero();    // undistorted normalised (X/Z, Y/Z)
  bool normalised_ok = false;  // x_n valid (a camera was given and Unproject converged)
  double flux_dn = 0.0;        // sum of max(pixel - background, 0) (DN px): sorts by brightness
  double background_dn = 0.0;  // background at the centroid (kFixed: fixed_background_dn)
  int peak_dn = 0;             // largest raw pixel value
  int area_px = 0;             // pixels above threshold
  int saturated_px = 0;        // pixels >= the saturation level
  bool saturated = false;      // saturated_px > max_saturated_px (policy kFlag)
  int x_min = 0, y_min = 0, x_max = 0, y_max = 0;  // bounding box, inclusive, px
  // Weighted central second moments (px^2) and elongation sqrt(l_max / l_min) of the moment
  // matrix plus 1/12 px^2 on the diagonal (a pixel's own extent, so one pixel is round).
  double m_xx = 0.0, m_yy = 0.0, m_xy = 0.0;
  double elongation = 1.0;
};

// Counts per failure mode and per gate. Used per frame (BlobList::counters) and cumulated
// over the life of a detector (BlobDetector::counters()).
struct DetectCounters {
  std::uint64_t frames = 0;
  std::uint64_t bad_frames = 0;          // kBadFrame, kCameraMismatch, kBadOptions
  std::uint64_t components = 0;          // connected components closed
  std::uint64_t rejected_small = 0;      // area < min_area_px
  std::uint64_t rejected_large = 0;      // area > max_area_px
  std::uint64_t rejected_border = 0;
  std::uint64_t rejected_faint = 0;      // peak - background < min_peak_above_background_dn
  std::uint64_t rejected_saturated = 0;  // policy kReject
  std::uint64_t rejected_elongated = 0;  // elongation > max_elongation
  std::uint64_t flagged_saturated = 0;   // policy kFlag, blob kept
  std::uint64_t over_blob_limit = 0;     // passed every gate but fainter than max_blobs others
  std::uint64_t label_table_full = 0;    // frames cut short because no label was free
  std::uint64_t open_discarded = 0;      // components still open when a frame was cut short
  std::uint64_t undistort_failures = 0;  // Unproject not kOk
  std::uint64_t blank_frames = 0;        // kBlankFrame
  std::uint64_t truncated_frames = 0;    // kTruncatedFrame: lower rows never written
  std::uint64_t saturated_frames = 0;    // frames with a blind cell from a saturated region
  std::uint64_t rejected_window_edge = 0;  // windowed Detect: touches its window's edge inside the
                                           // frame (may continue outside: not measured)
  std::uint64_t windows_dropped = 0;       // windowed Detect: empty, outside the frame or over the limit

  DetectCounters& operator+=(const DetectCounters& o);
};

enum class DetectStatus : unsigned char {
  kOk = 0,
  kBadOptions,       // the detector was built with options that are not IsValid()
  kBadFrame,         // null data, size <= 0 or above limits, stride < width * bytes per pixel
  kCameraMismatch,   // the camera's width/height differ from the frame's
  kBlobLimit,        // more blobs passed the gates than max_blobs: the brightest are kept
  kLabelTableFull,   // no free label: rows below were skipped, blobs closed before are kept
  kBlankFrame,       // no blob, and every sampled pixel has the same value (all zero, all
                     // saturated, stuck): no sensor gives that (read noise), so the frame
                     // carries no information and must not say "no beacon here"
  kTruncatedFrame,   // the lower rows were never written (a transfer cut short; see Detect):
                     // blobs from the rows above, the rows below reported blind
};
const char* ToString(DetectStatus s);

// The result of one frame. Blobs [0, count) are valid, sorted by flux, brightest first.
struct BlobList {
  int count = 0;
  std::array<Blob, limits::kMaxBlobsPerFrame> blobs{};
  // Copied from the frame.
  int camera = -1;
  std::uint32_t sequence = 0;
  std::uint64_t t_capture_ns = 0;
  // What the threshold was: in kAdaptive the median of the background mesh, the frame noise
  // estimate and the threshold range over the tiles; in kFixed the configured values.
  double background_dn = 0.0;
  double noise_dn = 0.0;
  double contrast_dn = 0.0;  // threshold - background (kFixed: fixed threshold - fixed background)
  int threshold_min_dn = 0;
  int threshold_max_dn = 0;
  // Where no blob could have been seen (limits::kBlindCellsX x kBlindCellsY cells, row-major,
  // firmware/lib/frame.h BlindCellOf): bit c set when cell c holds a saturated block (a lamp,
  // the sun in a window: half or more of a 32 x 32 px block's samples at the saturation level)
  // or rows never written (kTruncatedFrame). A beacon predicted there is not missing (match.h).
  std::uint32_t blind_cells = 0;
  int rows_written = 0;  // rows detected in: the frame's height, fewer when kTruncatedFrame
  DetectCounters counters;  // this frame only
};

// A rectangle of pixels [x0, x1) x [y0, y1) (windowed detection, issue 20 item 1).
struct PixelWindow {
  int x0 = 0;
  int y0 = 0;
  int x1 = 0;
  int y1 = 0;
};

// Stripe `index` (taken modulo `stripes`) of a frame cut into `stripes` bands of rows of equal
// height, widened by `margin_px` rows on each side (clipped to the frame), full width. Every row
// is in stripe index mod stripes; a blob at most margin_px rows tall lies inside the stripe of
// its top row without touching its edges, so a windowed Detect that includes stripe k of frame
// set k finds every such blob that does not move within N = stripes frame sets, and one whose
// image moves less than 2 margin_px - height rows (and less than a stripe) per frame set within
// 2N - 1 (README "Windowed detection").
PixelWindow DetectionStripe(int width, int height, int index, int stripes, int margin_px);

class BlobDetector {
 public:
  // Reserves all working memory (about 0.4 MB). `max_labels` sizes the label table; the default
  // can never overflow (common/limits.h), smaller values exist to test the overflow path.
  explicit BlobDetector(const DetectOptions& options = DetectOptions(),
                        int max_labels = limits::kMaxBlobLabels);
  ~BlobDetector();
  BlobDetector(BlobDetector&&) noexcept;
  BlobDetector& operator=(BlobDetector&&) noexcept;
  BlobDetector(const BlobDetector&) = delete;
  BlobDetector& operator=(const BlobDetector&) = delete;

  // Detects the blobs of `frame` into *out (count = 0 on kBadOptions/kBadFrame/
  // kCameraMismatch). With `camera` non-null, each centroid is undistorted into Blob::x_n;
  // the camera's size must equal the frame's. The frame is only read.
  //
  // Truncated frame (kTruncatedFrame): the bottom kMinUnwrittenRows or more rows hold one value
  // below saturation, every pixel of them exactly, while at least half the pixels of the
  // kWrittenProbeRows rows above the first of them differ from it. A buffer the transfer did
  // not fill keeps its old content, normally zero; a sensor's read noise does not stop at a row,
  // so a dark frame is either zero nearly everywhere (its rows above fail the second test) or
  // nowhere (its bottom rows fail the first), and a saturated bottom is glare, not a short
  // transfer. Blobs are detected in the rows above the first unwritten row but one (that row
  // may be half written), as in a frame that ends there: a blob cut by the end is a border blob.
  DetectStatus Detect(const FrameView& frame, const CameraIntrinsics* camera, BlobList* out);

  // Windowed detection (issue 20 item 1): as Detect, but components are found only inside
  // windows[0, num_windows) (at most limits::kMaxDetectWindows; more, empty ones and the parts
  // outside the frame are dropped and counted in windows_dropped). Windows that overlap or touch
  // are merged into their bounding box. The background, noise, thresholds, blind cells and the
  // truncation and blank tests are the whole frame's, as in Detect; a component that touches
  // its window's edge inside the frame may continue outside it and is rejected
  // (rejected_window_edge). So every blob found is the one Detect finds, bit for bit (centroid,
  // flux, moments, gates; test WindowedEqualsFullFrame); blobs outside the windows are missing.
  DetectStatus Detect(const FrameView& frame, const CameraIntrinsics* camera, const PixelWindow* windows,
                      int num_windows, BlobList* out);

  const DetectOptions& options() const { return options_; }
  // The vector width (bytes) of the fast path's row skip: 32 with AVX2 (use_avx2 and the CPU has
  // it), else 16.
  int vector_bytes() const;
  const DetectCounters& counters() const { return counters_; }  // since construction

 private:
  DetectStatus Run(const FrameView& frame, const CameraIntrinsics* camera, const PixelWindow* windows, int num_windows,
                   bool windowed, BlobList* out);

  DetectOptions options_;
  bool options_valid_ = false;
  DetectCounters counters_;
  std::unique_ptr<detail::DetectWorkspace> ws_;
};

}  // namespace mfns::fw
