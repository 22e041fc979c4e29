#include "firmware/modules/identify/blob_tracks.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mfns::fw {

namespace {
constexpr float kNoCost = std::numeric_limits<float>::infinity();
}  // namespace

bool BlobTrackOptions::IsValid() const {
  return std::isfinite(max_image_rate_rad_s) && max_image_rate_rad_s > 0.0 && std::isfinite(tight_gate_px) && tight_gate_px > 0.0 &&
         std::isfinite(tight_gate_fraction) && tight_gate_fraction >= 0.0 && std::isfinite(max_gap_s) &&
         max_gap_s > 0.0 && steady_age >= 2 && steady_age <= 255;
}

void BlobTracks::Reset() {
  num_prev_ = num_cur_ = num_steady_ = 0;
  has_prev_ = false;
}

// The association cost of cur continuing prev: below 1 within the tight gate of prev's
// prediction, in [1, 2] within the wide gate of its position, else infinite.
float BlobTracks::Cost(const Point& prev, const Point& cur, double dt_s, double wide_gate_px,
                       const BlobTrackOptions& o) const {
  if (prev.age >= 2) {
    const double pu = prev.du * dt_s, pv = prev.dv * dt_s;
    const double gate = o.tight_gate_px + o.tight_gate_fraction * std::hypot(pu, pv);
    const double d = std::hypot(cur.u - (prev.u + pu), cur.v - (prev.v + pv));
    if (d < gate) return static_cast<float>(d / gate);
  }
  const double d = std::hypot(cur.u - prev.u, cur.v - prev.v);
  return d <= wide_gate_px ? static_cast<float>(1.0 + d / wide_gate_px) : kNoCost;
}

// Mutual nearest (lowest cost) pairs between this camera's previous and current blobs.
void BlobTracks::AssociateCamera(int camera, double dt_s, double wide_gate_px, const BlobTrackOptions& o) {
  for (int c = 0; c < num_cur_; ++c) {
    const auto sc = static_cast<std::size_t>(c);
    if (cur_[sc].camera != camera) continue;
    for (int p = 0; p < num_prev_; ++p) {
      const auto sp = static_cast<std::size_t>(p);
      if (prev_[sp].camera != camera) continue;
      const float cost = Cost(prev_[sp], cur_[sc], dt_s, wide_gate_px, o);
      if (cost < best_prev_cost_[sc]) {
        best_prev_cost_[sc] = cost;
        best_prev_[sc] = static_cast<std::int16_t>(p);
      }
      if (cost < best_cur_cost_[sp]) {
        best_cur_cost_[sp] = cost;
        best_cur_[sp] = static_cast<std::int16_t>(c);
      }
    }
  }
  for (int c = 0; c < num_cur_; ++c) {
    const auto sc = static_cast<std::size_t>(c);
    const int p = best_prev_[sc];
    if (cur_[sc].camera != camera || p < 0 || best_cur_[static_cast<std::size_t>(p)] != c) continue;
    const Point& prev = prev_[static_cast<std::size_t>(p)];
    Point& cur = cur_[sc];
    const bool tight = best_prev_cost_[sc] < 1.0F;
    cur.age = tight ? static_cast<std::uint8_t>(std::min(255, prev.age + 1)) : std::uint8_t{2};
    cur.du = (cur.u - prev.u) / dt_s;
    cur.dv = (cur.v - prev.v) / dt_s;
    cur.id = prev.id;
  }
}

void BlobTracks::Update(const BlobObs* blobs, int n, std::uint64_t t_ns, std::uint32_t cameras, double px_per_rad,
                        const BlobTrackOptions& o) {
  steady_age_ = o.steady_age;
  num_cur_ = (blobs == nullptr || !o.IsValid() || !(px_per_rad > 0.0)) ? 0 : std::clamp(n, 0, limits::kMaxObservations);
  for (int i = 0; i < num_cur_; ++i) {
    const auto si = static_cast<std::size_t>(i);
    const BlobObs& b = blobs[i];
    const bool usable = b.camera >= 0 && b.camera < limits::kMaxCameras && b.x_n.allFinite();
    cur_[si] = Point{usable ? b.x_n.x() * px_per_rad : 0.0, usable ? b.x_n.y() * px_per_rad : 0.0, 0.0, 0.0, 1,
                     static_cast<std::int8_t>(usable ? b.camera : -1), 0U};
    best_prev_[si] = -1;
    best_prev_cost_[si] = kNoCost;
  }
  const double dt_s = has_prev_ && t_ns > prev_t_ns_ ? static_cast<double>(t_ns - prev_t_ns_) * 1e-9 : -1.0;
  if (dt_s > 0.0 && dt_s <= o.max_gap_s) {
    for (int p = 0; p < num_prev_; ++p) {
      best_cur_[static_cast<std::size_t>(p)] = -1;
      best_cur_cost_[static_cast<std::size_t>(p)] = kNoCost;
    }
    const double wide_gate_px = px_per_rad * o.max_image_rate_rad_s * dt_s + o.tight_gate_px;
    for (int k = 0; k < limits::kMaxCameras; ++k)
      if ((cameras >> k & 1u) != 0 && (prev_cameras_ >> k & 1u) != 0) AssociateCamera(k, dt_s, wide_gate_px, o);
  }
  num_steady_ = 0;
  for (int i = 0; i < num_cur_; ++i) {
    const auto si = static_cast<std::size_t>(i);
    if (cur_[si].id == 0) {
      if (++last_id_ == 0) ++last_id_;
      cur_[si].id = last_id_;
    }
    ids_[si] = cur_[si].id;
    ages_[si] = cur_[si].age;
    steady_[si] = cur_[si].age >= o.steady_age ? 1 : 0;
    num_steady_ += steady_[si];
  }
  std::copy(cur_.begin(), cur_.begin() + num_cur_, prev_.begin());
  num_prev_ = num_cur_;
  prev_t_ns_ = t_ns;
  prev_cameras_ = cameras;
  has_prev_ = true;
}

}  // namespace mfns::fw
