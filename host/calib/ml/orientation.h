// Settles the 180-degree ambiguity of a symmetric checkerboard (cols + rows even; see
// detect/target_detector.h) from the turntable's kinematics, before any rig is solved.
//
// Turning a view's labels (id -> N - 1 - id) moves its camera pose by F, the half turn about
// the board's normal through its centre. Within one camera, the relative rotation between
// two turntable images has the angle of the commanded relative platform rotation (a
// conjugation keeps angles), so each view takes the labelling that agrees with the camera's
// first view. Across cameras, each camera's own closed-form C_w_t must agree with the
// others': a whole camera is turned when that agrees better. The one choice left (the world
// frame itself, undecidable from a symmetric board) is the one whose C_w_t is nearer the
// identity, the paper's alignment (Appendix A.3).
#pragma once

#include <string>
#include <vector>

#include "host/calib/core/calib_types.h"
#include "host/calib/core/kinematics.h"

namespace mfns::host {

struct OrientationReport {
  int views_turned = 0;
  std::vector<std::string> notes;
};

// in->views with orientation_ambiguous set may be relabelled (and their flag cleared);
// view_T_w_k (per view, C_w_k and r_w_wk from Zhang) is moved with them. Free views are
// left as they are (their poses are free anyway).
OrientationReport ResolveOrientation(CalibInput* in, std::vector<Transform>* view_T_w_k);

}  // namespace mfns::host
