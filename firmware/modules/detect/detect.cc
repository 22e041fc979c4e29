#include "firmware/modules/detect/detect.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <utility>

namespace mfns::fw {
namespace {

constexpr int kMeshAxis = limits::kMaxBackgroundTilesPerAxis;
constexpr int kMeshSize = kMeshAxis * kMeshAxis;
constexpr int kMinTilePx =
    (std::max(limits::kMaxImageWidth, limits::kMaxImageHeight) + kMeshAxis - 1) / kMeshAxis;
// The adaptive threshold is constant over row segments this long: short enough to follow a
// background slope (error <= 8 px x slope), long enough for the vectorised background skip.
constexpr int kSegmentPx = 16;
constexpr int kMaxSegments = (limits::kMaxImageWidth + kSegmentPx - 1) / kSegmentPx;
// The fast path tests a row kChunkPx pixels at a time against a lower bound of the thresholds of
// the chunk's segments (issue 20 item 2); a multiple of kSegmentPx.
constexpr int kChunkPx = 128;
constexpr int kMaxChunks = (limits::kMaxImageWidth + kChunkPx - 1) / kChunkPx;
static_assert(kChunkPx % kSegmentPx == 0);
constexpr double kPixelVariance = 1.0 / 12.0;  // variance of a uniform 1 px box
constexpr double kMadToSigma = 1.4826;          // Gaussian sigma / median absolute deviation
constexpr double kClipSigmas = 3.5;             // background samples kept within this

// A horizontal run of foreground pixels [x0, x1] in one row and the label it belongs to.
struct Run {
  int x0 = 0;
  int x1 = 0;
  int label = -1;
};

// Union-find node and the running sums of one connected component (centroid weights w).
struct Component {
  double s0, sx, sy, sxx, syy, sxy;  // sum of w, w x, w y, w x^2, w y^2, w x y
  double flux;                       // sum of max(pixel - background, 0)
  int area, peak, saturated;
  int x_min, x_max, y_min, y_max;
  int parent;  // itself when a root
  int stamp;   // last row a run of this root was seen in (closing test)
};

// Row readers: the pixel value at column x of one row, and whether any of the 16 bytes from
// column x on exceed t (GCC vector extensions: SSE2 on x86-64, NEON on aarch64). Mono16 is
// little-endian and may be unaligned (any stride, any buffer offset), hence memcpy.
using U8x16 = std::uint8_t __attribute__((vector_size(16)));
using U16x8 = std::uint16_t __attribute__((vector_size(16)));
using U8x32 = std::uint8_t __attribute__((vector_size(32)));    // AVX2 only (QuietChunksAvx2)
using U16x16 = std::uint16_t __attribute__((vector_size(32)));  // AVX2 only

// The vector of kBytes bytes of Lane (vector_size cannot take a template's type parameter).
template <typename Lane, int kBytes>
struct VectorOf;
template <>
struct VectorOf<std::uint8_t, 16> {
  using Type = U8x16;
};
template <>
struct VectorOf<std::uint16_t, 16> {
  using Type = U16x8;
};
template <>
struct VectorOf<std::uint8_t, 32> {
  using Type = U8x32;
};
template <>
struct VectorOf<std::uint16_t, 32> {
  using Type = U16x16;
};

// Whether any lane of a vector comparison result is set.
template <typename V>
bool AnyLane(const V& mask) {
  static_assert(sizeof(V) == 16);
  std::uint64_t h[2];
  std::memcpy(h, &mask, sizeof h);
  return (h[0] | h[1]) != 0;
}

// *m = the lane-wise maximum of the kChunkPx pixels from p as vectors V (two independent chains).
// (An out parameter: a 32-byte vector returned by value from a baseline function changes the ABI.)
template <typename V, typename Lane>
[[gnu::always_inline]] inline void ChunkMax(const std::uint8_t* p, V* m) {
  constexpr int kBytes = static_cast<int>(sizeof(V));
  constexpr int kVectors = kChunkPx * static_cast<int>(sizeof(Lane)) / kBytes;
  static_assert(kVectors % 2 == 0);
  V m0, m1;
  std::memcpy(&m0, p, sizeof m0);
  std::memcpy(&m1, p + kBytes, sizeof m1);
  for (int i = 2; i < kVectors; i += 2) {
    V a, b;
    std::memcpy(&a, p + i * kBytes, sizeof a);
    std::memcpy(&b, p + (i + 1) * kBytes, sizeof b);
    m0 = a > m0 ? a : m0;
    m1 = b > m1 ? b : m1;
  }
  *m = m1 > m0 ? m1 : m0;
}

// Whether any of the kChunkPx pixels from p (pixel type V's lanes) exceeds t: the lane-wise
// maximum of the chunk's vectors against t, one comparison a chunk.
template <typename V, typename Lane>
bool ChunkAbove(const std::uint8_t* p, int t) {
  V m;
  ChunkMax<V, Lane>(p, &m);
  return AnyLane(m > static_cast<Lane>(t));
}

// Fast path: whether chunk p (kChunkPx pixels) has no pixel above t (t < 0: every pixel is above;
// t >= the lane's full scale: none can be): one lane-wise maximum of its 16-byte vectors and one
// comparison.
template <typename Lane>
[[gnu::always_inline]] inline bool ChunkQuiet(const std::uint8_t* p, int t) {
  using V = typename VectorOf<Lane, 16>::Type;
  if (t < 0) return false;
  if (t >= std::numeric_limits<Lane>::max()) return true;
  V m;
  ChunkMax<V, Lane>(p, &m);
  return !AnyLane(m > static_cast<Lane>(t));
}

// Fast path: how many whole chunks from chunk c on (below c_end) are quiet (ChunkQuiet against
// their lower bounds lb[k]). The loop runs over all the quiet chunks of a row in one call, so
// ScanRowFast's per-chunk bookkeeping (bounds, the open run) is paid once per stretch of
// background, not once per chunk.
template <typename Lane>
int QuietChunksBaseline(const std::uint8_t* row, const int* lb, int c, int c_end) {
  constexpr int kChunkBytes = kChunkPx * static_cast<int>(sizeof(Lane));
  int k = c;
  while (k < c_end && ChunkQuiet<Lane>(row + static_cast<std::ptrdiff_t>(k) * kChunkBytes, lb[k])) ++k;
  return k - c;
}

// Fast path: how many rows from row0 (`stride` bytes apart, at most `rows`) have every chunk
// [c, c_end) quiet: Label skips them whole when no run is open above (nothing to label or close),
// one call for a band of rows instead of a row's loop and calls each.
template <typename Lane>
int QuietRowsBaseline(const std::uint8_t* row0, std::ptrdiff_t stride, int rows, const int* lb, int c, int c_end) {
  int r = 0;
  while (r < rows && QuietChunksBaseline<Lane>(row0 + r * stride, lb, c, c_end) == c_end - c) ++r;
  return r;
}

// x86-64: the same loops on 32-byte AVX2 vectors where the CPU has AVX2 (chosen at construction,
// DetectOptions::use_avx2): half the loads and maxima, and the test is m - min(m, t) (nonzero
// where a pixel is above t) and one vptest. The build targets baseline x86-64 (SSE2: 16-byte
// vectors) so that it runs on any x86-64; a function-level target attribute adds AVX2 code for
// these loops alone, and __builtin_cpu_supports (libgcc / compiler-rt; no ifunc, so static and
// dynamic links alike) picks it. aarch64 has no such build: NEON's 16 bytes are its baseline.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define MFNS_DETECT_AVX2 1
template <typename Lane>
__attribute__((target("avx2"), always_inline)) inline bool ChunkQuietAvx2(const std::uint8_t* p, int t) {
  using V = typename VectorOf<Lane, 32>::Type;
  using I64x4 = long long __attribute__((vector_size(32)));
  if (t < 0) return false;
  if (t >= std::numeric_limits<Lane>::max()) return true;
  V m;
  ChunkMax<V, Lane>(p, &m);
  const V tv = V{} + static_cast<Lane>(t);
  const V excess = m - (m < tv ? m : tv);  // m - min(m, t): nonzero where a pixel is above t
  I64x4 e;
  std::memcpy(&e, &excess, sizeof e);
  return __builtin_ia32_ptestz256(e, e) != 0;
}

template <typename Lane>
__attribute__((target("avx2"), noinline)) int QuietChunksAvx2(const std::uint8_t* row, const int* lb, int c,
                                                              int c_end) {
  constexpr int kChunkBytes = kChunkPx * static_cast<int>(sizeof(Lane));
  int k = c;
  while (k < c_end && ChunkQuietAvx2<Lane>(row + static_cast<std::ptrdiff_t>(k) * kChunkBytes, lb[k])) ++k;
  return k - c;
}

template <typename Lane>
__attribute__((target("avx2"), noinline)) int QuietRowsAvx2(const std::uint8_t* row0, std::ptrdiff_t stride, int rows,
                                                            const int* lb, int c, int c_end) {
  constexpr int kChunkBytes = kChunkPx * static_cast<int>(sizeof(Lane));
  for (int r = 0; r < rows; ++r) {
    const std::uint8_t* row = row0 + r * stride;
    for (int k = c; k < c_end; ++k)
      if (!ChunkQuietAvx2<Lane>(row + static_cast<std::ptrdiff_t>(k) * kChunkBytes, lb[k])) return r;
  }
  return rows;
}
bool CpuHasAvx2() { return __builtin_cpu_supports("avx2") != 0; }
#else
#define MFNS_DETECT_AVX2 0
bool CpuHasAvx2() { return false; }
#endif

template <typename Lane>
int QuietChunks(bool avx2, const std::uint8_t* row, const int* lb, int c, int c_end) {
#if MFNS_DETECT_AVX2
  if (avx2) return QuietChunksAvx2<Lane>(row, lb, c, c_end);
#else
  (void)avx2;
#endif
  return QuietChunksBaseline<Lane>(row, lb, c, c_end);
}

template <typename Lane>
int QuietRows(bool avx2, const std::uint8_t* row0, std::ptrdiff_t stride, int rows, const int* lb, int c, int c_end) {
#if MFNS_DETECT_AVX2
  if (avx2) return QuietRowsAvx2<Lane>(row0, stride, rows, lb, c, c_end);
#else
  (void)avx2;
#endif
  return QuietRowsBaseline<Lane>(row0, stride, rows, lb, c, c_end);
}

struct Mono8Row {
  using Lane = std::uint8_t;
  static constexpr int kBlock = 16;  // pixels per AnyAbove
  static constexpr int kFullScale = 255;
  const std::uint8_t* p;
  int operator[](int x) const { return p[x]; }
  bool AnyAbove(int x, int t) const {
    U8x16 v;
    std::memcpy(&v, p + x, sizeof v);
    return AnyLane(v > static_cast<std::uint8_t>(std::min(t, 255)));
  }
  // Pixels [x, x + kChunkPx): any > t (t < 0: always true).
  bool AnyAboveChunk(int x, int t) const {
    return t < 0 || (t < kFullScale && ChunkAbove<U8x16, std::uint8_t>(p + x, t));
  }
};

struct Mono16Row {
  using Lane = std::uint16_t;
  static constexpr int kBlock = 8;
  static constexpr int kFullScale = 65535;
  const std::uint8_t* p;
  int operator[](int x) const {
    std::uint16_t v;
    std::memcpy(&v, p + 2 * static_cast<std::ptrdiff_t>(x), sizeof v);
    return v;
  }
  bool AnyAbove(int x, int t) const {
    U16x8 v;
    std::memcpy(&v, p + 2 * static_cast<std::ptrdiff_t>(x), sizeof v);
    return AnyLane(v > static_cast<std::uint16_t>(std::min(t, 65535)));
  }
  bool AnyAboveChunk(int x, int t) const {
    return t < 0 || (t < kFullScale && ChunkAbove<U16x8, std::uint16_t>(p + 2 * static_cast<std::ptrdiff_t>(x), t));
  }
};

// Piecewise-linear interpolation over sorted knots c[0..n-1] (spacing about `tile`): the
// segment i and the fraction f so that value = v[i] + f (v[i+1] - v[i]); beyond the outer knots
// the end segments are extended (a background slope continues to the image edge).
void Bracket(const double* c, int n, int tile, double t, int* i, double* f) {
  if (n == 1) {
    *i = 0;
    *f = 0.0;
    return;
  }
  // Truncation instead of floor: they differ only for t < 0, where both clamp to 0 (and x86-64's
  // baseline has no inline floor: a libm call per pixel of every run).
  int k = std::clamp(static_cast<int>(t / tile), 0, n - 1);
  if (t < c[k] && k > 0) --k;
  k = std::min(k, n - 2);
  *i = k;
  *f = (t - c[k]) / (c[k + 1] - c[k]);
}

double Interpolate(const double* c, const double* v, int n, int tile, double t) {
  int i = 0;
  double f = 0.0;
  Bracket(c, n, tile, t, &i, &f);
  return n == 1 ? v[0] : v[i] + f * (v[i + 1] - v[i]);
}

// Robust level and spread of v[0..n-1] (n >= 1; may reorder v): the mean and RMS about it of
// the values within kClipSigmas of the median, sigma from the MAD. Continuous-valued even when
// the MAD of integer data is 0 or 1 (the clip is at least kClipSigmas DN). The median and MAD
// come from a histogram when the values span at most kHistogramBins (always for mono8), from
// selection otherwise.
constexpr int kHistogramBins = 1024;

// The median bin m (rank n / 2, 0-based) and the MAD d in bins of a histogram of n values over
// `range` bins (both paths: MedianMad and HistogramClippedMeanRms).
void HistogramMedianMad(const int* hist, int range, int n, int* m_out, int* d_out) {
  const int half = n / 2;
  int m = 0;
  for (int seen = hist[0]; seen <= half; seen += hist[++m]) {
  }
  // Rank n / 2 of |v - median|: widen a window about the median until it holds more.
  int d = 0;
  for (int seen = hist[m]; seen <= half; ++d) {
    if (m - d - 1 >= 0) seen += hist[m - d - 1];
    if (m + d + 1 < range) seen += hist[m + d + 1];
  }
  *m_out = m;
  *d_out = d;
}

// `max_abs`: a bound on |v| known in advance (255 for mono8), or 0 to find the range.
void MedianMad(int* v, int n, int max_abs, int* hist, int* scratch, int* median, int* mad) {
  int lo = -max_abs, range = 2 * max_abs + 1;
  if (max_abs <= 0 || range > kHistogramBins) {
    const auto [lo_it, hi_it] = std::minmax_element(v, v + n);
    lo = *lo_it;
    range = *hi_it - lo + 1;
  }
  const int half = n / 2;  // the median is the element of rank n / 2 (0-based)
  if (range <= kHistogramBins) {
    std::fill_n(hist, range, 0);
    for (int k = 0; k < n; ++k) ++hist[v[k] - lo];
    int m = 0;
    HistogramMedianMad(hist, range, n, &m, mad);
    *median = lo + m;
    return;
  }
  std::nth_element(v, v + half, v + n);
  *median = v[half];
  for (int k = 0; k < n; ++k) scratch[k] = std::abs(v[k] - *median);
  std::nth_element(scratch, scratch + half, scratch + n);
  *mad = scratch[half];
}

void ClippedMeanRms(int* v, int n, int max_abs, int* hist, int* scratch, double* mean, double* rms) {
  int median = 0, mad = 0;
  MedianMad(v, n, max_abs, hist, scratch, &median, &mad);
  const double clip = kClipSigmas * std::max(kMadToSigma * mad, 1.0);
  double sum = 0.0, sum2 = 0.0;
  int m = 0;
  for (int k = 0; k < n; ++k) {
    const double d = v[k] - median;
    if (std::abs(d) <= clip) {
      sum += d;
      sum2 += d * d;
      ++m;
    }
  }
  const double mu = sum / m;  // m >= 1: the median itself is within the clip
  *mean = median + mu;
  *rms = std::sqrt(std::max(sum2 / m - mu * mu, 0.0));
}

// ClippedMeanRms from the histogram of the values (hist[b]: how many equal lo + b, b < range;
// n in all), bit for bit (the fast path; the reference path keeps ClippedMeanRms): the median and
// MAD loops are MedianMad's, which give the same ranks whatever empty bins lie outside the
// values' range; the clipped sums are sums of integers below 2^53, exact in any order, so equal
// to the sample loop's.
void HistogramClippedMeanRms(const int* hist, int range, int n, int lo, double* mean, double* rms) {
  int m = 0, d = 0;
  HistogramMedianMad(hist, range, n, &m, &d);
  const double clip = kClipSigmas * std::max(kMadToSigma * d, 1.0);
  const int reach = static_cast<int>(clip);  // |e| <= clip <=> |e| <= floor(clip) for integers; clip > 0
  std::int64_t sum = 0, sum2 = 0, count = 0;
  for (int b = std::max(m - reach, 0); b <= std::min(m + reach, range - 1); ++b) {
    const std::int64_t c = hist[b], e = b - m;
    sum += c * e;
    sum2 += c * e * e;
    count += c;
  }
  const double mu = static_cast<double>(sum) / static_cast<double>(count);
  *mean = lo + m + mu;
  *rms = std::sqrt(std::max(static_cast<double>(sum2) / static_cast<double>(count) - mu * mu, 0.0));
}

// The same from the values v[0..n-1], all in [lo, hi]; false when hi - lo + 1 > kHistogramBins
// (the caller falls back to ClippedMeanRms).
bool HistogramClippedMeanRms(const int* v, int n, int lo, int hi, int* hist, double* mean, double* rms) {
  const int range = hi - lo + 1;
  if (range > kHistogramBins) return false;
  std::fill_n(hist, range, 0);
  for (int k = 0; k < n; ++k) ++hist[v[k] - lo];
  HistogramClippedMeanRms(hist, range, n, lo, mean, rms);
  return true;
}

// [*lo, *hi]: the 16-bin blocks of hist[0, n) (n a multiple of 16, some bin not zero) from the
// first to the last that holds a bin not zero; four 16-byte vectors a block. A superset of the
// range of the values counted, which the histogram statistics accept (empty bins change no rank
// and no clipped sum: HistogramClippedMeanRms), found in a few dozen vector steps per tile instead
// of three comparisons per sample; stopping at block edges spares the mispredicted exits of a
// bin-by-bin search.
void BlockRangeOfHistogram(const int* hist, int n, int* lo, int* hi) {
  using I32x4 = std::int32_t __attribute__((vector_size(16)));
  constexpr int kBlock = 16;
  const auto any = [hist](int i) {
    I32x4 a, b, c, d;
    std::memcpy(&a, hist + i, sizeof a);
    std::memcpy(&b, hist + i + 4, sizeof b);
    std::memcpy(&c, hist + i + 8, sizeof c);
    std::memcpy(&d, hist + i + 12, sizeof d);
    return AnyLane((a | b) | (c | d));
  };
  int i = 0;
  while (i + kBlock < n && !any(i)) i += kBlock;
  int j = n;
  while (j - kBlock > i && !any(j - kBlock)) j -= kBlock;
  *lo = i;
  *hi = j - 1;
}

void AddComponent(Component* into, const Component& from) {
  into->s0 += from.s0;
  into->sx += from.sx;
  into->sy += from.sy;
  into->sxx += from.sxx;
  into->syy += from.syy;
  into->sxy += from.sxy;
  into->flux += from.flux;
  into->area += from.area;
  into->peak = std::max(into->peak, from.peak);
  into->saturated += from.saturated;
  into->x_min = std::min(into->x_min, from.x_min);
  into->x_max = std::max(into->x_max, from.x_max);
  into->y_min = std::min(into->y_min, from.y_min);
  into->y_max = std::max(into->y_max, from.y_max);
}

// The threshold (DN) of a row segment whose background lies between a (tile-centre row j) and
// b (row j + 1) at fraction f: the one expression of both paths, so they agree bit for bit.
// pixel > t <=> pixel > floor(t) for integer pixels; t is clamped >= 0, so truncate.
int SegmentThresholdOf(double a, double b, double f, double contrast, double top) {
  return static_cast<int>(std::clamp(a + f * (b - a) + contrast, 0.0, top));
}

// The median of 9 values (the value nth_element would put at rank 4): a 19-exchange network.
double MedianOf9(std::array<double, 9>& p) {
  const auto sort2 = [&p](std::size_t a, std::size_t b) {  // branch-free: minsd / maxsd
    const double lo = std::min(p[a], p[b]), hi = std::max(p[a], p[b]);
    p[a] = lo;
    p[b] = hi;
  };
  sort2(1, 2), sort2(4, 5), sort2(7, 8), sort2(0, 1), sort2(3, 4), sort2(6, 7), sort2(1, 2), sort2(4, 5), sort2(7, 8);
  sort2(0, 3), sort2(5, 8), sort2(4, 7), sort2(3, 6), sort2(1, 4), sort2(2, 5), sort2(4, 7), sort2(4, 2), sort2(6, 4);
  sort2(4, 2);
  return p[4];
}

bool BrighterFirst(const Blob& a, const Blob& b) {
  if (a.flux_dn != b.flux_dn) return a.flux_dn > b.flux_dn;
  if (a.uv_px.y() != b.uv_px.y()) return a.uv_px.y() < b.uv_px.y();
  return a.uv_px.x() < b.uv_px.x();
}

}  // namespace

const char* ToString(ThresholdMode m) {
  switch (m) {
    case ThresholdMode::kFixed: return "fixed";
    case ThresholdMode::kAdaptive: return "adaptive";
  }
  return "unknown";
}

const char* ToString(SaturationPolicy p) {
  switch (p) {
    case SaturationPolicy::kAccept: return "accept";
    case SaturationPolicy::kFlag: return "flag";
    case SaturationPolicy::kReject: return "reject";
  }
  return "unknown";
}

const char* ToString(CentroidWeights w) {
  switch (w) {
    case CentroidWeights::kRaw: return "raw";
    case CentroidWeights::kAboveBackground: return "above background";
    case CentroidWeights::kAboveThreshold: return "above threshold";
  }
  return "unknown";
}

const char* ToString(DetectStatus s) {
  switch (s) {
    case DetectStatus::kOk: return "ok";
    case DetectStatus::kBadOptions: return "bad options";
    case DetectStatus::kBadFrame: return "bad frame";
    case DetectStatus::kCameraMismatch: return "camera size differs from frame size";
    case DetectStatus::kBlobLimit: return "more blobs than max_blobs";
    case DetectStatus::kLabelTableFull: return "label table full";
    case DetectStatus::kBlankFrame: return "blank frame (every pixel alike)";
    case DetectStatus::kTruncatedFrame: return "truncated frame (lower rows never written)";
  }
  return "unknown";
}

bool DetectOptions::IsValid(const char** why) const {
  const auto fail = [why](const char* reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (threshold_mode != ThresholdMode::kFixed && threshold_mode != ThresholdMode::kAdaptive)
    return fail("threshold_mode");
  if (fixed_threshold_dn < 0 || fixed_threshold_dn > 65535) return fail("fixed_threshold_dn");
  if (!std::isfinite(fixed_background_dn) || fixed_background_dn < 0.0)
    return fail("fixed_background_dn");
  if (tile_px < kMinTilePx || tile_px > std::max(limits::kMaxImageWidth, limits::kMaxImageHeight))
    return fail("tile_px");
  if (sample_step_px < 1) return fail("sample_step_px");
  const int per_axis = (tile_px + sample_step_px - 1) / sample_step_px;
  if (per_axis * per_axis > limits::kMaxBackgroundSamplesPerTile) return fail("sample_step_px");
  if (!std::isfinite(k_sigma) || k_sigma <= 0.0) return fail("k_sigma");
  if (!std::isfinite(min_contrast_dn) || min_contrast_dn < 0.0) return fail("min_contrast_dn");
  if (centroid_weights != CentroidWeights::kRaw &&
      centroid_weights != CentroidWeights::kAboveBackground &&
      centroid_weights != CentroidWeights::kAboveThreshold)
    return fail("centroid_weights");
  if (min_area_px < 1) return fail("min_area_px");
  if (max_area_px < min_area_px) return fail("max_area_px");
  if (border_margin_px < 0) return fail("border_margin_px");
  if (!std::isfinite(min_peak_above_background_dn) || min_peak_above_background_dn < 0.0)
    return fail("min_peak_above_background_dn");
  if (saturation_dn < 0 || saturation_dn > 65535) return fail("saturation_dn");
  if (saturation_policy != SaturationPolicy::kAccept &&
      saturation_policy != SaturationPolicy::kFlag && saturation_policy != SaturationPolicy::kReject)
    return fail("saturation_policy");
  if (max_saturated_px < 0) return fail("max_saturated_px");
  if (!(max_elongation >= 1.0)) return fail("max_elongation");  // also rejects NaN
  if (max_blobs < 1 || max_blobs > limits::kMaxBlobsPerFrame) return fail("max_blobs");
  return true;
}

DetectCounters& DetectCounters::operator+=(const DetectCounters& o) {
  frames += o.frames;
  bad_frames += o.bad_frames;
  components += o.components;
  rejected_small += o.rejected_small;
  rejected_large += o.rejected_large;
  rejected_border += o.rejected_border;
  rejected_faint += o.rejected_faint;
  rejected_saturated += o.rejected_saturated;
  rejected_elongated += o.rejected_elongated;
  flagged_saturated += o.flagged_saturated;
  over_blob_limit += o.over_blob_limit;
  label_table_full += o.label_table_full;
  open_discarded += o.open_discarded;
  undistort_failures += o.undistort_failures;
  blank_frames += o.blank_frames;
  truncated_frames += o.truncated_frames;
  saturated_frames += o.saturated_frames;
  rejected_window_edge += o.rejected_window_edge;
  windows_dropped += o.windows_dropped;
  return *this;
}

// All working memory of a detector; one heap block reserved at construction.
struct detail::DetectWorkspace {
  int max_labels = 0;
  bool avx2 = false;  // the fast path's row skip on AVX2 vectors (QuietChunks, QuietRows)

  // Streaming components: runs of the previous and current row, the label table, its free
  // list, and the labels merged into another during the current row (freed at row end). The free
  // list holds the released labels; labels from next_fresh on were never used in this window, so
  // a window starts in O(1) (filling the 2048-entry list took microseconds a window) and hands out labels
  // in the order a list filled with max_labels - 1 .. 0 would: released ones first, then 0, 1, ...
  std::array<Run, limits::kMaxRunsPerRow> runs_a{};
  std::array<Run, limits::kMaxRunsPerRow> runs_b{};
  std::array<Component, limits::kMaxBlobLabels> comps{};
  std::array<int, limits::kMaxBlobLabels> free_labels{};
  int num_free = 0;
  int next_fresh = 0;
  std::array<int, limits::kMaxBlobLabels> merged{};
  int num_merged = 0;

  // Background mesh: tile backgrounds at tile centres (kFixed: one tile, the fixed level).
  int tile = 0;
  int nx = 0;
  int ny = 0;
  double contrast = 0.0;  // threshold - background (DN)
  std::array<double, kMeshSize> mesh_bg{};
  std::array<double, kMeshSize> mesh_sigma{};
  std::array<double, kMeshSize> mesh_tmp{};
  std::array<double, kMeshAxis> centre_x{};
  std::array<double, kMeshAxis> centre_y{};
  std::array<double, kMeshAxis> row_bg{};    // mesh interpolated to the current row
  std::array<double, kMeshAxis> point_bg{};  // scratch of BackgroundAt
  std::array<int, kMaxSegments> segment_thr{};  // the current row's thresholds (DN)
  std::array<int, limits::kMaxBackgroundSamplesPerTile> samples{};
  std::array<int, limits::kMaxBackgroundSamplesPerTile> differences{};
  std::array<int, limits::kMaxBackgroundSamplesPerTile> scratch{};
  std::array<int, kHistogramBins> histogram{};
  // Fast path, mono8: histograms of a tile's samples (value v at v) and differences (d at d + 255;
  // 512 bins, the last never used, for whole 16-bin blocks), filled while sampling; all zero
  // between tiles (each tile clears the bins of its range).
  std::array<int, 256> mono8_samples{};
  std::array<int, 512> mono8_differences{};
  // Background at each threshold segment's centre on each tile row: [ny][num_segments].
  std::array<double, kMeshAxis * kMaxSegments> segment_bg{};
  // Fast path: for the rows [band_first, band_last] (one pair of tile-centre rows), the lowest
  // threshold of each chunk's segments: no pixel at or below it is foreground there.
  std::array<int, kMaxChunks> chunk_lb{};
  int num_chunks = 0;
  int band_last = -1;
  // Fast path: the current row's bracket (row_a, row_b: segment backgrounds of its two tile-centre
  // rows, row_f the fraction between them), set by PrepareRowThresholds when a chunk needs them.
  const double* row_a = nullptr;
  const double* row_b = nullptr;
  double row_f = 0.0;

  // Windowed detection: the merged windows of the current call.
  std::array<PixelWindow, limits::kMaxDetectWindows> windows{};
  int num_windows = 0;

  // Per frame.
  int width = 0;
  int height = 0;
  int full_scale = 0;
  int saturation_level = 0;
  int segment_px = 0;  // kSegmentPx (kAdaptive) or the frame width (kFixed)
  int num_segments = 0;

  // The component of label l (labels are ints, -1 for none; here l >= 0).
  Component& Comp(int l) { return comps[static_cast<std::size_t>(l)]; }

  int Find(int a) {
    // Path halving; depth is small because labels merged in a row are freed at its end.
    for (int i = 0; i < max_labels && Comp(a).parent != a; ++i) {
      Comp(a).parent = Comp(Comp(a).parent).parent;
      a = Comp(a).parent;
    }
    return a;
  }

  // Every label free (the start of a window).
  void FreeAll() {
    num_free = 0;
    next_fresh = 0;
  }

  // Labels in use (open components and those merged in the current row).
  int LabelsInUse() const { return next_fresh - num_free; }

  int Alloc(int y) {
    if (num_free == 0 && next_fresh == max_labels) return -1;
    const int l = num_free > 0 ? free_labels[static_cast<std::size_t>(--num_free)] : next_fresh++;
    Comp(l) = Component{0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 0, 0, width, -1, height, -1, l, y};
    return l;
  }

  void Release(int l) { free_labels[static_cast<std::size_t>(num_free++)] = l; }

  // Joins the components of labels a and b; returns the surviving root.
  int Union(int a, int b) {
    const int ra = Find(a);
    const int rb = Find(b);
    if (ra == rb) return ra;
    AddComponent(&Comp(ra), Comp(rb));
    Comp(rb).parent = ra;
    merged[static_cast<std::size_t>(num_merged++)] = rb;
    return ra;
  }

  // Fills out[i], i < nx, with the mesh interpolated (vertically) to row y.
  void MeshAtRow(double y, double* out) const {
    int j = 0;
    double f = 0.0;
    Bracket(centre_y.data(), ny, tile, y, &j, &f);
    for (int i = 0; i < nx; ++i) {
      const double a = mesh_bg[static_cast<std::size_t>(j * nx + i)];
      out[i] = ny == 1 ? a : a + f * (mesh_bg[static_cast<std::size_t>((j + 1) * nx + i)] - a);
    }
  }

  double BackgroundAt(double x, double y) {
    MeshAtRow(y, point_bg.data());
    return Interpolate(centre_x.data(), point_bg.data(), nx, tile, x);
  }

  double RowBackground(int x) const { return Interpolate(centre_x.data(), row_bg.data(), nx, tile, x); }

  // After the mesh is final: the background at every segment centre on every tile row.
  // (Interpolate's arithmetic, with each segment's bracket found once for all tile rows.)
  void PrepareSegments() {
    for (int k = 0; k < num_segments; ++k) {
      const int x0 = k * segment_px, x1 = std::min(x0 + segment_px, width);
      int i = 0;
      double f = 0.0;
      Bracket(centre_x.data(), nx, tile, 0.5 * (x0 + x1 - 1), &i, &f);
      for (int j = 0; j < ny; ++j) {
        const double* v = mesh_bg.data() + j * nx + i;
        segment_bg[static_cast<std::size_t>(j * num_segments + k)] = nx == 1 ? v[0] : v[0] + f * (v[1] - v[0]);
      }
    }
  }

  // Row y's background (row_bg) and, in kAdaptive, its segment thresholds.
  void PrepareRow(int y, bool adaptive) {
    MeshAtRow(y, row_bg.data());
    if (!adaptive) return;
    int j = 0;
    double f = 0.0;
    Bracket(centre_y.data(), ny, tile, y, &j, &f);
    const double* a = segment_bg.data() + j * num_segments;
    const double* b = ny == 1 ? a : a + num_segments;
    const double top = full_scale;
    for (int k = 0; k < num_segments; ++k)
      segment_thr[static_cast<std::size_t>(k)] = SegmentThresholdOf(a[k], b[k], f, contrast, top);
  }

  // Fast path, kAdaptive: the bracket of row y, for SegmentThreshold.
  void PrepareRowThresholds(int y) {
    int j = 0;
    Bracket(centre_y.data(), ny, tile, y, &j, &row_f);
    row_a = segment_bg.data() + j * num_segments;
    row_b = ny == 1 ? row_a : row_a + num_segments;
  }

  // Fast path: the threshold of segment k on the row of the last PrepareRowThresholds (kAdaptive)
  // or the fixed threshold; equal to PrepareRow's segment_thr[k].
  int SegmentThreshold(int k, bool adaptive) const {
    if (!adaptive) return segment_thr[0];
    const auto i = static_cast<std::size_t>(k);
    return SegmentThresholdOf(row_a[i], row_b[i], row_f, contrast, full_scale);
  }

  // Fast path, from row y (the first row not yet in a band): the band of rows that share y's pair
  // of tile-centre rows, and the lowest threshold of each chunk over it. Along a band a segment's
  // threshold is a monotone function of the row (f grows with y, and each rounding step and the
  // clamp are monotone), so its lowest value is at the band's first or last row: chunk_lb is a
  // true lower bound of every threshold PrepareRow would give there.
  void PrepareBand(int y, bool adaptive) {
    num_chunks = (width + kChunkPx - 1) / kChunkPx;
    if (!adaptive) {
      std::fill_n(chunk_lb.begin(), num_chunks, segment_thr[0]);
      band_last = height - 1;
      return;
    }
    int j = 0, j_last = 0;
    double f = 0.0, f_last = 0.0;
    Bracket(centre_y.data(), ny, tile, y, &j, &f);
    // Bracket takes the last centre at or above the row (at most ny - 2): the band ends before the
    // next centre, or at the frame's end.
    band_last =
        j + 1 <= ny - 2 ? static_cast<int>(std::ceil(centre_y[static_cast<std::size_t>(j + 1)])) - 1 : height - 1;
    band_last = std::clamp(band_last, y, height - 1);
    Bracket(centre_y.data(), ny, tile, band_last, &j_last, &f_last);
    if (j_last != j) {  // not expected; a one-row band is always right
      band_last = y;
      f_last = f;
    }
    const double* a = segment_bg.data() + j * num_segments;
    const double* b = ny == 1 ? a : a + num_segments;
    const double top = full_scale;
    constexpr int kPerChunk = kChunkPx / kSegmentPx;
    for (int c = 0; c < num_chunks; ++c) {
      int lb = full_scale;
      for (int k = c * kPerChunk; k < std::min((c + 1) * kPerChunk, num_segments); ++k) {
        const auto i = static_cast<std::size_t>(k);
        lb = std::min({lb, SegmentThresholdOf(a[i], b[i], f, contrast, top),
                       SegmentThresholdOf(a[i], b[i], f_last, contrast, top)});
      }
      chunk_lb[static_cast<std::size_t>(c)] = lb;
    }
  }
};

BlobDetector::BlobDetector(const DetectOptions& options, int max_labels)
    : options_(options), options_valid_(options.IsValid()), ws_(new detail::DetectWorkspace) {
  ws_->max_labels = std::clamp(max_labels, 1, limits::kMaxBlobLabels);
  ws_->avx2 = options.use_avx2 && CpuHasAvx2();
}

BlobDetector::~BlobDetector() = default;
int BlobDetector::vector_bytes() const { return ws_ != nullptr && ws_->avx2 ? 32 : 16; }
BlobDetector::BlobDetector(BlobDetector&&) noexcept = default;
BlobDetector& BlobDetector::operator=(BlobDetector&&) noexcept = default;

namespace {

// One frame through the detector, with the pixel type as a template parameter.
template <typename RowT>
class FramePass {
 public:
  FramePass(const DetectOptions& o, detail::DetectWorkspace& ws, const FrameView& f, BlobList* out)
      : o_(o), ws_(ws), f_(f), out_(out) {}

  void SetUpFixed();
  void EstimateBackground();
  // Labels the components inside window r (the whole frame: every row, every column). With
  // `windowed`, a component touching r's edge inside the frame is rejected.
  DetectStatus Label(const PixelWindow& r, bool windowed);

 private:
  RowT Row(int y) const { return RowT{f_.data + static_cast<std::ptrdiff_t>(y) * f_.stride_bytes}; }
  bool Adaptive() const { return o_.threshold_mode == ThresholdMode::kAdaptive; }
  template <typename Visit>
  void ForEachSample(int x0, int x1, int y0, int y1, Visit&& visit) const;
  int ScanRow(int y, int xa, int xb, Run* runs) const;
  int ScanRowFast(int y, int xa, int xb, Run* runs) const;
  void Accumulate(const Run& run, int y, Component* c) const;
  int SampleHistogramsMono8(int x0, int x1, int y0, int y1, int* hs, int* hd) const;
  void Close(const Component& c);
  void Emit(const Blob& b);

  const DetectOptions& o_;
  detail::DetectWorkspace& ws_;
  const FrameView& f_;
  BlobList* out_;
  PixelWindow window_;     // of the current Label
  bool windowed_ = false;  // Label's `windowed`
};

template <typename RowT>
void FramePass<RowT>::SetUpFixed() {
  ws_.tile = std::max(f_.width, f_.height);
  ws_.nx = ws_.ny = 1;
  ws_.centre_x[0] = 0.5 * (f_.width - 1);
  ws_.centre_y[0] = 0.5 * (f_.height - 1);
  ws_.mesh_bg[0] = o_.fixed_background_dn;
  ws_.contrast = o_.fixed_threshold_dn - o_.fixed_background_dn;
  ws_.segment_px = f_.width;
  ws_.num_segments = 1;
  ws_.segment_thr[0] = o_.fixed_threshold_dn;  // exactly, whatever the background
  out_->background_dn = o_.fixed_background_dn;
  out_->noise_dn = 0.0;
  out_->contrast_dn = ws_.contrast;
  out_->threshold_min_dn = out_->threshold_max_dn = o_.fixed_threshold_dn;
}

// Calls visit(v, d) for each background sample of the tile [x0, x1) x [y0, y1): the pixel v of
// the grid every sample_step_px-th pixel of every sample_step_px-th row, centred in the tile (a
// partial edge tile still gets one sample per axis), and d = v - its right neighbour (the left
// one in the last column; 0 in a one-pixel-wide frame), which measures noise without the
// background's slope.
template <typename RowT>
template <typename Visit>
void FramePass<RowT>::ForEachSample(int x0, int x1, int y0, int y1, Visit&& visit) const {
  const int step = o_.sample_step_px;
  const int ox = std::min(step / 2, (x1 - x0 - 1) / 2);
  const int oy = std::min(step / 2, (y1 - y0 - 1) / 2);
  for (int y = y0 + oy; y < y1; y += step) {
    const RowT row = Row(y);
    int x = x0 + ox;
    for (const int x_inner = std::min(x1, f_.width - 1); x < x_inner; x += step) visit(row[x], row[x] - row[x + 1]);
    for (; x < x1; x += step) {
      const int xn = x + 1 < f_.width ? x + 1 : x - 1;
      visit(row[x], xn >= 0 ? row[x] - row[xn] : 0);
    }
  }
}

// Mono8, fast path: ForEachSample's samples v and differences dv counted into hs[v] and hd[dv]
// (the same samples; two a step, the loads of the second independent of the first's counts);
// returns how many.
template <typename RowT>
int FramePass<RowT>::SampleHistogramsMono8(int x0, int x1, int y0, int y1, int* hs, int* hd) const {
  const int step = o_.sample_step_px, width = f_.width;
  const int ox = std::min(step / 2, (x1 - x0 - 1) / 2), oy = std::min(step / 2, (y1 - y0 - 1) / 2);
  const int x_inner = std::min(x1, width - 1);  // samples left of it have a right neighbour
  int n = 0;
  for (int y = y0 + oy; y < y1; y += step) {
    const std::uint8_t* row = Row(y).p;
    int x = x0 + ox;
    for (; x + step < x_inner; x += 2 * step, n += 2) {
      const int a = row[x], an = row[x + 1], b = row[x + step], bn = row[x + step + 1];
      ++hs[a];
      ++hd[a - an];
      ++hs[b];
      ++hd[b - bn];
    }
    for (; x < x1; x += step, ++n) {
      const int xn = x + 1 < width ? x + 1 : x - 1;  // the last column: its left neighbour (none: 0)
      ++hs[row[x]];
      ++hd[xn >= 0 ? row[x] - row[xn] : 0];
    }
  }
  return n;
}

template <typename RowT>
void FramePass<RowT>::EstimateBackground() {
  const int T = o_.tile_px;
  ws_.tile = T;
  ws_.nx = (f_.width + T - 1) / T;
  ws_.ny = (f_.height + T - 1) / T;
  ws_.segment_px = kSegmentPx;
  ws_.num_segments = (f_.width + kSegmentPx - 1) / kSegmentPx;
  const int nx = ws_.nx;
  const int ny = ws_.ny;
  for (int i = 0; i < nx; ++i)
    ws_.centre_x[static_cast<std::size_t>(i)] = 0.5 * (i * T + std::min((i + 1) * T, f_.width) - 1);
  for (int j = 0; j < ny; ++j)
    ws_.centre_y[static_cast<std::size_t>(j)] = 0.5 * (j * T + std::min((j + 1) * T, f_.height) - 1);

  const int max_abs = f_.format == PixelFormat::kMono8 ? 255 : 0;  // mono16: find the range
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const int x0 = i * T, x1 = std::min(x0 + T, f_.width);
      const int y0 = j * T, y1 = std::min(y0 + T, f_.height);
      // Value ranges: [s_lo, s_hi] of the samples, [-d_abs, d_abs] of the differences.
      int n = 0, s_lo = ws_.full_scale, s_hi = 0, d_abs = 0;
      const auto range = [&](int v, int dv) {
        s_lo = std::min(s_lo, v);
        s_hi = std::max(s_hi, v);
        d_abs = std::max(d_abs, std::abs(dv));
        ++n;
      };
      double level = 0.0, spread = 0.0, diff_mean = 0.0, diff_rms = 0.0;
      if (!o_.reference_path && RowT::kFullScale == 255) {
        // Mono8, fast path: histograms filled while sampling; the bins used are cleared after.
        // The value ranges come from the histograms afterwards (BlockRangeOfHistogram), not from
        // each sample: the sampling loop is the detector's hottest after the row skip.
        int* const hs = ws_.mono8_samples.data();
        int* const hd = ws_.mono8_differences.data() + 255;
        n = SampleHistogramsMono8(x0, x1, y0, y1, hs, hd);
        BlockRangeOfHistogram(hs, 256, &s_lo, &s_hi);
        int d_lo = 0, d_hi = 0;
        BlockRangeOfHistogram(hd - 255, 512, &d_lo, &d_hi);
        d_abs = std::min(std::max(255 - d_lo, d_hi - 255), 255);  // |d| <= 255: bin 511 is never used
        HistogramClippedMeanRms(hs + s_lo, s_hi - s_lo + 1, n, s_lo, &level, &spread);
        HistogramClippedMeanRms(hd - d_abs, 2 * d_abs + 1, n, -d_abs, &diff_mean, &diff_rms);
        std::fill(hs + s_lo, hs + s_hi + 1, 0);
        std::fill(hd - d_abs, hd + d_abs + 1, 0);
      } else {
        ForEachSample(x0, x1, y0, y1, [&](int v, int dv) {
          ws_.samples[static_cast<std::size_t>(n)] = v;
          ws_.differences[static_cast<std::size_t>(n)] = dv;
          range(v, dv);
        });
        int* const hist = ws_.histogram.data();
        const bool fast = !o_.reference_path;
        if (!fast || !HistogramClippedMeanRms(ws_.samples.data(), n, s_lo, s_hi, hist, &level, &spread))
          ClippedMeanRms(ws_.samples.data(), n, max_abs, hist, ws_.scratch.data(), &level, &spread);
        if (!fast || !HistogramClippedMeanRms(ws_.differences.data(), n, -d_abs, d_abs, hist, &diff_mean, &diff_rms))
          ClippedMeanRms(ws_.differences.data(), n, max_abs, hist, ws_.scratch.data(), &diff_mean, &diff_rms);
      }
      const auto cell = static_cast<std::size_t>(j * nx + i);
      ws_.mesh_bg[cell] = level;
      ws_.mesh_sigma[cell] = diff_rms / std::numbers::sqrt2;  // var(a - b) = 2 var(a)
    }
  }

  const int cells = nx * ny;
  if (o_.mesh_median_filter && nx >= 3 && ny >= 3) {
    // 3x3 median over interior tiles: a tile filled by a bright object takes its neighbours'.
    std::copy_n(ws_.mesh_bg.begin(), cells, ws_.mesh_tmp.begin());
    for (int j = 1; j + 1 < ny; ++j) {
      for (int i = 1; i + 1 < nx; ++i) {
        std::array<double, 9> w{};
        std::size_t k = 0;
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) w[k++] = ws_.mesh_tmp[static_cast<std::size_t>((j + dj) * nx + (i + di))];
        ws_.mesh_bg[static_cast<std::size_t>(j * nx + i)] = MedianOf9(w);
      }
    }
  }

  // Frame noise: the median of the tiles' (read noise dominates a dark frame).
  std::copy_n(ws_.mesh_sigma.begin(), cells, ws_.mesh_tmp.begin());
  std::nth_element(ws_.mesh_tmp.begin(), ws_.mesh_tmp.begin() + cells / 2, ws_.mesh_tmp.begin() + cells);
  const double noise = ws_.mesh_tmp[static_cast<std::size_t>(cells / 2)];
  ws_.contrast = std::max(o_.k_sigma * noise, o_.min_contrast_dn);

  std::copy_n(ws_.mesh_bg.begin(), cells, ws_.mesh_tmp.begin());
  const auto [lo, hi] = std::minmax_element(ws_.mesh_tmp.begin(), ws_.mesh_tmp.begin() + cells);
  const double bg_min = *lo, bg_max = *hi;
  std::nth_element(ws_.mesh_tmp.begin(), ws_.mesh_tmp.begin() + cells / 2, ws_.mesh_tmp.begin() + cells);
  out_->background_dn = ws_.mesh_tmp[static_cast<std::size_t>(cells / 2)];
  out_->noise_dn = noise;
  out_->contrast_dn = ws_.contrast;
  const auto clamp_thr = [this](double t) {
    return static_cast<int>(std::clamp(std::floor(t + ws_.contrast), 0.0, static_cast<double>(ws_.full_scale)));
  };
  out_->threshold_min_dn = clamp_thr(bg_min);
  out_->threshold_max_dn = clamp_thr(bg_max);
  ws_.PrepareSegments();
}

// Finds the runs of row y (pixel > threshold of its segment); returns how many
// (<= (width + 1) / 2). Background is skipped a vector block at a time.
// The runs of pixels > t in [x, x1) of one row, continuing the run that starts at *start (-1:
// none open); closed runs are appended to runs[*n].
template <typename RowT>
void ScanSpan(const RowT& row, int x, int x1, int t, int* start, Run* runs, int* n) {
  while (x < x1) {
    if (*start < 0) {
      while (x + RowT::kBlock <= x1 && !row.AnyAbove(x, t)) x += RowT::kBlock;
      while (x < x1 && row[x] <= t) ++x;
      if (x < x1) *start = x;
    } else {
      while (x < x1 && row[x] > t) ++x;
      if (x < x1) {
        runs[(*n)++] = Run{*start, x - 1, -1};
        *start = -1;
      }
    }
  }
}

// The runs of row y within columns [xa, xb).
template <typename RowT>
int FramePass<RowT>::ScanRow(int y, int xa, int xb, Run* runs) const {
  const RowT row = Row(y);
  const int L = ws_.segment_px;
  int n = 0;
  int start = -1;
  for (int k = xa / L; k * L < xb; ++k)
    ScanSpan(row, std::max(k * L, xa), std::min((k + 1) * L, xb), ws_.segment_thr[static_cast<std::size_t>(k)], &start,
             runs, &n);
  if (start >= 0) runs[n++] = Run{start, xb - 1, -1};
  return n;
}

// ScanRow's runs, the same ones: a whole chunk with no pixel above its lower bound (chunk_lb of
// the row's band) holds no foreground and ends an open run at its first pixel; any other chunk is
// scanned segment by segment with the exact thresholds, computed for this row only then.
template <typename RowT>
int FramePass<RowT>::ScanRowFast(int y, int xa, int xb, Run* runs) const {
  const RowT row = Row(y);
  const int L = ws_.segment_px;
  int n = 0;
  int start = -1;
  bool thresholds_ready = false;
  // Chunks [first_full, end_full) lie wholly in [xa, xb); only those are skipped whole.
  const int first_full = (xa + kChunkPx - 1) / kChunkPx, end_full = xb / kChunkPx;
  for (int c = xa / kChunkPx; c * kChunkPx < xb; ++c) {
    const int cx0 = std::max(c * kChunkPx, xa), cx1 = std::min((c + 1) * kChunkPx, xb);
    const int quiet = c >= first_full && c < end_full
                          ? QuietChunks<typename RowT::Lane>(ws_.avx2, row.p, ws_.chunk_lb.data(), c, end_full)
                          : 0;
    if (quiet > 0) {
      if (start >= 0) {
        runs[n++] = Run{start, cx0 - 1, -1};
        start = -1;
      }
      c += quiet - 1;
      continue;
    }
    if (Adaptive() && !thresholds_ready) {
      ws_.PrepareRowThresholds(y);
      thresholds_ready = true;
    }
    for (int k = cx0 / L; k * L < cx1; ++k)
      ScanSpan(row, std::max(k * L, cx0), std::min((k + 1) * L, cx1), ws_.SegmentThreshold(k, Adaptive()), &start, runs,
               &n);
  }
  if (start >= 0) runs[n++] = Run{start, xb - 1, -1};
  return n;
}

// Adds the pixels of one run in row y to component c (row prepared for y).
template <typename RowT>
void FramePass<RowT>::Accumulate(const Run& run, int y, Component* c) const {
  const RowT row = Row(y);
  double s0 = 0.0, sx = 0.0, sxx = 0.0, flux = 0.0;
  int peak = c->peak, saturated = 0;
  for (int x = run.x0; x <= run.x1; ++x) {
    const int p = row[x];
    const double bg = ws_.RowBackground(x);
    const double above_bg = std::max(p - bg, 0.0);
    double w = above_bg;
    if (o_.centroid_weights == CentroidWeights::kRaw) {
      w = p;
    } else if (o_.centroid_weights == CentroidWeights::kAboveThreshold) {
      // In kFixed the threshold is fixed_threshold_dn exactly (= background + contrast).
      w = Adaptive() ? std::max(p - (bg + ws_.contrast), 0.0)
                     : std::max(p - static_cast<double>(o_.fixed_threshold_dn), 0.0);
    }
    s0 += w;
    sx += w * x;
    sxx += w * x * x;
    flux += above_bg;
    peak = std::max(peak, p);
    saturated += p >= ws_.saturation_level ? 1 : 0;
  }
  c->s0 += s0;
  c->sx += sx;
  c->sxx += sxx;
  c->sy += s0 * y;
  c->syy += s0 * y * y;
  c->sxy += sx * y;
  c->flux += flux;
  c->area += run.x1 - run.x0 + 1;
  c->peak = peak;
  c->saturated += saturated;
  c->x_min = std::min(c->x_min, run.x0);
  c->x_max = std::max(c->x_max, run.x1);
  c->y_min = std::min(c->y_min, y);
  c->y_max = std::max(c->y_max, y);
}

// A component is complete: measure it, gate it, keep it if it passes.
template <typename RowT>
void FramePass<RowT>::Close(const Component& c) {
  DetectCounters& k = out_->counters;
  ++k.components;
  const PixelWindow& win = window_;
  if (windowed_ && ((c.x_min == win.x0 && win.x0 > 0) || (c.y_min == win.y0 && win.y0 > 0) ||
                    (c.x_max == win.x1 - 1 && win.x1 < f_.width) || (c.y_max == win.y1 - 1 && win.y1 < f_.height))) {
    ++k.rejected_window_edge;  // may continue outside the window: not the whole component
    return;
  }
  if (c.area < o_.min_area_px) {
    ++k.rejected_small;
    return;
  }
  if (c.area > o_.max_area_px) {
    ++k.rejected_large;
    return;
  }
  const int m = o_.border_margin_px;
  if (o_.reject_border && (c.x_min <= m || c.y_min <= m || c.x_max >= f_.width - 1 - m ||
                           c.y_max >= f_.height - 1 - m)) {
    ++k.rejected_border;
    return;
  }
  Blob b;
  if (c.s0 > 0.0) {
    b.uv_px = Eigen::Vector2d(c.sx / c.s0, c.sy / c.s0);
  } else {
    b.uv_px = Eigen::Vector2d(0.5 * (c.x_min + c.x_max), 0.5 * (c.y_min + c.y_max));
  }
  b.background_dn = ws_.BackgroundAt(b.uv_px.x(), b.uv_px.y());
  b.peak_dn = c.peak;
  if (!(c.s0 > 0.0) || c.peak - b.background_dn < o_.min_peak_above_background_dn) {
    ++k.rejected_faint;
    return;
  }
  b.saturated_px = c.saturated;
  if (c.saturated > o_.max_saturated_px) {
    if (o_.saturation_policy == SaturationPolicy::kReject) {
      ++k.rejected_saturated;
      return;
    }
    if (o_.saturation_policy == SaturationPolicy::kFlag) b.saturated = true;
  }
  b.m_xx = std::max(c.sxx / c.s0 - b.uv_px.x() * b.uv_px.x(), 0.0);
  b.m_yy = std::max(c.syy / c.s0 - b.uv_px.y() * b.uv_px.y(), 0.0);
  b.m_xy = c.sxy / c.s0 - b.uv_px.x() * b.uv_px.y();
  // Eigenvalues of the 2x2 symmetric moment matrix (+ a pixel's own variance), closed form.
  const double a = b.m_xx + kPixelVariance, d = b.m_yy + kPixelVariance;
  const double half_trace = 0.5 * (a + d);
  const double r = std::sqrt(0.25 * (a - d) * (a - d) + b.m_xy * b.m_xy);
  const double l_min = std::max(half_trace - r, 1e-12);
  b.elongation = std::sqrt((half_trace + r) / l_min);
  if (b.elongation > o_.max_elongation) {
    ++k.rejected_elongated;
    return;
  }
  if (b.saturated) ++k.flagged_saturated;
  b.flux_dn = c.flux;
  b.area_px = c.area;
  b.x_min = c.x_min;
  b.x_max = c.x_max;
  b.y_min = c.y_min;
  b.y_max = c.y_max;
  Emit(b);
}

// Keeps the max_blobs brightest: when full, the faintest is replaced by a brighter newcomer.
template <typename RowT>
void FramePass<RowT>::Emit(const Blob& b) {
  if (out_->count < o_.max_blobs) {
    out_->blobs[static_cast<std::size_t>(out_->count++)] = b;
    return;
  }
  ++out_->counters.over_blob_limit;
  std::size_t faintest = 0;
  for (std::size_t i = 1; i < static_cast<std::size_t>(out_->count); ++i)
    if (BrighterFirst(out_->blobs[faintest], out_->blobs[i])) faintest = i;
  if (BrighterFirst(b, out_->blobs[faintest])) out_->blobs[faintest] = b;
}

// Streaming 8-connected labelling, one row at a time. A component is closed (measured and
// freed) at the end of the first row that does not continue it.
template <typename RowT>
DetectStatus FramePass<RowT>::Label(const PixelWindow& win, bool windowed) {
  detail::DetectWorkspace& w = ws_;
  window_ = win;
  windowed_ = windowed;
  // Every label is free at the start of a window (the previous one closed all of its own).
  w.FreeAll();
  Run* prev = w.runs_a.data();
  Run* cur = w.runs_b.data();
  int n_prev = 0;

  const bool fast = !o_.reference_path;
  // Fast path: with no run open above, rows whose chunks are all quiet are skipped a band at a
  // time (QuietRows); only when the window is whole chunks (the full frame of a width that is a
  // multiple of kChunkPx), since a partial chunk is scanned exactly in every row.
  const bool whole_chunks = fast && win.x0 % kChunkPx == 0 && win.x1 % kChunkPx == 0;
  const int c0 = win.x0 / kChunkPx, c1 = win.x1 / kChunkPx;
  w.band_last = win.y0 - 1;
  for (int y = win.y0; y < win.y1; ++y) {
    if (fast && y > w.band_last) w.PrepareBand(y, Adaptive());
    if (whole_chunks && n_prev == 0) {
      const int rows = std::min(w.band_last, win.y1 - 1) - y + 1;
      const int quiet =
          QuietRows<typename RowT::Lane>(w.avx2, Row(y).p, f_.stride_bytes, rows, w.chunk_lb.data(), c0, c1);
      if (quiet > 0) {  // no foreground in rows [y, y + quiet): nothing to label, nothing to close
        y += quiet - 1;
        continue;
      }
    }
    if (!fast && Adaptive()) w.PrepareRow(y, true);
    const int n_cur = fast ? ScanRowFast(y, win.x0, win.x1, cur) : ScanRow(y, win.x0, win.x1, cur);
    w.num_merged = 0;
    // The background along the row (Accumulate) only where there are runs.
    if (n_cur > 0 && (fast || !Adaptive())) w.PrepareRow(y, false);
    int j = 0;  // first previous run that may touch the current one
    for (int r = 0; r < n_cur; ++r) {
      Run& run = cur[r];
      // 8-connectivity: [x0, x1] touches [p0, p1] when p0 <= x1 + 1 and p1 >= x0 - 1.
      while (j < n_prev && prev[j].x1 < run.x0 - 1) ++j;
      int label = -1;
      for (int k = j; k < n_prev && prev[k].x0 <= run.x1 + 1; ++k)
        label = label < 0 ? w.Find(prev[k].label) : w.Union(label, prev[k].label);
      if (label < 0) {
        label = w.Alloc(y);
        if (label < 0) {
          // Out of labels: the frame is cut here; components still open are incomplete.
          ++out_->counters.label_table_full;
          out_->counters.open_discarded += static_cast<std::uint64_t>(w.LabelsInUse() - w.num_merged);
          return DetectStatus::kLabelTableFull;
        }
      }
      run.label = label;
      Accumulate(run, y, &w.Comp(label));
    }
    // Resolve the current runs to their roots and mark those roots as continuing.
    for (int r = 0; r < n_cur; ++r) {
      cur[r].label = w.Find(cur[r].label);
      w.Comp(cur[r].label).stamp = y;
    }
    // Roots of the previous row not continued in this one are complete.
    for (int k = 0; k < n_prev; ++k) {
      const int root = w.Find(prev[k].label);
      if (w.Comp(root).stamp != y) {
        w.Comp(root).stamp = y;  // closed once even when several runs point to it
        Close(w.Comp(root));
        w.Release(root);
      }
    }
    for (int m = 0; m < w.num_merged; ++m) w.Release(w.merged[static_cast<std::size_t>(m)]);
    std::swap(prev, cur);
    n_prev = n_cur;
  }
  for (int k = 0; k < n_prev; ++k) {
    const int root = prev[k].label;  // resolved at the end of the last row
    if (w.Comp(root).stamp != win.y1) {
      w.Comp(root).stamp = win.y1;
      Close(w.Comp(root));
      w.Release(root);
    }
  }
  return DetectStatus::kOk;
}

int SaturationLevel(const DetectOptions& o, const FrameView& f) {
  return o.saturation_dn > 0 ? o.saturation_dn : f.format == PixelFormat::kMono8 ? 255 : 65535;
}

// Detection in the whole frame (`windowed` false) or in ws.windows[0, ws.num_windows).
template <typename RowT>
DetectStatus DetectTyped(const DetectOptions& o, detail::DetectWorkspace& ws, const FrameView& f, bool windowed,
                         BlobList* out) {
  ws.width = f.width;
  ws.height = f.height;
  ws.full_scale = f.format == PixelFormat::kMono8 ? 255 : 65535;
  ws.saturation_level = SaturationLevel(o, f);
  FramePass<RowT> pass(o, ws, f, out);
  if (o.threshold_mode == ThresholdMode::kAdaptive) {
    pass.EstimateBackground();
  } else {
    pass.SetUpFixed();
  }
  if (!windowed) return pass.Label(PixelWindow{0, 0, f.width, f.height}, false);
  for (int i = 0; i < ws.num_windows; ++i) {
    PixelWindow r = ws.windows[static_cast<std::size_t>(i)];
    r.y1 = std::min(r.y1, f.height);  // a truncated frame ends above
    if (r.y0 >= r.y1) continue;
    const DetectStatus s = pass.Label(r, true);
    if (s != DetectStatus::kOk) return s;
  }
  return DetectStatus::kOk;
}

// Clips windows to the frame and merges those that overlap or touch (8-connectivity: one pixel
// apart) into their bounding box, until none do; stores them in ws.windows. Returns how many
// were dropped (empty after clipping, or beyond kMaxDetectWindows).
int MergeWindows(const PixelWindow* in, int n, int width, int height, detail::DetectWorkspace& ws) {
  int dropped = 0, m = 0;
  for (int i = 0; i < std::max(n, 0); ++i) {
    if (i >= limits::kMaxDetectWindows) {
      dropped += n - i;
      break;
    }
    PixelWindow r = in[i];
    r.x0 = std::max(r.x0, 0);
    r.y0 = std::max(r.y0, 0);
    r.x1 = std::min(r.x1, width);
    r.y1 = std::min(r.y1, height);
    if (r.x0 >= r.x1 || r.y0 >= r.y1) {
      ++dropped;
      continue;
    }
    ws.windows[static_cast<std::size_t>(m++)] = r;
  }
  // Each merge removes a window: at most m - 1 merges, each found in at most m^2 pairs.
  const auto near = [](const PixelWindow& a, const PixelWindow& b) {
    return a.x0 <= b.x1 && b.x0 <= a.x1 && a.y0 <= b.y1 && b.y0 <= a.y1;
  };
  for (bool merged = true; merged;) {
    merged = false;
    for (int i = 0; i < m && !merged; ++i) {
      for (int j = i + 1; j < m && !merged; ++j) {
        PixelWindow& a = ws.windows[static_cast<std::size_t>(i)];
        const PixelWindow b = ws.windows[static_cast<std::size_t>(j)];
        if (!near(a, b)) continue;
        a = PixelWindow{std::min(a.x0, b.x0), std::min(a.y0, b.y0), std::max(a.x1, b.x1), std::max(a.y1, b.y1)};
        ws.windows[static_cast<std::size_t>(j)] = ws.windows[static_cast<std::size_t>(--m)];
        merged = true;
      }
    }
  }
  ws.num_windows = m;
  return dropped;
}

bool FrameIsValid(const FrameView& f) {
  if (f.data == nullptr) return false;
  if (f.format != PixelFormat::kMono8 && f.format != PixelFormat::kMono16) return false;
  if (f.width <= 0 || f.height <= 0) return false;
  if (f.width > limits::kMaxImageWidth || f.height > limits::kMaxImageHeight) return false;
  return f.stride_bytes >= f.width * BytesPerPixel(f.format);
}

}  // namespace

namespace {
// The truncation rule (BlobDetector::Detect): at least this many uniform rows at the bottom (fewer
// are too little image to matter, and one uniform row can be a sensor's defect), judged against
// this many rows above them.
constexpr int kMinUnwrittenRows = 4;
constexpr int kWrittenProbeRows = 4;

// Pixels of row y in [x0, x1) that differ from v.
template <typename RowT>
int CountDiffering(const FrameView& f, int y, int x0, int x1, int v) {
  const RowT row{f.data + static_cast<std::ptrdiff_t>(y) * f.stride_bytes};
  int n = 0;
  for (int x = x0; x < x1; ++x) n += row[x] != v ? 1 : 0;
  return n;
}

// The rows to detect in: the frame's height, or for a truncated frame the rows above the first
// unwritten one but one (see Detect in detect.h). Bounded by the frame's pixels; a whole frame
// stops at its bottom row's first pixels that differ.
template <typename RowT>
int WrittenRows(const FrameView& f, int saturation_level) {
  const int fill = RowT{f.data + static_cast<std::ptrdiff_t>(f.height - 1) * f.stride_bytes}[0];
  if (fill >= saturation_level) return f.height;
  int y = f.height - 1;
  while (y >= 0 && CountDiffering<RowT>(f, y, 0, f.width, fill) == 0) --y;
  if (f.height - 1 - y < kMinUnwrittenRows || y < 1) return f.height;
  const int probe0 = std::max(0, y - kWrittenProbeRows);
  int differing = 0;
  for (int r = probe0; r < y; ++r) differing += CountDiffering<RowT>(f, r, 0, f.width, fill);
  return 2 * differing >= (y - probe0) * f.width ? y : f.height;
}

// Blind cells (BlobList::blind_cells): cells below rows_written, and cells a saturated block
// touches. A block is 32 x 32 px sampled every 8 px (16 samples); it is saturated when half its
// samples are: an LED's own saturated core (a few px) touches a sample or two and never blinds
// its cell, a lamp or a window of 16 px and more does. Cells are coarse (a sixth of the image):
// a beacon predicted anywhere in a cell a block touches is not missing, at the cost of that
// cell's evidence against a wrong pose. Work: width x height / 64 samples, in every 8th row
// (detect_benchmark, 1280 x 1024 mono8, with the truncation test: +0.01-0.03 ms a frame, on
// 0.05 ms fixed and 0.72 ms adaptive).
constexpr int kBlindBlockPx = 32;
constexpr int kBlindSampleStepPx = 8;

std::uint32_t CellsOfBox(const FrameView& f, int x0, int y0, int x1, int y1) {
  const int c0 = BlindCellOf(x0, y0, f.width, f.height), c1 = BlindCellOf(x1, y1, f.width, f.height);
  std::uint32_t cells = 0;
  for (int cy = c0 / limits::kBlindCellsX; cy <= c1 / limits::kBlindCellsX; ++cy)
    for (int cx = c0 % limits::kBlindCellsX; cx <= c1 % limits::kBlindCellsX; ++cx)
      cells |= std::uint32_t{1} << (cy * limits::kBlindCellsX + cx);
  return cells;
}

// Whether any pixel of row y is >= level (whole kChunkPx-pixel chunks by ChunkAbove, then the rest).
template <typename RowT>
bool RowReaches(const FrameView& f, int y, int level) {
  const RowT row{f.data + static_cast<std::ptrdiff_t>(y) * f.stride_bytes};
  int x = 0;
  for (; x + kChunkPx <= f.width; x += kChunkPx)
    if (row.AnyAboveChunk(x, level - 1)) return true;
  for (; x < f.width; ++x)
    if (row[x] >= level) return true;
  return false;
}

template <typename RowT>
std::uint32_t SaturatedCells(const FrameView& f, int rows, int saturation_level) {
  constexpr int kHalf = kBlindSampleStepPx / 2;
  std::uint32_t cells = 0;
  for (int y0 = 0; y0 < rows; y0 += kBlindBlockPx) {
    const int y1 = std::min(y0 + kBlindBlockPx, rows) - 1;
    // A band of blocks whose sampled rows hold no saturated pixel at all has no saturated block.
    bool any = false;
    for (int y = std::min(y0 + kHalf, y1); y <= y1 && !any; y += kBlindSampleStepPx)
      any = RowReaches<RowT>(f, y, saturation_level);
    if (!any) continue;
    for (int x0 = 0; x0 < f.width; x0 += kBlindBlockPx) {
      const int x1 = std::min(x0 + kBlindBlockPx, f.width) - 1;
      int samples = 0, saturated = 0;
      for (int y = std::min(y0 + kHalf, y1); y <= y1; y += kBlindSampleStepPx) {
        const RowT row{f.data + static_cast<std::ptrdiff_t>(y) * f.stride_bytes};
        for (int x = std::min(x0 + kHalf, x1); x <= x1; x += kBlindSampleStepPx, ++samples)
          saturated += row[x] >= saturation_level ? 1 : 0;
      }
      if (2 * saturated >= samples) cells |= CellsOfBox(f, x0, y0, x1, y1);
    }
  }
  return cells;
}

// Fills out's rows_written, blind_cells and their counters (a blank frame has no blind cell: the
// loop takes it as no frame at all).
void MarkBlindCells(const FrameView& frame, int rows_written, int saturation_level, BlobList* out) {
  out->rows_written = rows_written;
  if (out->counters.blank_frames > 0) return;
  const std::uint32_t saturated = frame.format == PixelFormat::kMono8
                                      ? SaturatedCells<Mono8Row>(frame, rows_written, saturation_level)
                                      : SaturatedCells<Mono16Row>(frame, rows_written, saturation_level);
  std::uint32_t unwritten = 0;
  // From the first uniform row (row rows_written, left out of the detection, holds the last pixels written).
  if (rows_written < frame.height) unwritten = CellsOfBox(frame, 0, rows_written + 1, frame.width - 1, frame.height - 1);
  out->blind_cells = saturated | unwritten;
  out->counters.saturated_frames = saturated != 0 ? 1 : 0;
  out->counters.truncated_frames = unwritten != 0 ? 1 : 0;
}

// Whether every pixel of a 64 x 64 grid over the frame has the same value (a few us).
bool IsFlat(const FrameView& frame) {
  constexpr int kGrid = 64;
  const std::uint16_t first = frame.At(0, 0);
  for (int gy = 0; gy < kGrid; ++gy) {
    const int y = static_cast<int>(static_cast<long>(gy) * (frame.height - 1) / (kGrid - 1));
    for (int gx = 0; gx < kGrid; ++gx)
      if (frame.At(static_cast<int>(static_cast<long>(gx) * (frame.width - 1) / (kGrid - 1)), y) != first) return false;
  }
  return true;
}
}  // namespace

DetectStatus BlobDetector::Detect(const FrameView& frame, const CameraIntrinsics* camera, BlobList* out) {
  return Run(frame, camera, nullptr, 0, false, out);
}

DetectStatus BlobDetector::Detect(const FrameView& frame, const CameraIntrinsics* camera, const PixelWindow* windows,
                                  int num_windows, BlobList* out) {
  return Run(frame, camera, windows, num_windows, true, out);
}

PixelWindow DetectionStripe(int width, int height, int index, int stripes, int margin_px) {
  const int n = std::max(stripes, 1);
  const int k = ((index % n) + n) % n;
  const auto row = [&](int i) { return static_cast<int>(static_cast<long>(height) * i / n); };
  return PixelWindow{0, std::max(row(k) - margin_px, 0), width, std::min(row(k + 1) + margin_px, height)};
}

DetectStatus BlobDetector::Run(const FrameView& frame, const CameraIntrinsics* camera, const PixelWindow* windows,
                               int num_windows, bool windowed, BlobList* out) {
  out->count = 0;
  out->camera = frame.camera;
  out->sequence = frame.sequence;
  out->t_capture_ns = frame.t_capture_ns;
  out->background_dn = out->noise_dn = out->contrast_dn = 0.0;
  out->threshold_min_dn = out->threshold_max_dn = 0;
  out->blind_cells = 0;
  out->rows_written = 0;
  out->counters = DetectCounters{};
  out->counters.frames = 1;

  DetectStatus status = DetectStatus::kOk;
  if (!options_valid_) {
    status = DetectStatus::kBadOptions;
  } else if (!FrameIsValid(frame)) {
    status = DetectStatus::kBadFrame;
  } else if (camera != nullptr && (camera->width != frame.width || camera->height != frame.height)) {
    status = DetectStatus::kCameraMismatch;
  }
  if (status != DetectStatus::kOk) {
    out->counters.bad_frames = 1;
    counters_ += out->counters;
    return status;
  }

  const bool mono8 = frame.format == PixelFormat::kMono8;
  const int saturation_level = SaturationLevel(options_, frame);
  FrameView written = frame;  // a truncated frame is detected as if it ended where writing stopped
  written.height = mono8 ? WrittenRows<Mono8Row>(frame, saturation_level) : WrittenRows<Mono16Row>(frame, saturation_level);
  if (windowed)
    out->counters.windows_dropped =
        static_cast<std::uint64_t>(MergeWindows(windows, num_windows, frame.width, frame.height, *ws_));
  status = mono8 ? DetectTyped<Mono8Row>(options_, *ws_, written, windowed, out)
                 : DetectTyped<Mono16Row>(options_, *ws_, written, windowed, out);
  if (status == DetectStatus::kOk && out->counters.over_blob_limit > 0) status = DetectStatus::kBlobLimit;
  if (status == DetectStatus::kOk && out->count == 0 && IsFlat(frame)) {
    status = DetectStatus::kBlankFrame;
    out->counters.blank_frames = 1;
  }
  MarkBlindCells(frame, written.height, saturation_level, out);
  if (written.height < frame.height && status != DetectStatus::kLabelTableFull) status = DetectStatus::kTruncatedFrame;

  std::sort(out->blobs.begin(), out->blobs.begin() + out->count, BrighterFirst);
  for (int i = 0; i < out->count && camera != nullptr; ++i) {
    Blob& b = out->blobs[static_cast<std::size_t>(i)];
    b.normalised_ok = Unproject(*camera, b.uv_px, &b.x_n) == UnprojectStatus::kOk;
    if (!b.normalised_ok) ++out->counters.undistort_failures;
  }
  counters_ += out->counters;
  return status;
}

}  // namespace mfns::fw
