#include "host/calib/ml/orientation.h"

#include <algorithm>
#include <cmath>

#include "host/calib/ml/hand_eye.h"

namespace mfns::host {
namespace {

const Eigen::Matrix3d kHalfTurn = Eigen::Vector3d(-1.0, -1.0, 1.0).asDiagonal();

void Turn(CalibInput* in, std::vector<Transform>* T, std::size_t v, const Eigen::Vector3d& centre) {
  const int n = static_cast<int>(in->target_points.size());
  for (CornerObs& c : in->views[v].corners) c.id = n - 1 - c.id;
  std::sort(in->views[v].corners.begin(), in->views[v].corners.end(),
            [](const CornerObs& a, const CornerObs& b) { return a.id < b.id; });
  Transform& t = (*T)[v];
  t.C = kHalfTurn * t.C;
  t.r = kHalfTurn * (t.r - centre) + centre;
}

Eigen::Matrix3d Nominal(const CalibInput& in, const ViewObservation& v) {
  return PlatformRotation(v.main_cmd, v.aux_cmd) * in.C_p_b;
}

}  // namespace

OrientationReport ResolveOrientation(CalibInput* in, std::vector<Transform>* view_T_w_k) {
  OrientationReport rep;
  bool any = false;
  for (const ViewObservation& v : in->views) any = any || v.orientation_ambiguous;
  if (!any) return rep;
  const Eigen::Vector3d centre = 0.5 * (in->target_points.front() + in->target_points.back());
  const int K = static_cast<int>(in->cameras.size());
  std::vector<std::vector<std::size_t>> tt(static_cast<std::size_t>(K));
  for (std::size_t v = 0; v < in->views.size(); ++v)
    if (in->views[v].kind == ImageKind::kTurntable) tt[static_cast<std::size_t>(in->views[v].camera)].push_back(v);

  // 1. Within each camera: agree with the camera's first turntable view.
  for (int k = 0; k < K; ++k) {
    const std::vector<std::size_t>& vs = tt[static_cast<std::size_t>(k)];
    if (vs.size() < 2) continue;
    const std::size_t r = vs.front();
    for (std::size_t n = 1; n < vs.size(); ++n) {
      const std::size_t j = vs[n];
      if (!in->views[j].orientation_ambiguous) continue;
      const double cmd = RotationAngle(Nominal(*in, in->views[j]) * Nominal(*in, in->views[r]).transpose());
      const Eigen::Matrix3d rel = (*view_T_w_k)[j].C * (*view_T_w_k)[r].C.transpose();
      const double same = std::abs(RotationAngle(rel) - cmd), turned = std::abs(RotationAngle(kHalfTurn * rel) - cmd);
      if (turned < same) {
        Turn(in, view_T_w_k, j, centre);
        ++rep.views_turned;
      }
    }
  }
  // 2. Across cameras: each camera's own C_w_t, anchored on the camera with most views.
  std::vector<int> order;
  for (int k = 0; k < K; ++k)
    if (tt[static_cast<std::size_t>(k)].size() >= 3) order.push_back(k);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return tt[static_cast<std::size_t>(a)].size() > tt[static_cast<std::size_t>(b)].size();
  });
  bool have_anchor = false;
  Eigen::Matrix3d anchor = Eigen::Matrix3d::Identity();
  for (int k : order) {
    const std::vector<std::size_t>& vs = tt[static_cast<std::size_t>(k)];
    bool all_ambiguous = true;
    for (std::size_t v : vs) all_ambiguous = all_ambiguous && in->views[v].orientation_ambiguous;
    std::vector<HandEyeView> hv;
    for (std::size_t v : vs) hv.push_back({k, in->views[v].main_cmd, in->views[v].aux_cmd, (*view_T_w_k)[v]});
    Eigen::Matrix3d C_w_t;
    try {
      C_w_t = SolveHandEyeLinear(hv, K, in->C_p_b, in->r_p_pb).C_w_t;
    } catch (const std::exception& e) {
      rep.notes.push_back("orientation: camera " + in->cameras[static_cast<std::size_t>(k)].name +
                          ": not checked against the others (" + e.what() + ")");
      continue;
    }
    // Turning every view of the camera turns its C_w_t into F C_w_t.
    const Eigen::Matrix3d reference = have_anchor ? anchor : Eigen::Matrix3d::Identity();
    const bool turn = all_ambiguous && RotationAngle((kHalfTurn * C_w_t) * reference.transpose()) <
                                           RotationAngle(C_w_t * reference.transpose());
    if (turn) {
      for (std::size_t v : vs) Turn(in, view_T_w_k, v, centre);
      rep.views_turned += static_cast<int>(vs.size());
      C_w_t = kHalfTurn * C_w_t;
    }
    if (!have_anchor) {
      anchor = C_w_t;
      have_anchor = true;
    }
  }
  for (ViewObservation& v : in->views)
    if (v.kind == ImageKind::kTurntable) v.orientation_ambiguous = false;
  rep.notes.push_back("orientation: symmetric checkerboard; " + std::to_string(rep.views_turned) +
                      " turntable views relabelled by the half turn to agree with the kinematics");
  return rep;
}

}  // namespace mfns::host
