#include "host/report/tables.h"

#include <cstdio>
#include <cstring>
#include <sstream>

#include "common/rotation/rotation.h"
#include "host/report/paper_numbers.h"

namespace mfns::host {
namespace {

std::string Fmt(bool sign, double v) {
  char b[64];
  if (sign) std::snprintf(b, sizeof(b), "%+.4f", v);
  else std::snprintf(b, sizeof(b), "%.4f", v);
  return b;
}

const CameraCalibError* Find(const NamedCalibration& m, const std::string& name) {
  for (const CameraCalibError& c : m.cameras)
    if (c.name == name) return &c;
  return nullptr;
}

int PublishedIndex(const Rig& published, const std::string& name) {
  for (int i = 0; i < published.num_cameras; ++i)
    if (name == published.cameras[static_cast<std::size_t>(i)].name.data()) return i;
  return -1;
}

}  // namespace

std::string FormatTable5(const std::vector<NamedPoseSummary>& runs) {
  std::ostringstream o;
  o << "Table 5: navigation error over the sweep (estimate - truth; mean and std per axis)\n";
  o << "  axis          pub. mean   pub. std";
  for (const NamedPoseSummary& r : runs) {
    std::string l = r.label.substr(0, 10);
    char b[128];
    std::snprintf(b, sizeof(b), " | %10s mean %9s std   CRB rms", l.c_str(), "");
    o << b;
  }
  o << "\n";
  for (std::size_t a = 0; a < 6; ++a) {
    char b[128];
    std::snprintf(b, sizeof(b), "  %-11s %10.4f %10.4f", kPoseAxes[a], kPaperTable5[a].mean, kPaperTable5[a].std);
    o << b;
    for (const NamedPoseSummary& r : runs) {
      const AxisSummary& x = r.summary.axes[a];
      if (x.n == 0) {
        std::snprintf(b, sizeof(b), " | %15s %13s %9s", "-", "-", "-");
      } else {
        std::snprintf(b, sizeof(b), " | %15.4f %13.4f %9.4f", x.mean, x.std, x.bound_rms);
      }
      o << b;
    }
    o << "\n";
  }
  for (const NamedPoseSummary& r : runs) {
    const PoseSummary& s = r.summary;
    char b[320];
    std::snprintf(b, sizeof(b),
                  "  %s: %d frame sets, %d in the statistics; fix %d, degraded %d, lost %d, no output %d; "
                  ">= 3 beacons in view %d, of which posed %d\n",
                  r.label.c_str(), s.frames, s.used, s.fixes, s.degraded, s.lost, s.missing, s.frames_3plus,
                  s.posed_3plus);
    o << b;
  }
  o << "  paper: Sensors 2017, 17, 655, Table 5 (real turntable; beacons matched by hand)\n";
  return o.str();
}

std::string FormatTable3(const std::vector<NamedCalibration>& methods, const Rig& published) {
  std::ostringstream o;
  o << "Table 3: camera-to-body calibration error (estimate - truth, with the estimate's 1-sigma)\n";
  {
    char h[64];
    std::snprintf(h, sizeof(h), "  %-6s %-14s", "camera", "quantity");
    o << h;
  }
  for (const NamedCalibration& m : methods) {
    char b[64];
    std::snprintf(b, sizeof(b), " | %-22s", m.label.substr(0, 22).c_str());
    o << b;
  }
  o << " | paper sigma\n";
  if (methods.empty()) return o.str();
  static const char* kRot[3] = {"phi_deg", "theta_deg", "psi_deg"};
  static const char* kPos[3] = {"r_x_mm", "r_y_mm", "r_z_mm"};
  for (const CameraCalibError& first : methods.front().cameras) {
    const int p = PublishedIndex(published, first.name);
    const RigCameraSigma* ps = (p >= 0 && published.has_sigma) ? &published.sigma[static_cast<std::size_t>(p)] : nullptr;
    // rows: 3 Euler, |rotation|, 3 position, |position|
    for (int row = 0; row < 8; ++row) {
      std::string q;
      if (row < 3) q = kRot[row];
      else if (row == 3) q = "|rotation|_deg";
      else if (row < 7) q = kPos[row - 4];
      else q = "|position|_mm";
      char b[96];
      std::snprintf(b, sizeof(b), "  %-6s %-14s", first.name.c_str(), q.c_str());
      o << b;
      for (const NamedCalibration& m : methods) {
        const CameraCalibError* c = Find(m, first.name);
        std::string cell = "-";
        if (c != nullptr) {
          double v = 0, s = -1;
          if (row < 3) {
            v = c->euler_error_deg[row];
            s = c->has_sigma ? c->euler_sigma_deg[row] : -1;
          } else if (row == 3) {
            v = c->rotation_deg;
          } else if (row < 7) {
            v = c->position_error_mm[row - 4];
            s = c->has_sigma ? c->position_sigma_mm[row - 4] : -1;
          } else {
            v = c->position_mm;
          }
          cell = Fmt(true, v) + (s >= 0 ? " (" + Fmt(false, s) + ")" : "");
        }
        std::snprintf(b, sizeof(b), " | %-22s", cell.c_str());
        o << b;
      }
      std::string pub = "-";
      if (ps != nullptr && row < 3) pub = Fmt(false, RadToDeg(ps->euler[row]));
      if (ps != nullptr && row >= 4 && row < 7) pub = Fmt(false, ps->r_b_bk[row - 4] * 1e3);
      o << " | " << pub << "\n";
    }
  }
  o << "  rotation: 2-1-3 Euler angles of C_k_b; near phi = 90 deg (camera y) theta and psi are\n"
       "  ill-conditioned, |rotation| (angle of C_k_b_true^T C_k_b_est) is the robust measure.\n"
       "  paper sigma: Table 3 (CPC on the real rig), read as C_k_b and r_b_bk (common/rig/paper_rig.h)\n";
  return o.str();
}

}  // namespace mfns::host
