#include "host/calib/app/rig_method.h"

#include "host/util/user_error.h"

namespace mfns::host {

const char* ToString(RigMethod m) {
  switch (m) {
    case RigMethod::kMl: return "ml";
    case RigMethod::kPaper: return "paper";
    case RigMethod::kOpenCvHandEye: return "opencv-handeye";
  }
  return "?";
}

RigMethod ParseRigMethod(const std::string& s) {
  if (s == "ml") return RigMethod::kMl;
  if (s == "paper") return RigMethod::kPaper;
  if (s == "opencv-handeye") return RigMethod::kOpenCvHandEye;
  throw UserError("--method \"" + OneLine(s) + "\": expected ml, paper or opencv-handeye");
}

}  // namespace mfns::host
