#include "common/rig/paper_rig.h"

#include <cstring>

#include "common/rotation/rotation.h"

namespace mfns {
namespace {

constexpr double kMm = 1e-3;

struct PaperCamera {
  const char* name;
  double alpha_x, alpha_y, u0, v0;
  std::array<double, 5> kc;
  double sigma_alpha_x, sigma_alpha_y, sigma_u0, sigma_v0;
  std::array<double, 5> sigma_kc;
  double phi_deg, theta_deg, psi_deg, sigma_phi_deg, sigma_theta_deg, sigma_psi_deg;
  double r_mm[3], sigma_r_mm[3];
};

// Tables 2 and 3 (reference/paper-tables.yaml: table2_intrinsics, table3_extrinsics; checked
// against the file by PaperNumbers.PaperRigIsTables2To4 in host/report).
constexpr PaperCamera kCameras[] = {
    {"x", 1599.26136, 1599.93302, 632.61591, 522.17870, {-0.13013, 0.28701, -0.00040, -0.00004, 0.0},
     1.78966, 1.64101, 1.62023, 1.61823, {0.00336, 0.02243, 0.00029, 0.00031, 0.0},
     -0.5788, -90.3523, 0.0395, 0.0413, 0.0990, 0.0153,
     {76.1319, -36.8373, 78.8949}, {0.2529, 0.4498, 0.4959}},
    {"y", 1605.35286, 1603.54359, 619.71227, 505.99361, {-0.11276, 0.01776, -0.00031, 0.00057, 0.0},
     1.66249, 1.73608, 1.80177, 1.93821, {0.00301, 0.01776, 0.00034, 0.00030, 0.0},
     90.1636, -0.5501, 0.1925, 0.0301, 0.0920, 0.0157,
     {-32.5004, 75.7149, 76.9967}, {0.5358, 0.0825, 0.1963}},
    {"z", 1611.21596, 1610.79607, 649.51210, 531.29472, {-0.10481, 0.15881, -0.00137, 0.00184, 0.0},
     2.14183, 2.14219, 1.39920, 1.34749, {0.00338, 0.02341, 0.00021, 0.00022, 0.0},
     -0.1076, -0.7211, 1.1690, 0.0485, 0.0657, 0.0443,
     {34.1604, 30.8251, 119.7096}, {0.3097, 0.3097, 0.2932}},
};

// Table 4, world frame, mm.
constexpr double kBeaconsMm[][3] = {
    {487.4734, -720.0265, 240.8359},  {-51.2618, -737.6155, 164.7393}, {-366.1525, -711.8317, 131.2681},
    {-458.8302, -215.2964, -69.2627}, {-454.6380, 410.3959, -60.6549}, {-117.4392, 296.0537, 83.0754},
    {182.4478, 279.1964, 143.2510},   {481.8346, 252.9609, 217.5775},  {647.3834, -127.6167, 178.7407},
    {-122.5798, -44.9064, 562.5394},
};
constexpr double kBeaconSigmaMm = 0.3963;

}  // namespace

Rig PaperRig() {
  Rig rig;
  std::strncpy(rig.rig_id.data(), kPaperRigId, rig.rig_id.size() - 1);
  rig.num_cameras = 3;
  rig.has_sigma = true;
  for (std::size_t i = 0; i < 3; ++i) {
    const PaperCamera& p = kCameras[i];
    RigCamera& c = rig.cameras[i];
    std::strncpy(c.name.data(), p.name, c.name.size() - 1);
    c.intrinsics.width = 1280;
    c.intrinsics.height = 1024;
    c.intrinsics.alpha_x = p.alpha_x;
    c.intrinsics.alpha_y = p.alpha_y;
    c.intrinsics.skew = 0.0;
    c.intrinsics.u0 = p.u0;
    c.intrinsics.v0 = p.v0;
    c.intrinsics.kc = p.kc;
    c.C_k_b = EulerToMatrix({DegToRad(p.phi_deg), DegToRad(p.theta_deg), DegToRad(p.psi_deg)});
    c.r_b_bk = Eigen::Vector3d(p.r_mm[0], p.r_mm[1], p.r_mm[2]) * kMm;
    RigCameraSigma& s = rig.sigma[i];
    s.intrinsics = {p.sigma_alpha_x, p.sigma_alpha_y, 0.0, p.sigma_u0, p.sigma_v0};
    s.distortion = p.sigma_kc;
    s.euler = Eigen::Vector3d(DegToRad(p.sigma_phi_deg), DegToRad(p.sigma_theta_deg),
                              DegToRad(p.sigma_psi_deg));
    s.r_b_bk = Eigen::Vector3d(p.sigma_r_mm[0], p.sigma_r_mm[1], p.sigma_r_mm[2]) * kMm;
  }
  rig.num_beacons = 10;
  for (std::size_t i = 0; i < 10; ++i)
    rig.beacons_w[i] = Eigen::Vector3d(kBeaconsMm[i][0], kBeaconsMm[i][1], kBeaconsMm[i][2]) * kMm;
  rig.beacon_sigma = kBeaconSigmaMm * kMm;
  return rig;
}

}  // namespace mfns
