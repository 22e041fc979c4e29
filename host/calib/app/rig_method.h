// The methods of `mfns-calib rig --method` (calibrate.h runs them): the name a user types and
// its check, apart from the solvers so that the command line's checks (calib_cli.h) and its fuzz
// target need neither OpenCV nor Ceres.
#pragma once

#include <string>

namespace mfns::host {

enum class RigMethod : unsigned char { kMl, kPaper, kOpenCvHandEye };
const char* ToString(RigMethod m);
RigMethod ParseRigMethod(const std::string& s);  // "ml", "paper", "opencv-handeye"; UserError otherwise

}  // namespace mfns::host
