// Test helper: errors of calibrations against the truth summed over seeds.
#pragma once

#include <cmath>
#include <cstdio>

#include "common/rotation/rotation.h"
#include "host/calib/app/calibrate.h"
#include "host/calib/report/compare.h"
#include "host/testing/synth_calib.h"

namespace mfns::host {

struct Tally {
  int within3 = 0, total = 0;
  double rot2 = 0, pos2 = 0, rot_pred2 = 0, pos_pred2 = 0;
  int n = 0;
  void Add(const RigCalibration& r, const SynthScene& scene) {
    const TurntableMount mount = scene.mount;
    const RigErrors e = CompareRig(r, scene.rig, &mount);
    for (const CameraError& c : e.cameras) {
      rot2 += c.rotation_deg * c.rotation_deg;
      pos2 += c.position_mm * c.position_mm;
      ++n;
    }
    for (const CameraResult& c : r.cameras) {  // what the covariance predicts for the same sums
      rot_pred2 += RadToDeg(RadToDeg(c.sigma_rotation.squaredNorm()));
      pos_pred2 += c.sigma_r_b_bk.squaredNorm() * 1e6;
    }
    for (const ParamError& p : e.params) {
      ++total;
      if (p.sigma > 0 && std::abs(p.error) <= 3.0 * p.sigma) ++within3;
    }
  }
  double RotRms() const { return std::sqrt(rot2 / n); }
  double PosRms() const { return std::sqrt(pos2 / n); }
  double RotPredicted() const { return std::sqrt(rot_pred2 / n); }
  double PosPredicted() const { return std::sqrt(pos_pred2 / n); }
  double FractionWithin3() const { return total > 0 ? static_cast<double>(within3) / total : 0.0; }
  // One line of text, exact (a test split over processes sums its parts: Merge).
  bool Save(std::FILE* f) const {
    return std::fprintf(f, "%d %d %d %.17g %.17g %.17g %.17g\n", within3, total, n, rot2, pos2, rot_pred2,
                        pos_pred2) > 0;
  }
  bool Load(std::FILE* f) {
    return std::fscanf(f, "%d %d %d %lg %lg %lg %lg", &within3, &total, &n, &rot2, &pos2, &rot_pred2, &pos_pred2) == 7;
  }
  void Merge(const Tally& o) {
    within3 += o.within3;
    total += o.total;
    n += o.n;
    rot2 += o.rot2;
    pos2 += o.pos2;
    rot_pred2 += o.rot_pred2;
    pos_pred2 += o.pos_pred2;
  }
  void Print(const char* label) const {
    std::printf("%-15s C_k_b RMS %.5f deg (covariance predicts %.5f), r_b_bk RMS %.4f mm (predicts %.4f), %d/%d "
                "parameters within 3 sigma\n",
                label, RotRms(), RotPredicted(), PosRms(), PosPredicted(), within3, total);
  }
};

// ml and paper (and OpenCV's hand-eye when `handeye` is set) on the same noisy corners of
// `seeds` synthetic scenes.
inline void RunCornerSeeds(int seeds, const SynthOptions& base, double pixel_sigma, Tally* ml, Tally* paper,
                           Tally* handeye = nullptr) {
  for (int seed = 1; seed <= seeds; ++seed) {
    SynthOptions so = base;
    so.seed = static_cast<std::uint64_t>(seed);
    const SynthScene scene = MakeSynthScene(so);
    CalibInput in = SynthCorners(scene, pixel_sigma, so.seed);
    RigOptions ro;
    const IntrinsicsStage st = PrepareViews(&in, ro);
    ml->Add(SolveRig(in, st, ro), scene);
    ro.method = RigMethod::kPaper;
    paper->Add(SolveRig(in, st, ro), scene);
    if (handeye != nullptr) {
      ro.method = RigMethod::kOpenCvHandEye;
      handeye->Add(SolveRig(in, st, ro), scene);
    }
  }
}

}  // namespace mfns::host
