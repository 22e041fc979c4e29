#include "host/calib/survey/turntable_placement_yaml.h"

#include <cmath>
#include <cstdio>

#include "common/rotation/rotation.h"
#include "host/rigio/yaml_fields.h"
#include "host/util/atomic_file.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

// One optional (value, sigma) pair of the file: both or neither. *v in the file's units.
bool ReadPair(const YAML::Node& root, const char* value_key, const char* sigma_key, const YamlCtx& ctx,
              Eigen::Vector3d* v, double* sigma) {
  const bool has_value = Has(root, value_key), has_sigma = Has(root, sigma_key);
  if (has_value != has_sigma) {
    const char* given = has_value ? value_key : sigma_key;
    const char* missing = has_value ? sigma_key : value_key;
    ctx.Sub(given).Fail(root[given], std::string("needs ") + missing + " beside it");
  }
  if (!has_value) return false;
  const std::array<double, 3> a = Numbers<3>(root[value_key], ctx.Sub(value_key));
  *v = Eigen::Vector3d(a[0], a[1], a[2]);
  *sigma = Number(root[sigma_key], ctx.Sub(sigma_key));
  // (In m, or in rad from deg, at least 1e-3 of it: that must be a usable sigma.)
  if (!UsableSigma(*sigma * 1e-3)) ctx.Sub(sigma_key).Fail(root[sigma_key], "must be positive");
  return true;
}

TurntablePlacement ParsePlacement(const std::string& text, const std::string& source) {
  const YAML::Node root = LoadYaml(text, source);
  const YamlCtx ctx{source, ""};
  if (!root.IsMap()) ctx.Fail(root, "expected a map with centre_mm, centre_b_mm and/or axis (and their sigmas)");
  RejectUnknownKeys(root, {"centre_mm", "centre_sigma_mm", "centre_b_mm", "centre_b_sigma_mm", "axis", "axis_sigma_deg"},
                    ctx);
  TurntablePlacement t;
  double sigma = 0.0;
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  if ((t.has_centre = ReadPair(root, "centre_mm", "centre_sigma_mm", ctx, &v, &sigma))) {
    t.centre_w = v * 1e-3;
    t.centre_sigma_m = sigma * 1e-3;
  }
  if ((t.has_centre_b = ReadPair(root, "centre_b_mm", "centre_b_sigma_mm", ctx, &v, &sigma))) {
    t.centre_b = v * 1e-3;
    t.centre_b_sigma_m = sigma * 1e-3;
  }
  if ((t.has_axis = ReadPair(root, "axis", "axis_sigma_deg", ctx, &v, &sigma))) {
    // (A norm that overflows or underflows is no direction either.)
    const double n = v.norm();
    if (!(n > 0.0) || !std::isfinite(n) || !(v / n).allFinite()) ctx.Sub("axis").Fail(root["axis"], "must not be 0");
    t.axis_w = v / n;
    t.axis_sigma_rad = DegToRad(sigma);
  }
  if (!t.Any())
    ctx.Fail(root, "no placement: give centre_mm, centre_b_mm and/or axis, each with its sigma");
  return t;  // (TurntablePlacement::IsValid holds: finite values, usable sigmas, a unit axis)
}

std::string Triple(const Eigen::Vector3d& v, int digits) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "[%.*f, %.*f, %.*f]", digits, v.x(), digits, v.y(), digits, v.z());
  return buf;
}

std::string Scalar(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

}  // namespace

TurntablePlacement ParseTurntablePlacementYaml(const std::string& text, const std::string& source) {
  return CatchYamlErrors(source, [&] { return ParsePlacement(text, source); });
}

TurntablePlacement ReadTurntablePlacementYaml(const std::filesystem::path& path) {
  return ParseTurntablePlacementYaml(ReadFile(path, 64u << 10), path.string());
}

std::string FormatTurntablePlacementYaml(const TurntablePlacement& t, const std::string& comment) {
  std::string out = comment.empty() ? "" : "# " + comment + "\n";
  if (t.has_centre)
    out += "centre_mm: " + Triple(t.centre_w * 1e3, 6) + "\ncentre_sigma_mm: " + Scalar(t.centre_sigma_m * 1e3, 6) + "\n";
  if (t.has_centre_b)
    out += "centre_b_mm: " + Triple(t.centre_b * 1e3, 6) + "\ncentre_b_sigma_mm: " + Scalar(t.centre_b_sigma_m * 1e3, 6) +
           "\n";
  if (t.has_axis) out += "axis: " + Triple(t.axis_w, 9) + "\naxis_sigma_deg: " + Scalar(RadToDeg(t.axis_sigma_rad), 7) + "\n";
  return out;
}

}  // namespace mfns::host
