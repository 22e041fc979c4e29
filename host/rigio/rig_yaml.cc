#include "host/rigio/rig_yaml.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <sstream>

#include "common/rotation/rotation.h"
#include "host/rigio/yaml_fields.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

constexpr double kMm = 1e-3;

Eigen::Vector3d Vec3(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

template <std::size_t N>
void CopyName(const std::string& s, std::array<char, N>& out, const YAML::Node& n, const YamlCtx& ctx) {
  if (s.empty() || s.size() >= N)
    ctx.Fail(n, "must be 1.." + std::to_string(N - 1) + " characters, got '" + s + "'");
  for (char c : s)
    if (c < 0x21 || c > 0x7e) ctx.Fail(n, "must be printable ASCII without spaces");
  out.fill('\0');
  std::memcpy(out.data(), s.data(), s.size());
}

Eigen::Matrix3d ReadRotation(const YAML::Node& cam, const YamlCtx& ctx) {
  const YAML::Node c_node = cam["C_k_b"], e_node = cam["euler_deg"];
  const bool has_c = c_node.IsDefined() && !c_node.IsNull();
  const bool has_e = e_node.IsDefined() && !e_node.IsNull();
  if (!has_c && !has_e) ctx.Fail(cam, "needs C_k_b or euler_deg");
  Eigen::Matrix3d C;
  if (has_e) {
    const auto e = Numbers<3>(e_node, ctx.Sub("euler_deg"));
    C = EulerToMatrix({DegToRad(e[0]), DegToRad(e[1]), DegToRad(e[2])});
  }
  if (has_c) {
    const auto m = Numbers<9>(c_node, ctx.Sub("C_k_b"));
    Eigen::Matrix3d Cm;
    Cm << m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8];
    if (!IsRotation(Cm, 1e-6)) ctx.Sub("C_k_b").Fail(c_node, "not a rotation matrix (orthonormal, det +1)");
    // Kept as the nearest exact rotation: the writer derives euler_deg from it, and near the
    // 2-1-3 set's singularity (phi = +-90 deg) a matrix 1e-7 off orthonormal gave angles that
    // the reader then refused as disagreeing with C_k_b (found by rig_yaml_fuzz).
    Cm = NearestRotation(Cm);
    if (has_e) {
      const double diff = LogSO3(Cm * C.transpose()).norm();
      if (diff > 1e-6)
        ctx.Sub("euler_deg").Fail(e_node, "disagrees with C_k_b by " + std::to_string(RadToDeg(diff)) + " deg");
    }
    C = Cm;
  }
  return C;
}

void ReadSigma(const YAML::Node& s, const YamlCtx& ctx, RigCameraSigma* out) {
  if (!s.IsMap()) ctx.Fail(s, "expected a map");
  out->intrinsics = Numbers<5>(Require(s, "intrinsics", ctx), ctx.Sub("intrinsics"));
  out->distortion = Numbers<5>(Require(s, "distortion", ctx), ctx.Sub("distortion"));
  out->euler = Vec3(Numbers<3>(Require(s, "euler_deg", ctx), ctx.Sub("euler_deg"))) * DegToRad(1.0);
  out->r_b_bk = Vec3(Numbers<3>(Require(s, "r_b_bk_mm", ctx), ctx.Sub("r_b_bk_mm"))) * kMm;
  for (double v : out->intrinsics)
    if (v < 0) ctx.Sub("intrinsics").Fail(s, "sigma must not be negative");
  for (double v : out->distortion)
    if (v < 0) ctx.Sub("distortion").Fail(s, "sigma must not be negative");
  if ((out->euler.array() < 0).any() || (out->r_b_bk.array() < 0).any())
    ctx.Fail(s, "sigma must not be negative");
}

void ReadCamera(const YAML::Node& n, const YamlCtx& ctx, RigCamera* cam, RigCameraSigma* sigma, bool* has_sigma) {
  if (!n.IsMap()) ctx.Fail(n, "expected a map");
  const YAML::Node name = Require(n, "name", ctx);
  CopyName(String(name, ctx.Sub("name")), cam->name, name, ctx.Sub("name"));
  CameraIntrinsics& k = cam->intrinsics;
  k.width = Integer(Require(n, "width", ctx), ctx.Sub("width"));
  k.height = Integer(Require(n, "height", ctx), ctx.Sub("height"));
  if (k.width <= 0 || k.width > limits::kMaxImageWidth || k.height <= 0 || k.height > limits::kMaxImageHeight)
    ctx.Fail(n, "image size " + std::to_string(k.width) + "x" + std::to_string(k.height) +
                    " outside 1.." + std::to_string(limits::kMaxImageWidth) + "x" +
                    std::to_string(limits::kMaxImageHeight));
  const auto intr = Numbers<5>(Require(n, "intrinsics", ctx), ctx.Sub("intrinsics"));
  k.alpha_x = intr[0];
  k.alpha_y = intr[1];
  k.skew = intr[2];
  k.u0 = intr[3];
  k.v0 = intr[4];
  k.kc = Numbers<5>(Require(n, "distortion", ctx), ctx.Sub("distortion"));
  cam->C_k_b = ReadRotation(n, ctx);
  cam->r_b_bk = Vec3(Numbers<3>(Require(n, "r_b_bk_mm", ctx), ctx.Sub("r_b_bk_mm"))) * kMm;
  const YAML::Node s = n["sigma"];
  if (s.IsDefined() && !s.IsNull()) {
    ReadSigma(s, ctx.Sub("sigma"), sigma);
    *has_sigma = true;
  }
}

// A length or an angle for an error message: 6 significant digits, no trailing zeros ("0.5").
std::string Short(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::general, 6);
  return std::string(buf, r.ptr);
}

// beacon_sigma_mm: one number (every beacon's 1-sigma per coordinate), or a list of one per
// beacons_mm entry, in its order (mfns-calib survey's); then beacon_sigma is their largest.
void ReadBeaconSigma(const YAML::Node& bs, const YamlCtx& ctx, Rig* rig) {
  if (!bs.IsSequence()) {
    rig->beacon_sigma = Number(bs, ctx) * kMm;
    if (rig->beacon_sigma < 0) ctx.Fail(bs, "must not be negative");
    return;
  }
  if (bs.size() != static_cast<std::size_t>(rig->num_beacons))
    ctx.Fail(bs, "expected one number or " + std::to_string(rig->num_beacons) +
                     " entries (one per beacons_mm entry), got " + std::to_string(bs.size()));
  rig->has_beacon_sigmas = true;
  rig->beacon_sigma = 0.0;
  for (std::size_t i = 0; i < bs.size(); ++i) {
    const double s = Number(bs[i], ctx.Index(i)) * kMm;
    if (s < 0) ctx.Index(i).Fail(bs[i], "must not be negative");
    rig->beacon_sigmas[i] = s;
    rig->beacon_sigma = std::max(rig->beacon_sigma, s);
  }
}

// beacon_facing: [[nx, ny, nz, half_angle_deg], ...], one per beacons_mm entry, in its order.
// A normal within 1e-3 of unit length is normalised (hand-typed or rounded values); anything
// further off is an error, as is a half-angle outside (0, 180] deg.
void ReadFacing(const YAML::Node& f, const YamlCtx& ctx, Rig* rig) {
  if (!f.IsSequence()) ctx.Fail(f, "expected a list of [nx, ny, nz, half_angle_deg]");
  if (f.size() != static_cast<std::size_t>(rig->num_beacons))
    ctx.Fail(f, "expected " + std::to_string(rig->num_beacons) + " entries (one per beacons_mm entry), got " +
                    std::to_string(f.size()));
  for (std::size_t i = 0; i < f.size(); ++i) {
    const YamlCtx ictx = ctx.Index(i);
    const auto v = Numbers<4>(f[i], ictx);
    const Eigen::Vector3d n(v[0], v[1], v[2]);
    const double length = n.norm();
    if (!(std::abs(length - 1.0) <= 1e-3)) ictx.Fail(f[i], "normal length " + Short(length) + ", expected 1");
    if (!(v[3] > 0.0 && v[3] <= 180.0))
      ictx.Fail(f[i], "half-angle " + Short(v[3]) + " deg, expected (0, 180]");
    rig->beacon_normal_w[i] = n / length;
    rig->beacon_half_angle[i] = std::min(DegToRad(v[3]), kPi);
  }
  rig->has_facing = true;
}

// 15 significant digits: any decimal of up to 15 digits (every published or measured value)
// prints back as written, and a computed double comes back within 1e-15 relative.
std::string Num(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::general, 15);
  return std::string(buf, r.ptr);
}

template <typename It>
std::string List(It begin, It end) {
  std::string s = "[";
  for (It it = begin; it != end; ++it) s += (it == begin ? "" : ", ") + Num(*it);
  return s + "]";
}

std::string List(std::initializer_list<double> v) { return List(v.begin(), v.end()); }

// The rig file's field of a camera problem (nullptr: the camera as a whole).
const char* CameraField(RigStatus s) {
  switch (s) {
    case RigStatus::kBadCameraName: return "name";
    case RigStatus::kBadIntrinsics: return "intrinsics";
    case RigStatus::kBadDistortion: return "distortion";
    case RigStatus::kNotARotation: return "C_k_b";
    case RigStatus::kBadCameraOffset: return "r_b_bk_mm";
    case RigStatus::kBadSigma: return "sigma";
    default: return nullptr;
  }
}

Rig ParseRig(const std::string& text, const std::string& source);

}  // namespace

void FailIfInvalid(const Rig& rig, const YAML::Node& root, const YamlCtx& ctx) {
  int bad_camera = -1, bad_beacon = -1;
  const RigStatus status = ValidateRig(rig, &bad_camera, &bad_beacon);
  if (status == RigStatus::kOk) return;
  if (bad_camera >= 0) {
    const auto i = static_cast<std::size_t>(bad_camera);
    const YAML::Node cam = root["cameras"][i];
    const char* field = CameraField(status);
    const YamlCtx where = ctx.Sub("cameras").Index(i);
    if (field != nullptr && Has(cam, field)) where.Sub(field).Fail(cam[field], ToString(status));
    where.Fail(cam, ToString(status));
  }
  if (bad_beacon >= 0) {
    const auto i = static_cast<std::size_t>(bad_beacon);
    const char* list = status == RigStatus::kBadFacing  ? "beacon_facing"
                       : status == RigStatus::kBadSigma ? "beacon_sigma_mm"
                                                        : "beacons_mm";
    std::string what = ToString(status);
    if (status == RigStatus::kDuplicateBeacon)
      what = "same position as beacons_mm[" + std::to_string(SameBeaconAs(rig, bad_beacon)) + "] (closer than " +
             Short(limits::kMinBeaconSeparationM / kMm) + " mm)";
    ctx.Sub(list).Index(i).Fail(root[list][i], what);
  }
  if (status == RigStatus::kBadSigma && Has(root, "beacon_sigma_mm"))
    ctx.Sub("beacon_sigma_mm").Fail(root["beacon_sigma_mm"], ToString(status));
  ctx.Fail(root, ToString(status));
}

Rig ParseRigYaml(const std::string& text, const std::string& source) {
  return CatchYamlErrors(source, [&] { return ParseRig(text, source); });
}

Rig ReadRigYaml(const std::filesystem::path& path) {
  return ParseRigYaml(ReadFile(path, 4u << 20), path.string());
}

namespace {

Rig ParseRig(const std::string& text, const std::string& source) {
  const YAML::Node root = LoadYaml(text, source);
  const YamlCtx ctx{source, ""};
  if (!root.IsMap()) ctx.Fail(root, "expected a map with rig_id and cameras");
  Rig rig;
  const YAML::Node id = Require(root, "rig_id", ctx);
  CopyName(String(id, ctx.Sub("rig_id")), rig.rig_id, id, ctx.Sub("rig_id"));

  const YAML::Node cams = Require(root, "cameras", ctx);
  if (!cams.IsSequence() || cams.size() == 0) ctx.Sub("cameras").Fail(cams, "expected a non-empty list");
  if (cams.size() > static_cast<std::size_t>(limits::kMaxCameras))
    ctx.Sub("cameras").Fail(cams, std::to_string(cams.size()) + " cameras, limit " + std::to_string(limits::kMaxCameras));
  rig.num_cameras = static_cast<int>(cams.size());
  for (std::size_t i = 0; i < cams.size(); ++i) {
    ReadCamera(cams[i], ctx.Sub("cameras").Index(i), &rig.cameras[i], &rig.sigma[i], &rig.has_sigma);
    for (std::size_t j = 0; j < i; ++j)
      if (std::strcmp(rig.cameras[j].name.data(), rig.cameras[i].name.data()) == 0)
        ctx.Sub("cameras").Index(i).Sub("name").Fail(cams[i], "repeats the name of cameras[" + std::to_string(j) + "]");
  }

  const YAML::Node beacons = root["beacons_mm"];
  if (beacons.IsDefined() && !beacons.IsNull()) {
    const YamlCtx bctx = ctx.Sub("beacons_mm");
    if (!beacons.IsSequence()) bctx.Fail(beacons, "expected a list of [x, y, z]");
    if (beacons.size() > static_cast<std::size_t>(limits::kMaxBeacons))
      bctx.Fail(beacons, std::to_string(beacons.size()) + " beacons, limit " + std::to_string(limits::kMaxBeacons));
    rig.num_beacons = static_cast<int>(beacons.size());
    for (std::size_t i = 0; i < beacons.size(); ++i)
      rig.beacons_w[i] = Vec3(Numbers<3>(beacons[i], bctx.Index(i))) * kMm;
  }
  const YAML::Node bs = root["beacon_sigma_mm"];
  if (bs.IsDefined() && !bs.IsNull()) ReadBeaconSigma(bs, ctx.Sub("beacon_sigma_mm"), &rig);
  const YAML::Node facing = root["beacon_facing"];
  if (facing.IsDefined() && !facing.IsNull()) ReadFacing(facing, ctx.Sub("beacon_facing"), &rig);

  FailIfInvalid(rig, root, ctx);
  return rig;
}

}  // namespace

std::string FormatRigYaml(const Rig& rig) {
  std::ostringstream o;
  o << "# MFNS rig file (DESIGN.md): lengths in mm, angles in deg, intrinsics in px.\n";
  o << "rig_id: " << rig.rig_id.data() << "\ncameras:\n";
  for (int i = 0; i < rig.num_cameras; ++i) {
    const auto idx = static_cast<std::size_t>(i);
    const RigCamera& c = rig.cameras[idx];
    const CameraIntrinsics& k = c.intrinsics;
    const EulerAngles e = MatrixToEuler(c.C_k_b);
    const Eigen::Vector3d r_mm = c.r_b_bk / kMm;
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> C = c.C_k_b;
    o << "  - name: " << c.name.data() << "\n";
    o << "    width: " << k.width << "\n    height: " << k.height << "\n";
    o << "    intrinsics: " << List({k.alpha_x, k.alpha_y, k.skew, k.u0, k.v0}) << "\n";
    o << "    distortion: " << List(k.kc.begin(), k.kc.end()) << "\n";
    o << "    C_k_b: " << List(C.data(), C.data() + 9) << "\n";
    o << "    euler_deg: " << List({RadToDeg(e.phi), RadToDeg(e.theta), RadToDeg(e.psi)}) << "\n";
    o << "    r_b_bk_mm: " << List({r_mm.x(), r_mm.y(), r_mm.z()}) << "\n";
    if (rig.has_sigma) {
      const RigCameraSigma& s = rig.sigma[idx];
      const Eigen::Vector3d e_deg = s.euler * RadToDeg(1.0), sr_mm = s.r_b_bk / kMm;
      o << "    sigma:\n";
      o << "      intrinsics: " << List(s.intrinsics.begin(), s.intrinsics.end()) << "\n";
      o << "      distortion: " << List(s.distortion.begin(), s.distortion.end()) << "\n";
      o << "      euler_deg: " << List({e_deg.x(), e_deg.y(), e_deg.z()}) << "\n";
      o << "      r_b_bk_mm: " << List({sr_mm.x(), sr_mm.y(), sr_mm.z()}) << "\n";
    }
  }
  if (rig.num_beacons > 0) {
    o << "beacons_mm:\n";
    for (int i = 0; i < rig.num_beacons; ++i) {
      const Eigen::Vector3d b = rig.beacons_w[static_cast<std::size_t>(i)] / kMm;
      o << "  - " << List({b.x(), b.y(), b.z()}) << "\n";
    }
  }
  if (rig.has_beacon_sigmas && rig.num_beacons > 0) {
    o << "beacon_sigma_mm: [";  // one per beacon (mfns-calib survey)
    for (int i = 0; i < rig.num_beacons; ++i)
      o << (i == 0 ? "" : ", ") << Num(rig.beacon_sigmas[static_cast<std::size_t>(i)] / kMm);
    o << "]\n";
  } else if (rig.beacon_sigma > 0) {
    o << "beacon_sigma_mm: " << Num(rig.beacon_sigma / kMm) << "\n";
  }
  if (rig.has_facing) {
    o << "beacon_facing:" << (rig.num_beacons == 0 ? " []" : "") << "  # [nx, ny, nz, half_angle_deg] per beacon\n";
    for (int i = 0; i < rig.num_beacons; ++i) {
      const auto m = static_cast<std::size_t>(i);
      const Eigen::Vector3d& n = rig.beacon_normal_w[m];
      o << "  - " << List({n.x(), n.y(), n.z(), RadToDeg(rig.beacon_half_angle[m])}) << "\n";
    }
  }
  return o.str();
}

void WriteRigYaml(const std::filesystem::path& path, const Rig& rig) {
  int bad_camera = -1;
  const RigStatus status = ValidateRig(rig, &bad_camera);
  if (status != RigStatus::kOk)
    throw UserError(path.string() + ": refusing to write an invalid rig" +
                    (bad_camera >= 0 ? " (cameras[" + std::to_string(bad_camera) + "])" : "") + ": " +
                    ToString(status));
  WriteFileAtomic(path, FormatRigYaml(rig));
}

}  // namespace mfns::host
