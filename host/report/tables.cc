#include "host/report/tables.h"

#include <cstdio>
#include <cstring>
#include <iterator>
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

constexpr const char* kTable5Caption = "Table 5: navigation error over the sweep (estimate - truth; mean and std per axis)";
constexpr const char* kTable3Caption =
    "Table 3: camera-to-body calibration error (estimate - truth, with the estimate's 1-sigma)";
constexpr int kTable3Rows = 8;  // per camera: 3 Euler, |rotation|, 3 position, |position|
const char* const kTable3Notes[] = {
    "rotation: 2-1-3 Euler angles of C_k_b; near phi = 90 deg (camera y) theta and psi are",
    "ill-conditioned, |rotation| (angle of C_k_b_true^T C_k_b_est) is the robust measure.",
    "paper sigma: Table 3 (CPC on the real rig), read as C_k_b and r_b_bk (common/rig/paper_rig.h)"};

std::vector<std::string> Table5Notes(const std::vector<NamedPoseSummary>& runs) {
  std::vector<std::string> notes;
  for (const NamedPoseSummary& r : runs) {
    const PoseSummary& s = r.summary;
    char b[320];
    std::snprintf(b, sizeof(b),
                  "%s: %d frame sets, %d in the statistics; fix %d, degraded %d, lost %d, no output %d; "
                  ">= 3 beacons in view %d, of which posed %d",
                  r.label.c_str(), s.frames, s.used, s.fixes, s.degraded, s.lost, s.missing, s.frames_3plus,
                  s.posed_3plus);
    notes.push_back(b);
  }
  notes.push_back("paper: Sensors 2017, 17, 655, Table 5 (real turntable; beacons matched by hand)");
  return notes;
}

std::string Table3Quantity(int row) {
  static const char* kRot[3] = {"phi_deg", "theta_deg", "psi_deg"};
  static const char* kPos[3] = {"r_x_mm", "r_y_mm", "r_z_mm"};
  if (row < 3) return kRot[row];
  if (row == 3) return "|rotation|_deg";
  if (row < 7) return kPos[row - 4];
  return "|position|_mm";
}

// A method's cell: its error and, where known, its 1-sigma; "-" when it has no such camera.
std::string Table3Value(const CameraCalibError* c, int row) {
  if (c == nullptr) return "-";
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
  return Fmt(true, v) + (s >= 0 ? " (" + Fmt(false, s) + ")" : "");
}

std::string Table3Published(const RigCameraSigma* ps, int row) {
  if (ps != nullptr && row < 3) return Fmt(false, RadToDeg(ps->euler[row]));
  if (ps != nullptr && row >= 4 && row < 7) return Fmt(false, ps->r_b_bk[row - 4] * 1e3);
  return "-";
}

const RigCameraSigma* PublishedSigma(const Rig& published, const std::string& name) {
  const int p = PublishedIndex(published, name);
  return (p >= 0 && published.has_sigma) ? &published.sigma[static_cast<std::size_t>(p)] : nullptr;
}

}  // namespace

std::string FormatTable5(const std::vector<NamedPoseSummary>& runs) {
  std::ostringstream o;
  o << kTable5Caption << "\n";
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
  for (const std::string& n : Table5Notes(runs)) o << "  " << n << "\n";
  return o.str();
}

std::string FormatTable3(const std::vector<NamedCalibration>& methods, const Rig& published) {
  std::ostringstream o;
  o << kTable3Caption << "\n";
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
  for (const CameraCalibError& first : methods.front().cameras) {
    const RigCameraSigma* ps = PublishedSigma(published, first.name);
    for (int row = 0; row < kTable3Rows; ++row) {
      char b[96];
      std::snprintf(b, sizeof(b), "  %-6s %-14s", first.name.c_str(), Table3Quantity(row).c_str());
      o << b;
      for (const NamedCalibration& m : methods) {
        std::snprintf(b, sizeof(b), " | %-22s", Table3Value(Find(m, first.name), row).c_str());
        o << b;
      }
      o << " | " << Table3Published(ps, row) << "\n";
    }
  }
  for (const char* n : kTable3Notes) o << "  " << n << "\n";
  return o.str();
}

CellTable Table5Cells(const std::vector<NamedPoseSummary>& runs) {
  CellTable t;
  t.caption = kTable5Caption;
  t.header = {"axis", "paper mean", "paper std"};
  for (const NamedPoseSummary& r : runs)
    for (const char* q : {" mean", " std", " CRB rms"}) t.header.push_back(r.label + q);
  for (std::size_t a = 0; a < 6; ++a) {
    std::vector<std::string> row{kPoseAxes[a], Fmt(false, kPaperTable5[a].mean), Fmt(false, kPaperTable5[a].std)};
    for (const NamedPoseSummary& r : runs) {
      const AxisSummary& x = r.summary.axes[a];
      for (const double v : {x.mean, x.std, x.bound_rms}) row.push_back(x.n == 0 ? "-" : Fmt(false, v));
    }
    t.rows.push_back(std::move(row));
  }
  t.notes = Table5Notes(runs);
  return t;
}

CellTable Table3Cells(const std::vector<NamedCalibration>& methods, const Rig& published) {
  CellTable t;
  t.caption = kTable3Caption;
  t.header = {"camera", "quantity"};
  t.key_columns = 2;
  for (const NamedCalibration& m : methods) t.header.push_back(m.label);
  t.header.push_back("paper sigma");
  if (!methods.empty()) {
    for (const CameraCalibError& first : methods.front().cameras) {
      const RigCameraSigma* ps = PublishedSigma(published, first.name);
      for (int row = 0; row < kTable3Rows; ++row) {
        std::vector<std::string> cells{first.name, Table3Quantity(row)};
        for (const NamedCalibration& m : methods) cells.push_back(Table3Value(Find(m, first.name), row));
        cells.push_back(Table3Published(ps, row));
        t.rows.push_back(std::move(cells));
      }
    }
  }
  t.notes.assign(std::begin(kTable3Notes), std::end(kTable3Notes));
  return t;
}

}  // namespace mfns::host
