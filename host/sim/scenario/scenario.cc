#include "host/sim/scenario/scenario.h"

#include <cmath>
#include <random>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "host/rigio/rig_yaml.h"
#include "host/rigio/yaml_fields.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

constexpr double kMm = 1e-3;
constexpr double kArcsec = kPi / 180.0 / 3600.0;

Eigen::Vector3d Vec3(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

Eigen::Matrix3d EulerDeg(const std::array<double, 3>& e) {
  return EulerToMatrix({DegToRad(e[0]), DegToRad(e[1]), DegToRad(e[2])});
}

Rig ReadRigField(const YAML::Node& root, const YamlCtx& ctx, const std::filesystem::path& base_dir) {
  if (!Has(root, "rig")) return PaperRig();
  const std::string name = String(root["rig"], ctx.Sub("rig"));
  if (name == "paper") return PaperRig();
  const std::filesystem::path path = std::filesystem::path(name).is_absolute() ? std::filesystem::path(name) : base_dir / name;
  // The rig file's own error (missing, or its file:line: field) behind the scenario's line, so
  // that the user sees which scenario named it.
  try {
    return ReadRigYaml(path);
  } catch (const UserError& e) {
    ctx.Sub("rig").Fail(root["rig"], e.what());
  }
}

void ReadModule(const YAML::Node& n, const YamlCtx& ctx, StationModule* m) {
  const std::string shape = String(Require(n, "shape", ctx), ctx.Sub("shape"));
  if (shape == "cylinder") {
    RejectUnknownKeys(n, {"shape", "diameter_mm", "length_mm"}, ctx);
    m->shape = ModuleShape::kCylinder;
    m->diameter = Number(Require(n, "diameter_mm", ctx), ctx.Sub("diameter_mm")) * kMm;
    m->length = Number(Require(n, "length_mm", ctx), ctx.Sub("length_mm")) * kMm;
    if (!(m->diameter >= 0.5 && m->diameter <= 50.0)) ctx.Sub("diameter_mm").Fail(n["diameter_mm"], "must be 500..50000");
    if (!(m->length >= 0.5 && m->length <= 200.0)) ctx.Sub("length_mm").Fail(n["length_mm"], "must be 500..200000");
  } else if (shape == "box") {
    RejectUnknownKeys(n, {"shape", "size_mm"}, ctx);
    m->shape = ModuleShape::kBox;
    m->size = Vec3(Numbers<3>(Require(n, "size_mm", ctx), ctx.Sub("size_mm"))) * kMm;
    if (!(m->size.minCoeff() >= 0.5 && m->size.maxCoeff() <= 200.0))
      ctx.Sub("size_mm").Fail(n["size_mm"], "every side must be 500..200000");
  } else {
    ctx.Sub("shape").Fail(n["shape"], "expected cylinder or box, got '" + shape + "'");
  }
}

void ReadBeaconLayout(const YAML::Node& n, const YamlCtx& ctx, BeaconLayout* b) {
  RejectUnknownKeys(n, {"layout", "count", "seed", "jitter", "end_caps", "half_angle_deg", "facing"}, ctx);
  b->present = true;
  const std::string layout = Has(n, "layout") ? String(n["layout"], ctx.Sub("layout")) : "jittered-grid";
  if (layout == "jittered-grid") {
    b->layout = BeaconLayoutKind::kJitteredGrid;
  } else if (layout == "random") {
    b->layout = BeaconLayoutKind::kRandom;
  } else {
    ctx.Sub("layout").Fail(n["layout"], "expected jittered-grid or random, got '" + layout + "'");
  }
  b->count = Integer(Require(n, "count", ctx), ctx.Sub("count"));
  if (b->count < 10 || b->count > limits::kMaxBeacons)
    ctx.Sub("count").Fail(n["count"], "must be 10.." + std::to_string(limits::kMaxBeacons));
  if (Has(n, "seed")) {
    const long long seed = n["seed"].as<long long>(-1);
    if (seed < 0) ctx.Sub("seed").Fail(n["seed"], "expected a non-negative integer");
    b->seed_given = true;
    b->seed = static_cast<std::uint64_t>(seed);
  }
  b->jitter = NumberOr(n, "jitter", b->jitter, ctx);
  if (!(b->jitter >= 0.0 && b->jitter <= 0.5)) ctx.Sub("jitter").Fail(n["jitter"], "must be 0..0.5 (a fraction of the cell)");
  b->end_caps = BooleanOr(n, "end_caps", b->end_caps, ctx);
  const double half_deg = NumberOr(n, "half_angle_deg", RadToDeg(b->half_angle), ctx);
  if (!(half_deg > 0.0 && half_deg <= 180.0)) ctx.Sub("half_angle_deg").Fail(n["half_angle_deg"], "must be in (0, 180]");
  b->half_angle = DegToRad(half_deg);
  b->facing = BooleanOr(n, "facing", b->facing, ctx);
}

// Beacons generated on the module's walls, each facing inward with the layout's beam.
void GenerateBeacons(const Scenario& s, Rig* rig) {
  const std::vector<WallBeacon> walls = GenerateWallBeacons(s.module, s.beacon_layout, s.map_seed);
  rig->num_beacons = static_cast<int>(walls.size());
  rig->has_facing = true;
  for (std::size_t i = 0; i < walls.size(); ++i) {
    rig->beacons_w[i] = walls[i].p_w;
    rig->beacon_normal_w[i] = walls[i].normal_w;
    rig->beacon_half_angle[i] = s.beacon_layout.half_angle;
  }
}

// Static reflections: random points on the module's walls from the map seed (their own
// stream), with the generated beacons' beam (60 deg when the beacons are not generated).
void GenerateReflectors(const YAML::Node& n, const YamlCtx& ctx, Scenario* s) {
  Clutter& c = s->clutter;
  c.reflectors = s->rig;
  c.reflectors.num_beacons = 0;
  c.reflectors.has_facing = true;
  if (c.static_reflections == 0) return;
  if (s->module.shape == ModuleShape::kNone)
    ctx.Sub("spurious").Sub("static_reflections").Fail(n["spurious"]["static_reflections"], "needs a module (its walls reflect)");
  BeaconLayout layout = s->beacon_layout;
  layout.layout = BeaconLayoutKind::kRandom;
  layout.count = c.static_reflections;
  layout.end_caps = true;
  const std::vector<WallBeacon> points = GenerateWallBeacons(s->module, layout, s->map_seed ^ 0x5ef1ec7u);
  c.reflectors.num_beacons = static_cast<int>(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    c.reflectors.beacons_w[i] = points[i].p_w;
    c.reflectors.beacon_normal_w[i] = points[i].normal_w;
    c.reflectors.beacon_half_angle[i] = layout.half_angle;
  }
}

// beacon_facing: [[nx, ny, nz, half_angle_deg], ...], one per beacon (beacons_mm or the rig's),
// as in the rig file: a normal within 1e-3 of unit length is normalised.
void ReadBeaconFacing(const YAML::Node& f, const YamlCtx& ctx, Rig* rig) {
  if (!f.IsSequence()) ctx.Fail(f, "expected a list of [nx, ny, nz, half_angle_deg]");
  if (f.size() != static_cast<std::size_t>(rig->num_beacons))
    ctx.Fail(f, "expected " + std::to_string(rig->num_beacons) + " entries (one per beacon), got " + std::to_string(f.size()));
  for (std::size_t i = 0; i < f.size(); ++i) {
    const auto v = Numbers<4>(f[i], ctx.Index(i));
    const Eigen::Vector3d n(v[0], v[1], v[2]);
    if (!(std::abs(n.norm() - 1.0) <= 1e-3)) ctx.Index(i).Fail(f[i], "normal length " + std::to_string(n.norm()) + ", expected 1");
    if (!(v[3] > 0.0 && v[3] <= 180.0)) ctx.Index(i).Fail(f[i], "half-angle must be in (0, 180] deg");
    rig->beacon_normal_w[i] = n.normalized();
    rig->beacon_half_angle[i] = DegToRad(v[3]);
  }
  rig->has_facing = true;
}

void ReadBeacons(const YAML::Node& root, const YamlCtx& ctx, Rig* rig) {
  if (Has(root, "beacons_mm")) {
    const YAML::Node b = root["beacons_mm"];
    const YamlCtx bctx = ctx.Sub("beacons_mm");
    if (!b.IsSequence()) bctx.Fail(b, "expected a list of [x, y, z]");
    if (b.size() > static_cast<std::size_t>(limits::kMaxBeacons))
      bctx.Fail(b, std::to_string(b.size()) + " beacons, limit " + std::to_string(limits::kMaxBeacons));
    rig->num_beacons = static_cast<int>(b.size());
    for (std::size_t i = 0; i < b.size(); ++i) rig->beacons_w[i] = Vec3(Numbers<3>(b[i], bctx.Index(i))) * kMm;
    rig->has_facing = false;  // a rig file's facing was for its own beacons
  }
  if (Has(root, "beacon_facing")) ReadBeaconFacing(root["beacon_facing"], ctx.Sub("beacon_facing"), rig);
  if (Has(root, "beacon_sigma_mm")) rig->beacon_sigma = Number(root["beacon_sigma_mm"], ctx.Sub("beacon_sigma_mm")) * kMm;
  // A calibration session (target:) needs no beacons: its rig may be a calibration result
  // without a map. Everything else (render, crb, navmatrix) does.
  if (rig->num_beacons == 0 && !Has(root, "target"))
    ctx.Fail(root, "the scenario has no beacons (give beacons_mm or a rig with beacons)");
  // The rig file was checked when read; the scenario's own beacons_mm, facing and sigma are
  // checked the same way (found by scenario_yaml_fuzz: a beacon 5.9 km out passed).
  FailIfInvalid(*rig, root, ctx);
}

void ReadTurntable(const YAML::Node& n, const YamlCtx& ctx, Turntable* tt) {
  RejectUnknownKeys(n, {"C_w_t_euler_deg", "r_w_wt_mm", "mount_euler_deg", "mount_r_p_pb_mm"}, ctx);
  if (Has(n, "C_w_t_euler_deg")) tt->C_w_t = EulerDeg(Numbers<3>(n["C_w_t_euler_deg"], ctx.Sub("C_w_t_euler_deg")));
  if (Has(n, "r_w_wt_mm")) tt->r_w_wt = Vec3(Numbers<3>(n["r_w_wt_mm"], ctx.Sub("r_w_wt_mm"))) * kMm;
  if (Has(n, "mount_euler_deg")) tt->C_p_b = EulerDeg(Numbers<3>(n["mount_euler_deg"], ctx.Sub("mount_euler_deg")));
  if (Has(n, "mount_r_p_pb_mm")) tt->r_p_pb = Vec3(Numbers<3>(n["mount_r_p_pb_mm"], ctx.Sub("mount_r_p_pb_mm"))) * kMm;
}

// A positive number in the given unit.
double Positive(const YAML::Node& n, const char* key, double fallback_si, double unit, const YamlCtx& ctx) {
  const double v = NumberOr(n, key, fallback_si / unit, ctx) * unit;
  if (!(v > 0.0)) ctx.Sub(key).Fail(n[key], "must be positive");
  return v;
}

void ReadWander(const YAML::Node& n, const YamlCtx& ctx, Trajectory* tr) {
  RejectUnknownKeys(n, {"kind", "margin_mm", "max_speed_mm_s", "max_accel_mm_s2", "max_rate_deg_s",
                        "max_angular_accel_deg_s2", "correlation_s"}, ctx);
  tr->kind = TrajectoryKind::kWander;
  WanderLimits& w = tr->wander;
  w.margin = NumberOr(n, "margin_mm", w.margin / kMm, ctx) * kMm;
  if (w.margin < 0.0) ctx.Sub("margin_mm").Fail(n["margin_mm"], "must not be negative");
  w.max_speed = Positive(n, "max_speed_mm_s", w.max_speed, kMm, ctx);
  w.max_accel = Positive(n, "max_accel_mm_s2", w.max_accel, kMm, ctx);
  w.max_rate = Positive(n, "max_rate_deg_s", w.max_rate, DegToRad(1.0), ctx);
  w.max_angular_accel = Positive(n, "max_angular_accel_deg_s2", w.max_angular_accel, DegToRad(1.0), ctx);
  w.correlation_s = Positive(n, "correlation_s", w.correlation_s, 1.0, ctx);
}

// The wander trajectory needs a module with room for its margin and steering band.
void CheckWanderRoom(const Scenario& s, const YAML::Node& n, const YamlCtx& ctx) {
  if (s.trajectory.kind != TrajectoryKind::kWander) return;
  if (s.module.shape == ModuleShape::kNone) ctx.Sub("kind").Fail(n["kind"], "wander needs a module (module: {shape: ...})");
  const double keep_out = s.trajectory.wander.margin + WanderBuffer(s.trajectory.wander, 1.0 / s.frame_rate_hz);
  const double room = s.module.shape == ModuleShape::kBox ? s.module.size.minCoeff()
                                                          : std::min(s.module.diameter, s.module.length);
  if (room <= 2.0 * keep_out + 0.05)
    ctx.Fail(n, "the module (" + std::to_string(std::lround(room / kMm)) + " mm at its narrowest) has no room for " +
                    std::to_string(std::lround(keep_out / kMm)) + " mm (margin and steering band) on both sides");
}

void ReadTrajectory(const YAML::Node& n, const YamlCtx& ctx, Trajectory* tr) {
  const std::string kind = String(Require(n, "kind", ctx), ctx.Sub("kind"));
  if (kind == "static") {
    RejectUnknownKeys(n, {"kind", "position_mm", "euler_deg"}, ctx);
    tr->kind = TrajectoryKind::kStatic;
    if (Has(n, "position_mm")) tr->static_pose.r_w_wb = Vec3(Numbers<3>(n["position_mm"], ctx.Sub("position_mm"))) * kMm;
    // Attitude as DESIGN.md reports it: the Euler angles of C_b_w.
    if (Has(n, "euler_deg")) tr->static_pose.C_w_b = EulerDeg(Numbers<3>(n["euler_deg"], ctx.Sub("euler_deg"))).transpose();
  } else if (kind == "turntable") {
    RejectUnknownKeys(n, {"kind", "mode", "main_start_deg", "main_step_deg", "main_rate_deg_s", "aux_start_deg",
                          "aux_step_deg", "aux_rate_deg_s"}, ctx);
    tr->kind = TrajectoryKind::kTurntable;
    const std::string mode = Has(n, "mode") ? String(n["mode"], ctx.Sub("mode")) : "steps";
    if (mode != "steps" && mode != "rate") ctx.Sub("mode").Fail(n["mode"], "expected 'steps' or 'rate', got '" + mode + "'");
    tr->turntable_rate_mode = mode == "rate";
    tr->main_start = DegToRad(NumberOr(n, "main_start_deg", 0, ctx));
    tr->main_step = DegToRad(NumberOr(n, "main_step_deg", 0, ctx));
    tr->main_rate = DegToRad(NumberOr(n, "main_rate_deg_s", 0, ctx));
    tr->aux_start = DegToRad(NumberOr(n, "aux_start_deg", 0, ctx));
    tr->aux_step = DegToRad(NumberOr(n, "aux_step_deg", 0, ctx));
    tr->aux_rate = DegToRad(NumberOr(n, "aux_rate_deg_s", 0, ctx));
  } else if (kind == "free-flight") {
    RejectUnknownKeys(n, {"kind", "centre_mm", "amplitude_mm", "period_s", "tilt_deg", "yaw_rate_deg_s"}, ctx);
    tr->kind = TrajectoryKind::kFreeFlight;
    if (Has(n, "centre_mm")) tr->centre = Vec3(Numbers<3>(n["centre_mm"], ctx.Sub("centre_mm"))) * kMm;
    tr->amplitude = Vec3(Numbers<3>(Require(n, "amplitude_mm", ctx), ctx.Sub("amplitude_mm"))) * kMm;
    tr->period_s = NumberOr(n, "period_s", 20.0, ctx);
    if (!(tr->period_s > 0)) ctx.Sub("period_s").Fail(n["period_s"], "must be positive");
    tr->tilt = DegToRad(NumberOr(n, "tilt_deg", 0, ctx));
    tr->yaw_rate = DegToRad(NumberOr(n, "yaw_rate_deg_s", 0, ctx));
  } else if (kind == "wander") {
    ReadWander(n, ctx, tr);
  } else {
    ctx.Sub("kind").Fail(n["kind"], "expected static, turntable, free-flight or wander, got '" + kind + "'");
  }
}

// `name: {enabled: bool, <magnitude_key>: number}` or absent.
void ReadSwitch(const YAML::Node& n, const char* name, const char* magnitude_key, double unit, const YamlCtx& ctx,
                bool* enabled, double* magnitude) {
  if (!Has(n, name)) return;
  const YAML::Node s = n[name];
  const YamlCtx sctx = ctx.Sub(name);
  RejectUnknownKeys(s, {"enabled", magnitude_key}, sctx);
  *enabled = BooleanOr(s, "enabled", true, sctx);
  if (Has(s, magnitude_key)) {
    *magnitude = Number(s[magnitude_key], sctx.Sub(magnitude_key)) * unit;
    if (*magnitude < 0) sctx.Sub(magnitude_key).Fail(s[magnitude_key], "must not be negative");
  }
}

void ReadErrors(const YAML::Node& n, const YamlCtx& ctx, ErrorSources* e) {
  RejectUnknownKeys(n, {"pixel_noise", "beacon_map", "intrinsics", "extrinsic_rotation", "extrinsic_translation",
                        "turntable_angle", "turntable_axis"}, ctx);
  ReadSwitch(n, "pixel_noise", "centroid_sigma_px", 1.0, ctx, &e->pixel_noise, &e->centroid_sigma_px);
  ReadSwitch(n, "beacon_map", "sigma_mm", kMm, ctx, &e->beacon_map, &e->beacon_sigma);
  ReadSwitch(n, "intrinsics", "scale", 1.0, ctx, &e->intrinsics, &e->intrinsics_scale);
  ReadSwitch(n, "extrinsic_rotation", "sigma_deg", DegToRad(1.0), ctx, &e->extrinsic_rotation,
             &e->extrinsic_rotation_sigma);
  ReadSwitch(n, "extrinsic_translation", "sigma_mm", kMm, ctx, &e->extrinsic_translation,
             &e->extrinsic_translation_sigma);
  ReadSwitch(n, "turntable_angle", "sigma_arcsec", kArcsec, ctx, &e->turntable_angle, &e->turntable_angle_sigma);
  ReadSwitch(n, "turntable_axis", "sigma_arcsec", kArcsec, ctx, &e->turntable_axis, &e->turntable_axis_sigma);
}

void ReadSensor(const YAML::Node& n, const YamlCtx& ctx, SensorSetup* s) {
  RejectUnknownKeys(n, {"mono16", "psf_sigma_px", "flux_e_at_1m", "background_e", "gain_e_per_dn", "read_noise_e",
                        "full_well_e", "edge_margin_px"}, ctx);
  s->edge_margin_px = NumberOr(n, "edge_margin_px", s->edge_margin_px, ctx);
  if (!(s->edge_margin_px >= 0.0 && s->edge_margin_px <= 100.0))
    ctx.Sub("edge_margin_px").Fail(n["edge_margin_px"], "must be 0..100");
  s->mono16 = BooleanOr(n, "mono16", s->mono16, ctx);
  s->psf_sigma_px = NumberOr(n, "psf_sigma_px", s->psf_sigma_px, ctx);
  s->flux_e_at_1m = NumberOr(n, "flux_e_at_1m", s->flux_e_at_1m, ctx);
  s->background_e = NumberOr(n, "background_e", s->background_e, ctx);
  s->gain_e_per_dn = NumberOr(n, "gain_e_per_dn", s->gain_e_per_dn, ctx);
  s->read_noise_e = NumberOr(n, "read_noise_e", s->read_noise_e, ctx);
  s->full_well_e = NumberOr(n, "full_well_e", s->full_well_e, ctx);
  if (!(s->psf_sigma_px > 0) || !(s->flux_e_at_1m > 0) || s->background_e < 0 || !(s->gain_e_per_dn > 0) ||
      s->read_noise_e < 0 || !(s->full_well_e > 0))
    ctx.Fail(n, "psf, flux, gain and full well must be positive; background and read noise not negative");
}

int CameraIndex(const Rig& rig, const std::string& name, const YAML::Node& n, const YamlCtx& ctx) {
  for (int i = 0; i < rig.num_cameras; ++i)
    if (name == rig.cameras[static_cast<std::size_t>(i)].name.data()) return i;
  ctx.Fail(n, "no camera named '" + name + "' in the rig");
}

// `frames: [first, last]`, inclusive (a window past the run's end never applies: --frames may
// shorten a run).
void ReadWindow(const YAML::Node& n, const YamlCtx& ctx, int* first, int* last) {
  const YAML::Node w = Require(n, "frames", ctx);
  const YamlCtx wctx = ctx.Sub("frames");
  if (!w.IsSequence() || w.size() != 2) wctx.Fail(w, "expected [first, last]");
  *first = Integer(w[0], wctx.Index(0));
  *last = Integer(w[1], wctx.Index(1));
  if (*first < 0 || *last < *first) wctx.Fail(w, "expected 0 <= first <= last");
}

std::vector<int> BeaconList(const YAML::Node& list, const YamlCtx& ctx, int num_beacons) {
  if (!list.IsSequence()) ctx.Fail(list, "expected a list of beacon indices");
  std::vector<int> out;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const int b = Integer(list[i], ctx.Index(i));
    if (b < 0 || b >= num_beacons) ctx.Index(i).Fail(list[i], "no beacon " + std::to_string(b));
    out.push_back(b);
  }
  return out;
}

void ReadSpurious(const YAML::Node& n, const YamlCtx& ctx, Clutter* c) {
  RejectUnknownKeys(n, {"count", "near_fraction", "near_radius_px", "static_reflections"}, ctx);
  c->spurious = IntegerOr(n, "count", 0, ctx);
  if (c->spurious < 0 || c->spurious > 100) ctx.Sub("count").Fail(n["count"], "must be 0..100");
  c->near_fraction = NumberOr(n, "near_fraction", c->near_fraction, ctx);
  if (!(c->near_fraction >= 0.0 && c->near_fraction <= 1.0)) ctx.Sub("near_fraction").Fail(n["near_fraction"], "must be 0..1");
  if (Has(n, "near_radius_px")) {
    const auto r = Numbers<2>(n["near_radius_px"], ctx.Sub("near_radius_px"));
    if (!(r[0] >= 0.0 && r[1] >= r[0] && r[1] <= 500.0))
      ctx.Sub("near_radius_px").Fail(n["near_radius_px"], "expected 0 <= min <= max <= 500");
    c->near_radius_min_px = r[0];
    c->near_radius_max_px = r[1];
  }
  c->static_reflections = IntegerOr(n, "static_reflections", 0, ctx);
  if (c->static_reflections < 0 || c->static_reflections > limits::kMaxBeacons)
    ctx.Sub("static_reflections").Fail(n["static_reflections"], "must be 0.." + std::to_string(limits::kMaxBeacons));
}

void ReadOcclusions(const YAML::Node& list, const YamlCtx& lctx, const Rig& rig, Clutter* c) {
  if (!list.IsSequence()) lctx.Fail(list, "expected a list");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YAML::Node n = list[i];
    const YamlCtx ctx = lctx.Index(i);
    RejectUnknownKeys(n, {"frames", "camera", "rect_px", "beacons"}, ctx);
    Clutter::Occlusion o;
    ReadWindow(n, ctx, &o.first_frame, &o.last_frame);
    if (Has(n, "camera")) o.camera = CameraIndex(rig, String(n["camera"], ctx.Sub("camera")), n["camera"], ctx.Sub("camera"));
    if (Has(n, "rect_px")) {
      if (o.camera < 0) ctx.Sub("rect_px").Fail(n["rect_px"], "a region needs its camera (camera: NAME)");
      const auto r = Numbers<4>(n["rect_px"], ctx.Sub("rect_px"));
      if (!(r[2] > r[0] && r[3] > r[1])) ctx.Sub("rect_px").Fail(n["rect_px"], "expected [u0, v0, u1, v1] with u1 > u0, v1 > v0");
      o.has_rect = true;
      o.rect_px = Eigen::Vector4d(r[0], r[1], r[2], r[3]);
    }
    if (Has(n, "beacons")) o.beacons = BeaconList(n["beacons"], ctx.Sub("beacons"), rig.num_beacons);
    c->occlusions.push_back(o);
  }
}

void ReadBlinded(const YAML::Node& list, const YamlCtx& lctx, const Rig& rig, Clutter* c) {
  if (!list.IsSequence()) lctx.Fail(list, "expected a list");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YAML::Node n = list[i];
    const YamlCtx ctx = lctx.Index(i);
    RejectUnknownKeys(n, {"camera", "frames", "mode"}, ctx);
    Clutter::Blinding b;
    b.camera = CameraIndex(rig, String(Require(n, "camera", ctx), ctx.Sub("camera")), n["camera"], ctx.Sub("camera"));
    ReadWindow(n, ctx, &b.first_frame, &b.last_frame);
    const std::string mode = Has(n, "mode") ? String(n["mode"], ctx.Sub("mode")) : "saturated";
    if (mode != "saturated" && mode != "black") ctx.Sub("mode").Fail(n["mode"], "expected saturated or black, got '" + mode + "'");
    b.saturated = mode == "saturated";
    c->blinded.push_back(b);
  }
}

void ReadClutter(const YAML::Node& n, const YamlCtx& ctx, const Rig& rig, Clutter* c) {
  RejectUnknownKeys(n, {"reflections_per_frame", "reflection_flux_scale", "bright_regions", "occluded_beacons",
                        "stop_camera", "stop_frame", "spurious", "occlusions", "blinded"}, ctx);
  if (Has(n, "spurious")) ReadSpurious(n["spurious"], ctx.Sub("spurious"), c);
  if (Has(n, "occlusions")) ReadOcclusions(n["occlusions"], ctx.Sub("occlusions"), rig, c);
  if (Has(n, "blinded")) ReadBlinded(n["blinded"], ctx.Sub("blinded"), rig, c);
  c->reflections_per_frame = IntegerOr(n, "reflections_per_frame", 0, ctx);
  c->reflection_flux_scale = NumberOr(n, "reflection_flux_scale", c->reflection_flux_scale, ctx);
  if (c->reflections_per_frame < 0 || c->reflections_per_frame > 50)
    ctx.Sub("reflections_per_frame").Fail(n["reflections_per_frame"], "must be 0..50");
  if (Has(n, "bright_regions")) {
    const YAML::Node list = n["bright_regions"];
    const YamlCtx lctx = ctx.Sub("bright_regions");
    if (!list.IsSequence()) lctx.Fail(list, "expected a list");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const YamlCtx ictx = lctx.Index(i);
      RejectUnknownKeys(list[i], {"camera", "rect_px", "level_e"}, ictx);
      Clutter::Region r;
      r.camera = CameraIndex(rig, String(Require(list[i], "camera", ictx), ictx.Sub("camera")), list[i], ictx.Sub("camera"));
      const auto rect = Numbers<4>(Require(list[i], "rect_px", ictx), ictx.Sub("rect_px"));
      r.rect_px = Eigen::Vector4d(rect[0], rect[1], rect[2], rect[3]);
      r.level_e = Number(Require(list[i], "level_e", ictx), ictx.Sub("level_e"));
      c->bright_regions.push_back(r);
    }
  }
  if (Has(n, "occluded_beacons")) c->occluded_beacons = BeaconList(n["occluded_beacons"], ctx.Sub("occluded_beacons"), rig.num_beacons);
  if (Has(n, "stop_camera")) {
    c->stop_camera = CameraIndex(rig, String(n["stop_camera"], ctx.Sub("stop_camera")), n["stop_camera"], ctx.Sub("stop_camera"));
    c->stop_frame = IntegerOr(n, "stop_frame", 0, ctx);
  }
}

void ReadCalibration(const YAML::Node& root, const YamlCtx& ctx, CalibrationSetup* c) {
  if (Has(root, "target")) {
    const YAML::Node t = root["target"];
    const YamlCtx tctx = ctx.Sub("target");
    const std::string type = String(Require(t, "type", tctx), tctx.Sub("type"));
    if (type == "checkerboard") {
      RejectUnknownKeys(t, {"type", "cols", "rows", "square_mm"}, tctx);
      c->cols = Integer(Require(t, "cols", tctx), tctx.Sub("cols"));
      c->rows = Integer(Require(t, "rows", tctx), tctx.Sub("rows"));
      c->square = Number(Require(t, "square_mm", tctx), tctx.Sub("square_mm")) * kMm;
    } else if (type == "aprilgrid") {
      RejectUnknownKeys(t, {"type", "tag_cols", "tag_rows", "tag_size_mm", "tag_spacing"}, tctx);
      c->aprilgrid = true;
      c->cols = Integer(Require(t, "tag_cols", tctx), tctx.Sub("tag_cols"));
      c->rows = Integer(Require(t, "tag_rows", tctx), tctx.Sub("tag_rows"));
      c->square = Number(Require(t, "tag_size_mm", tctx), tctx.Sub("tag_size_mm")) * kMm;
      c->tag_spacing = NumberOr(t, "tag_spacing", c->tag_spacing, tctx);
    } else {
      tctx.Sub("type").Fail(t["type"], "expected checkerboard or aprilgrid, got '" + type + "'");
    }
    if (c->cols < 2 || c->rows < 2 || c->cols > 40 || c->rows > 40 || !(c->square > 0))
      tctx.Fail(t, "needs 2..40 columns and rows and a positive size");
    c->present = true;
  }
  if (Has(root, "calibration")) {
    const YAML::Node n = root["calibration"];
    const YamlCtx cctx = ctx.Sub("calibration");
    RejectUnknownKeys(n, {"turntable_images", "free_images", "variation_deg", "free_distance_mm", "free_tilt_deg",
                          "illumination_e", "blur_sigma_px", "vignetting"}, cctx);
    c->turntable_images = IntegerOr(n, "turntable_images", c->turntable_images, cctx);
    c->free_images = IntegerOr(n, "free_images", c->free_images, cctx);
    if (c->turntable_images < 0 || c->turntable_images > 100 || c->free_images < 0 || c->free_images > 100)
      cctx.Fail(n, "image counts must be 0..100");
    c->variation = DegToRad(NumberOr(n, "variation_deg", RadToDeg(c->variation), cctx));
    if (Has(n, "free_distance_mm")) {
      const auto d = Numbers<2>(n["free_distance_mm"], cctx.Sub("free_distance_mm"));
      c->free_distance_min = d[0] * kMm;
      c->free_distance_max = d[1] * kMm;
      if (!(d[0] > 0 && d[1] >= d[0])) cctx.Sub("free_distance_mm").Fail(n["free_distance_mm"], "expected 0 < min <= max");
    }
    c->free_tilt = DegToRad(NumberOr(n, "free_tilt_deg", RadToDeg(c->free_tilt), cctx));
    c->illumination_e = NumberOr(n, "illumination_e", c->illumination_e, cctx);
    c->blur_sigma_px = NumberOr(n, "blur_sigma_px", c->blur_sigma_px, cctx);
    c->vignetting = BooleanOr(n, "vignetting", c->vignetting, cctx);
  }
}

}  // namespace

BodyPose TurntablePose(const Turntable& tt, double main_rad, double aux_rad) {
  const Eigen::Matrix3d C_t_p = R1(aux_rad).transpose() * R3(main_rad).transpose();
  BodyPose pose;
  pose.C_w_b = tt.C_w_t * C_t_p * tt.C_p_b;
  pose.r_w_wb = tt.r_w_wt + tt.C_w_t * (C_t_p * tt.r_p_pb);
  return pose;
}

static Scenario ParseScenario(const std::string& text, const std::string& source, const std::filesystem::path& base_dir) {
  const YAML::Node root = LoadYaml(text, source);
  const YamlCtx ctx{source, ""};
  RejectUnknownKeys(root, {"name", "seed", "rig", "beacons_mm", "beacon_sigma_mm", "frame_rate_hz", "frames", "t0_ns",
                           "turntable", "trajectory", "errors", "sensor", "clutter", "target", "calibration", "module",
                           "beacons", "beacon_facing"}, ctx);
  Scenario s;
  s.name = Has(root, "name") ? String(root["name"], ctx.Sub("name")) : std::filesystem::path(source).stem().string();
  if (Has(root, "seed")) {
    const long long seed = root["seed"].as<long long>(-1);
    if (seed < 0) ctx.Sub("seed").Fail(root["seed"], "expected a non-negative integer");
    s.seed = static_cast<std::uint64_t>(seed);
  }
  s.map_seed = s.seed;
  s.rig = ReadRigField(root, ctx, base_dir);
  if (Has(root, "module")) ReadModule(root["module"], ctx.Sub("module"), &s.module);
  if (Has(root, "beacons")) {
    const YamlCtx bctx = ctx.Sub("beacons");
    if (s.module.shape == ModuleShape::kNone) bctx.Fail(root["beacons"], "generated beacons need a module");
    if (Has(root, "beacons_mm")) bctx.Fail(root["beacons"], "give beacons (generated) or beacons_mm, not both");
    if (Has(root, "beacon_facing"))
      ctx.Sub("beacon_facing").Fail(root["beacon_facing"], "generated beacons take their facing from beacons.half_angle_deg");
    ReadBeaconLayout(root["beacons"], bctx, &s.beacon_layout);
    s.map_seed = s.beacon_layout.seed_given ? s.beacon_layout.seed : s.seed;
    s.map_facing = s.beacon_layout.facing;
    GenerateBeacons(s, &s.rig);
  }
  ReadBeacons(root, ctx, &s.rig);  // beacons_mm, beacon_facing (both refused above with generated ones), beacon_sigma_mm
  s.frame_rate_hz = NumberOr(root, "frame_rate_hz", s.frame_rate_hz, ctx);
  if (!(s.frame_rate_hz > 0 && s.frame_rate_hz <= 1000))
    ctx.Sub("frame_rate_hz").Fail(root["frame_rate_hz"], "must be in (0, 1000]");
  s.frames = IntegerOr(root, "frames", s.frames, ctx);
  if (s.frames < 1 || s.frames > 1'000'000) ctx.Sub("frames").Fail(root["frames"], "must be 1..1000000");
  if (Has(root, "t0_ns")) {
    long long t0 = 0;
    if (!root["t0_ns"].IsScalar() || !YAML::convert<long long>::decode(root["t0_ns"], t0) || t0 < 0)
      ctx.Sub("t0_ns").Fail(root["t0_ns"], "expected a non-negative integer");
    s.t0_ns = t0;
  }
  if (Has(root, "turntable")) ReadTurntable(root["turntable"], ctx.Sub("turntable"), &s.turntable);
  if (Has(root, "trajectory")) {
    ReadTrajectory(root["trajectory"], ctx.Sub("trajectory"), &s.trajectory);
    CheckWanderRoom(s, root["trajectory"], ctx.Sub("trajectory"));
  }
  if (Has(root, "errors")) ReadErrors(root["errors"], ctx.Sub("errors"), &s.errors);
  if (Has(root, "sensor")) ReadSensor(root["sensor"], ctx.Sub("sensor"), &s.sensor);
  if (Has(root, "clutter")) {
    ReadClutter(root["clutter"], ctx.Sub("clutter"), s.rig, &s.clutter);
    GenerateReflectors(root["clutter"], ctx.Sub("clutter"), &s);
  }
  ReadCalibration(root, ctx, &s.calibration);
  return s;
}

Scenario ParseScenarioYaml(const std::string& text, const std::string& source, const std::filesystem::path& base_dir) {
  return CatchYamlErrors(source, [&] { return ParseScenario(text, source, base_dir); });
}

Scenario LoadPreset(const std::string& name) { return ParseScenarioYaml(PresetYaml(name), "preset " + name, "."); }

Scenario LoadScenarioFile(const std::filesystem::path& path) {
  return ParseScenarioYaml(ReadFile(path, 1u << 20), path.string(), path.parent_path());
}

std::vector<FrameTruth> SimulateTrajectory(const Scenario& s) {
  std::mt19937_64 rng(s.seed * 0x9E3779B97F4A7C15ull + 1);
  std::normal_distribution<double> angle_noise(0.0, s.errors.turntable_angle ? s.errors.turntable_angle_sigma : 0.0);
  std::uniform_real_distribution<double> phase(0.0, 2.0 * kPi);
  const Trajectory& tr = s.trajectory;
  // Free flight: per axis two sinusoids with seeded phases, periods P and P / 2.7.
  std::array<double, 6> ph{};
  for (double& p : ph) p = phase(rng);
  std::vector<FrameTruth> out(static_cast<std::size_t>(s.frames));
  // Wander: its own stream of the scenario seed (the other kinds' draws stay as they were).
  const std::vector<BodyPose> wander = tr.kind == TrajectoryKind::kWander
                                           ? WanderPoses(s.module, tr.wander, s.frames, 1.0 / s.frame_rate_hz, s.seed)
                                           : std::vector<BodyPose>{};
  for (int i = 0; i < s.frames; ++i) {
    FrameTruth& f = out[static_cast<std::size_t>(i)];
    f.frame = i;
    const double t = i / s.frame_rate_hz;
    f.t_ns = s.t0_ns + static_cast<std::int64_t>(std::llround(t * 1e9));
    switch (tr.kind) {
      case TrajectoryKind::kStatic:
        f.pose = tr.static_pose;
        break;
      case TrajectoryKind::kTurntable: {
        f.main_cmd = tr.main_start + (tr.turntable_rate_mode ? tr.main_rate * t : tr.main_step * i);
        f.aux_cmd = tr.aux_start + (tr.turntable_rate_mode ? tr.aux_rate * t : tr.aux_step * i);
        f.main_true = f.main_cmd + angle_noise(rng);
        f.aux_true = f.aux_cmd + angle_noise(rng);
        f.pose = TurntablePose(s.turntable, f.main_true, f.aux_true);
        break;
      }
      case TrajectoryKind::kFreeFlight: {
        const double w = 2.0 * kPi / tr.period_s;
        Eigen::Vector3d r;
        for (int a = 0; a < 3; ++a)
          r[a] = tr.centre[a] + tr.amplitude[a] * (0.7 * std::sin(w * t + ph[static_cast<std::size_t>(a)]) +
                                                   0.3 * std::sin(2.7 * w * t + ph[static_cast<std::size_t>(a + 3)]));
        const double roll = tr.tilt * std::sin(1.3 * w * t + ph[0]);
        const double pitch = tr.tilt * std::sin(0.9 * w * t + ph[1]);
        const double yaw = tr.yaw_rate * t + 0.5 * tr.tilt * std::sin(w * t + ph[2]);
        f.pose.r_w_wb = r;
        f.pose.C_w_b = EulerToMatrix({roll, pitch, yaw}).transpose();
        break;
      }
      case TrajectoryKind::kWander:
        f.pose = wander[static_cast<std::size_t>(i)];
        break;
    }
  }
  return out;
}

Rig BelievedRig(const Scenario& s) {
  // An independent stream: changing the trajectory does not change the believed rig.
  std::mt19937_64 rng(s.seed * 0xD1B54A32D192ED03ull + 7);
  std::normal_distribution<double> n01(0.0, 1.0);
  const ErrorSources& e = s.errors;
  Rig rig = s.rig;
  const Rig paper = PaperRig();  // Table 2 sigma when the rig carries none
  for (int k = 0; k < rig.num_cameras; ++k) {
    const auto idx = static_cast<std::size_t>(k);
    RigCamera& cam = rig.cameras[idx];
    if (e.intrinsics) {
      const RigCameraSigma& sg = rig.has_sigma ? s.rig.sigma[idx] : paper.sigma[std::min<std::size_t>(idx, 2)];
      CameraParamVector p = cam.intrinsics.ToVector();
      for (int j = 0; j < 5; ++j) p[j] += e.intrinsics_scale * sg.intrinsics[static_cast<std::size_t>(j)] * n01(rng);
      for (int j = 0; j < 5; ++j) p[5 + j] += e.intrinsics_scale * sg.distortion[static_cast<std::size_t>(j)] * n01(rng);
      cam.intrinsics.SetFromVector(p);
    }
    if (e.extrinsic_rotation) {
      const Eigen::Vector3d w(n01(rng), n01(rng), n01(rng));
      cam.C_k_b = ExpSO3(w * e.extrinsic_rotation_sigma) * cam.C_k_b;
    }
    if (e.extrinsic_translation)
      cam.r_b_bk += Eigen::Vector3d(n01(rng), n01(rng), n01(rng)) * e.extrinsic_translation_sigma;
  }
  if (e.beacon_map) {
    for (int i = 0; i < rig.num_beacons; ++i)
      rig.beacons_w[static_cast<std::size_t>(i)] += Eigen::Vector3d(n01(rng), n01(rng), n01(rng)) * e.beacon_sigma;
    rig.beacon_sigma = e.beacon_sigma;
  } else {
    rig.beacon_sigma = 0.0;  // the believed map is the true one
  }
  rig.has_facing = rig.has_facing && s.map_facing;
  return rig;
}

SurveyedTurntable SurveyTurntable(const Scenario& s) {
  std::mt19937_64 rng(s.seed * 0x94D049BB133111EBull + 13);  // its own stream
  std::normal_distribution<double> n01(0.0, 1.0);
  const ErrorSources& e = s.errors;
  const Turntable& tt = s.turntable;
  SurveyedTurntable out;
  out.centre_sigma = e.beacon_map ? e.beacon_sigma : 0.0;
  out.centre_w = tt.r_w_wt + out.centre_sigma * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
  out.centre_b = -(tt.C_p_b.transpose() * tt.r_p_pb);
  const Eigen::Vector3d axis = tt.C_w_t * R1(s.trajectory.aux_start).transpose() * Eigen::Vector3d::UnitZ();
  out.axis_sigma = e.turntable_axis ? e.turntable_axis_sigma : 0.0;
  // A turn of axis_sigma per direction across the axis (two normal draws in its tangent plane).
  const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
  out.axis_w = (ExpSO3(out.axis_sigma * (n01(rng) * u + n01(rng) * v)) * axis).normalized();
  return out;
}

Rig TruthMapRig(const Scenario& s) {
  Rig rig = s.rig;
  rig.beacon_sigma = 0.0;
  rig.has_facing = rig.has_facing && s.map_facing;
  return rig;
}

}  // namespace mfns::host
