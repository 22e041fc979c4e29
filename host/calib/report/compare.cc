#include "host/calib/report/compare.h"

#include "common/rotation/rotation.h"

namespace mfns::host {

RigErrors CompareRig(const RigCalibration& rig, const Rig& truth, const TurntableMount* truth_mount) {
  RigErrors out;
  static const char* kIntrinsicNames[kNumCameraParams] = {"alpha_x", "alpha_y", "skew", "u0", "v0",
                                                          "kc1",     "kc2",     "kc3",  "kc4", "kc5"};
  static const char* kAxes[3] = {"x", "y", "z"};
  for (const CameraResult& c : rig.cameras) {
    const RigCamera* t = nullptr;
    for (int k = 0; k < truth.num_cameras; ++k)
      if (c.name == truth.cameras[static_cast<std::size_t>(k)].name.data()) t = &truth.cameras[static_cast<std::size_t>(k)];
    if (t == nullptr) continue;
    const Eigen::Vector3d e_rot = LogSO3(t->C_k_b.transpose() * c.C_k_b);  // Exp(e) C_b_k_est = C_b_k_true
    const Eigen::Vector3d e_pos = c.r_b_bk - t->r_b_bk;
    out.cameras.push_back({c.name, RadToDeg(e_rot.norm()), e_pos.norm() * 1e3});
    const CameraParamVector est = c.intrinsics.ToVector(), tru = t->intrinsics.ToVector();
    for (int i = 0; i < kNumCameraParams; ++i) {
      if (c.sigma_intrinsics[i] == 0.0 && est[i] == tru[i]) continue;  // fixed at the true value
      out.params.push_back({c.name + "." + kIntrinsicNames[i], i < kKc1 ? "px" : "1", est[i] - tru[i], c.sigma_intrinsics[i]});
    }
    // e is the rotation taking the estimate to the truth; estimate - truth is -e.
    for (int a = 0; a < 3; ++a)
      out.params.push_back({c.name + ".rot_b." + kAxes[a], "deg", -RadToDeg(e_rot[a]), RadToDeg(c.sigma_rotation[a])});
    for (int a = 0; a < 3; ++a)
      out.params.push_back({c.name + ".r_b_bk." + kAxes[a], "mm", e_pos[a] * 1e3, c.sigma_r_b_bk[a] * 1e3});
  }
  if (truth_mount != nullptr) {
    const Eigen::Vector3d e_rot = LogSO3(truth_mount->C_w_t * rig.C_w_t.transpose());
    const Eigen::Vector3d e_pos = rig.r_w_wt - truth_mount->r_w_wt;
    out.C_w_t_deg = RadToDeg(e_rot.norm());
    out.r_w_wt_mm = e_pos.norm() * 1e3;
    for (int a = 0; a < 3; ++a)
      out.params.push_back({std::string("C_w_t.rot_w.") + kAxes[a], "deg", -RadToDeg(e_rot[a]), RadToDeg(rig.sigma_C_w_t[a])});
    for (int a = 0; a < 3; ++a)
      out.params.push_back({std::string("r_w_wt.") + kAxes[a], "mm", e_pos[a] * 1e3, rig.sigma_r_w_wt[a] * 1e3});
  }
  return out;
}

}  // namespace mfns::host
