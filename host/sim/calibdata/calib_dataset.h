// `mfns-sim calib-dataset`: a simulated calibration session (paper Section 4.2) in the format
// of docs/calib-dataset.md: target fixed (world = target frame), the flyer on the two-axis
// turntable at commanded angles (true angles off by the turntable's error), 11 turntable images
// and 10 hand-held views per camera by default, rendered with area-sampled edges, blur,
// vignetting and sensor noise; with the true rig, the true turntable transform and the true
// corner positions.
//
// Turntable angles per camera: a base pose that turns the camera towards the target
// (z: main 0, aux 0; y: main 0, aux -90 deg; x: main 90, aux -90 deg; other cameras: the
// base whose view direction is closest to the target) plus a fixed pattern of offsets of
// `variation` about both axes (2x larger about the main axis for a camera looking along it,
// which only rotates its view of the target).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "host/sim/scenario/scenario.h"

namespace mfns::host {

struct CalibDatasetOptions {
  std::filesystem::path out_dir;
  int threads = 0;        // 0: all cores
  bool progress = true;
};

struct CalibDatasetSummary {
  int images = 0;
  int complete = 0;  // images in which every target corner is visible
  // Per camera (the rig's order): its turntable images, and those with every corner visible. A
  // camera with none cannot have its mounting calibrated (mfns-calib rig refuses it): the
  // turntable cannot turn it to face the target with the scenario's mount (turntable: C_p_b).
  std::vector<int> turntable_images, turntable_complete;
};

// The warnings for a summary: one line per camera whose turntable images never show the whole
// target (names from the scenario's rig); empty when every camera has at least one.
std::vector<std::string> TurntableWarnings(const Scenario& s, const CalibDatasetSummary& sum);

// Throws UserError when the scenario has no target or on I/O failure.
CalibDatasetSummary WriteCalibDataset(const Scenario& s, const std::string& scenario_text,
                                      const CalibDatasetOptions& options);

}  // namespace mfns::host
