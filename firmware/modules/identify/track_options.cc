#include <cmath>

#include "firmware/modules/identify/noise_model.h"
#include "firmware/modules/identify/tracker.h"

// TrackOptions' checks and the pixel scaling of its gates (tracker.h); the tracking itself is in
// tracker.cc.
namespace mfns::fw {

bool TrackOptions::IsValid(const char** why) const {
  const char* bad = nullptr;
  const char* sub = nullptr;
  auto positive = [](double x) { return x > 0.0 && std::isfinite(x); };
  if (!lis.IsValid(&sub)) bad = sub;
  else if (!positive(gate_px)) bad = "gate_px";
  else if (!positive(hold_gate_px)) bad = "hold_gate_px";
  else if (!positive(max_gate_px) || max_gate_px < gate_px || max_gate_px < hold_gate_px) bad = "max_gate_px";
  else if (!positive(refine_gate_px)) bad = "refine_gate_px";
  else if (!(miss_margin_px >= 0.0) || !std::isfinite(miss_margin_px)) bad = "miss_margin_px";
  else if (max_missing < 0) bad = "max_missing";
  else if (max_ambiguous_tried < 0 || max_ambiguous_tried > limits::kMaxAmbiguousMatches) bad = "max_ambiguous_tried";
  else if (!positive(ambiguity_chi2)) bad = "ambiguity_chi2";
  else if (!(identity_gate_chi2 >= 0.0) || !std::isfinite(identity_gate_chi2)) bad = "identity_gate_chi2";
  else if (!(ambiguity_max_spread_m >= 0.0) || !(ambiguity_max_spread_rad >= 0.0) ||
           !std::isfinite(ambiguity_max_spread_m) || !std::isfinite(ambiguity_max_spread_rad))
    bad = "ambiguity_max_spread";
  else if (!(continuity_max_m2 >= 0.0) || !std::isfinite(continuity_max_m2)) bad = "continuity_max_m2";
  else if (!(ambiguity_accept_m2 >= 0.0) || !(ambiguity_reject_m2 >= ambiguity_accept_m2) ||
           !std::isfinite(ambiguity_reject_m2))
    bad = "ambiguity_accept_m2 / ambiguity_reject_m2";
  else if (!(ambiguity_innovation_factor >= 1.0) || !std::isfinite(ambiguity_innovation_factor)) bad = "ambiguity_innovation_factor";
  else if (!positive(max_rms_px)) bad = "max_rms_px";
  else if (!positive(max_coast_s)) bad = "max_coast_s";
  else if (!positive(velocity_window_s)) bad = "velocity_window_s";
  else if (!(gate_sigmas >= 0.0) || !std::isfinite(gate_sigmas)) bad = "gate_sigmas";
  else if (!positive(gate_depth_m)) bad = "gate_depth_m";
  else if (!positive(steady_gate_px) || !(steady_gate_fraction >= 0.0) || !std::isfinite(steady_gate_fraction))
    bad = "steady_gate_px / steady_gate_fraction";
  else if (!positive(max_seed_s)) bad = "max_seed_s";
  else if (fix_min_beacons < 3) bad = "fix_min_beacons";
  else if (!positive(degraded_rms_px)) bad = "degraded_rms_px";
  else if (!positive(fix_rms_sigmas)) bad = "fix_rms_sigmas";
  else if (!positive(max_position_sigma_m)) bad = "max_position_sigma_m";
  else if (!positive(max_attitude_sigma_rad)) bad = "max_attitude_sigma_rad";
  else if (!positive(max_speed_m_s)) bad = "max_speed_m_s";
  else if (!positive(max_rate_rad_s)) bad = "max_rate_rad_s";
  else if (!positive(max_accel_m_s2)) bad = "max_accel_m_s2";
  else if (!positive(max_angular_accel_rad_s2)) bad = "max_angular_accel_rad_s2";
  else if (!(chain_slack_m >= 0.0) || !(chain_slack_rad >= 0.0)) bad = "chain_slack";
  else if (min_acquire_frames < 2) bad = "min_acquire_frames";
  else if (lis_fix_min_beacons < 3) bad = "lis_fix_min_beacons";
  else if (leave_one_out_min_beacons < 5 || leave_one_out_max_beacons < leave_one_out_min_beacons)
    bad = "leave_one_out_min_beacons / leave_one_out_max_beacons";
  else if (leave_two_out_min_beacons != 0 &&
           (leave_two_out_min_beacons < 6 || leave_two_out_max_beacons < leave_two_out_min_beacons))
    bad = "leave_two_out_min_beacons / leave_two_out_max_beacons";
  else if (!(residual_test_sigmas >= 0.0) || !std::isfinite(residual_test_sigmas)) bad = "residual_test_sigmas";
  else if (lis_budget_per_frame < 1) bad = "lis_budget_per_frame";
  else if (!positive(chain_stale_s)) bad = "chain_stale_s";
  else if (!(cold_search_s >= 0.0) || !std::isfinite(cold_search_s)) bad = "cold_search_s";
  else if (seeded_max_hypotheses < 1 || seeded_max_hypotheses > limits::kMaxLisHypotheses) bad = "seeded_max_hypotheses";

  else if (!positive(twin_m) || !positive(twin_rad)) bad = "twin";
  else if (!positive(innovation_m) || !positive(innovation_rad)) bad = "innovation";
  else if (!(map_error_px >= 0.0) || !std::isfinite(map_error_px)) bad = "map_error_px";
  else if (!solve.IsValid(&sub)) bad = sub;
  if (why != nullptr) *why = bad != nullptr ? bad : "ok";
  return bad == nullptr;
}

void TrackOptions::ScalePixelGates(double factor) {
  for (double* px : {&gate_px, &hold_gate_px, &max_gate_px, &refine_gate_px, &miss_margin_px,
                     &lis.hypothesis_match.gate_px, &lis.hypothesis_match.miss_margin_px, &lis.refine_match.gate_px,
                     &lis.refine_match.miss_margin_px, &lis.near_miss_px})
    *px *= factor;
}

void TrackOptions::AllowForMapError(double map_px) {
  if (!(map_px > 0.0) || !std::isfinite(map_px)) return;
  // Gates on a single residual cover 4 sigmas of the map error, RMS bounds 2 (an RMS averages).
  auto grow = [map_px](double* b, double sigmas) { *b = GrowForMapError(*b, sigmas, map_px); };
  for (double* gate : {&refine_gate_px, &solve.outlier_threshold_px, &lis.refine_match.gate_px,
                       &lis.solve.outlier_threshold_px})
    if (*gate > 0.0) grow(gate, 4.0);  // (an outlier threshold <= 0 means no rejection: kept)
  for (double* rms : {&max_rms_px, &lis.max_rms_px, &degraded_rms_px}) grow(rms, 2.0);
  map_error_px = map_px;
}

double PixelGateScale(const Rig& rig) {
  const double f = LargestFocalPx(rig);
  return f > 0.0 && std::isfinite(f) ? f / kGateReferencePxPerRad : 1.0;
}

double BeaconMapErrorPx(const Rig& rig, double range_m) {
  if (!(range_m > 0.0) || !(rig.beacon_sigma > 0.0)) return 0.0;
  return LargestFocalPx(rig) * rig.beacon_sigma / range_m;
}

}  // namespace mfns::fw
