// `mfns-sim render`: a scenario rendered to the frames directory of DESIGN.md with its truth.
//
// DIR/frames/<camera>/<frame:06d>.pgm   mono8 (or mono16) frames, 1 per camera per frame set;
//                     what each camera sees is host/sim/observe's ObserveCamera (beam facing,
//                     occlusions, spurious spots); a blinded camera's frame is saturated (every
//                     pixel at full scale) or black per its mode, a stopped camera's black
// DIR/truth.csv       frame,t_ns,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg (true pose)
// DIR/blobs.csv       frame,camera,beacon,u_px,v_px,u_geom_px,v_geom_px: true blob centres of
//                     the visible beacons only, no spurious spots (u_px: the rendered spot's
//                     centre, what a perfect detector finds, = SimulateBlobs' uv_px; u_geom_px:
//                     the beacon's projection without centroid noise)
// DIR/crb.csv         per frame set: beacons seen per camera (those blobs.csv lists) and the
//                     Cramér-Rao bound of the pose (1-sigma per axis) for centroid noise sigma_px
// DIR/turntable.csv   frame,main_cmd_deg,aux_cmd_deg,main_true_deg,aux_true_deg (turntable runs)
// DIR/turntable-survey.yaml  the turntable's placement as surveyed (SurveyTurntable; turntable runs):
//                     centre_mm, centre_sigma_mm, centre_b_mm, centre_b_sigma_mm, axis, axis_sigma_deg
//                     (mfns-calib survey --turntable-placement reads it)
// DIR/rig.yaml        the true rig and beacons;  DIR/believed-rig.yaml  the rig with the
//                     scenario's calibration and survey errors (what a navigator would load);
//                     both with the beacons' facing unless the scenario's map has none
//                     (beacons.facing: false)
// DIR/scenario.yaml   the scenario text that made it
// Every (frame, camera) image draws from its own random stream seeded by (seed, frame,
// camera), so output bytes do not depend on the number of threads.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

#include <opencv2/core.hpp>

#include "host/sim/scenario/scenario.h"

namespace mfns::host {

struct RenderOptions {
  std::filesystem::path out_dir;
  int threads = 0;            // 0: all cores
  bool write_images = true;   // false: truth, blobs and bound only (fast)
  bool progress = true;       // a progress line on stderr
};

struct RenderSummary {
  int frames = 0;
  int frames_with_3 = 0;      // frame sets with >= 3 visible beacons in total
  int frames_with_none = 0;
  double mean_visible = 0.0;
};

// Renders scenario `s` (whose YAML text is `scenario_text`) into options.out_dir (created if
// missing). DIR/frames is replaced as a whole once every new frame is written (rendered into
// DIR/.frames.partial-PID first): no frame of an earlier render into DIR stays behind (with
// write_images false the earlier frames are removed), a failed render leaves the earlier frames
// untouched, and files of DIR other than the outputs above are left alone. Throws UserError on
// I/O failure and for a scenario without beacons.
RenderSummary RenderScenario(const Scenario& s, const std::string& scenario_text, const RenderOptions& options);

// Camera `camera`'s frame of frame set f, the very image `render` writes for it (its own random
// stream), in memory: for runs that feed the firmware in process (host/sim/faults).
cv::Mat RenderCameraFrame(const Scenario& s, const FrameTruth& f, int camera);

// Writes crb.csv (see above) for the scenario's trajectory into path, returns visibility
// statistics.
RenderSummary WriteBoundCsv(const Scenario& s, const std::filesystem::path& path);

}  // namespace mfns::host
