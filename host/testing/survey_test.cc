// AdjustMap against the simulator's truth: maps surveyed with 0.4 mm errors, observed over
// simulated flights and sweeps (true identities: identification is the navigator's, tested
// with it), start poses off by millimetres as a navigator's fixes are.
#include "host/calib/survey/survey.h"

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <algorithm>
#include <random>
#include <sstream>

#include "common/rotation/rotation.h"
#include "host/sim/observe/observe.h"
#include "host/sim/scenario/scenario.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

struct Case {
  Scenario truth;
  Rig surveyed;
  std::vector<SurveyFrameSet> sets;
};

// Appends the frame sets of truth's run (its seed draws the centroid noise and the start poses'
// errors) as pivot group `group`.
void AddFrameSets(const Scenario& truth, int group, std::vector<SurveyFrameSet>* sets) {
  std::mt19937_64 rng(truth.seed * 7919);
  std::normal_distribution<double> n(0.0, 1.0);
  for (const FrameTruth& f : SimulateTrajectory(truth)) {
    const BlobFrameSet b = SimulateBlobs(truth, f);
    SurveyFrameSet s;
    s.t_ns = static_cast<std::uint64_t>(f.t_ns);
    s.pivot_group = group;
    for (std::size_t i = 0; i < b.blobs.size(); ++i)
      if (b.beacon[i] >= 0) s.observations.push_back({b.blobs[i].camera, b.beacon[i], b.blobs[i].uv_px});
    if (s.observations.size() < 3) continue;
    PoseDelta d;
    for (int k = 0; k < 3; ++k) d(k) = 2e-3 * n(rng), d(k + 3) = 2e-3 * n(rng);
    s.pose = Retract(f.pose, d);
    sets->push_back(std::move(s));
  }
}

Case MakeCase(const std::string& preset, std::uint64_t seed, int frames, std::uint64_t map_seed = 0) {
  Case c;
  c.truth = LoadPreset(preset);
  c.truth.seed = seed;
  c.truth.map_seed = map_seed != 0 ? map_seed : seed;
  c.truth.frames = frames;
  c.truth.errors.beacon_map = true;
  c.truth.errors.beacon_sigma = 0.4e-3;
  c.surveyed = BelievedRig(c.truth);
  AddFrameSets(c.truth, -1, &c.sets);
  return c;
}

struct Score {
  double surveyed_rms_m = 0, refined_rms_m = 0;
  int coordinates = 0, within_3_sigma = 0, moved = 0;
};

// Over the beacons seen in at least min_sets frame sets.
Score ScoreMap(const Case& c, const SurveyResult& r, int min_sets) {
  Score s;
  double se = 0, re = 0;
  for (std::size_t b = 0; b < r.beacons.size(); ++b) {
    const SurveyBeacon& sb = r.beacons[b];
    if (sb.frame_sets < min_sets) continue;
    const Eigen::Vector3d& truth = c.truth.rig.beacons_w[b];
    const Eigen::Vector3d e = sb.refined_w - truth;
    se += (sb.surveyed_w - truth).squaredNorm();
    re += e.squaredNorm();
    for (int k = 0; k < 3; ++k) s.within_3_sigma += std::abs(e(k)) <= 3.0 * sb.Sigma()(k) ? 1 : 0;
    s.coordinates += 3;
    s.moved += sb.moved ? 1 : 0;
  }
  s.surveyed_rms_m = std::sqrt(se / std::max(1, s.coordinates));
  s.refined_rms_m = std::sqrt(re / std::max(1, s.coordinates));
  return s;
}

// Free flights through three module maps and draws of each (other maps, trajectories and noise;
// free-flight's map is fixed, its survey errors drawn).
struct Draw {
  const char* preset;
  std::uint64_t seed;
};
const Draw kMapDraws[] = {{"free-flight", 1}, {"free-flight", 2},      {"station-box", 1},
                          {"station-box", 2}, {"station-cylinder", 1}, {"station-cylinder", 3}};

TEST(SurveyTest, RefinedMapsBeatTheSurveyWithHonestSigma) {
  int coordinates = 0, within = 0;
  for (const Draw& d : kMapDraws) {
    const Case c = MakeCase(d.preset, d.seed, 600);
    const SurveyResult r = AdjustMap(c.surveyed, c.sets, SurveyOptions{});
    const Score s = ScoreMap(c, r, 20);
    SCOPED_TRACE(std::string(d.preset) + " seed " + std::to_string(d.seed));
    ASSERT_GT(s.coordinates, 30);
    // 600 frame sets (32 s) give 0.35-0.57; issue 16's 1/3 takes a longer flight
    // (OneTwoMinuteFlightReachesAThirdOfTheSurveysError).
    EXPECT_LE(s.refined_rms_m, 0.6 * s.surveyed_rms_m) << s.refined_rms_m << " vs " << s.surveyed_rms_m;
    EXPECT_NEAR(r.sigma_px, 0.1, 0.02);
    EXPECT_EQ(s.moved, 0);
    coordinates += s.coordinates;
    within += s.within_3_sigma;
    std::printf("%s seed %llu: %d beacons, surveyed %.3f mm, refined %.3f mm, %d/%d within 3 sigma\n", d.preset,
                static_cast<unsigned long long>(d.seed), s.coordinates / 3, 1e3 * s.surveyed_rms_m,
                1e3 * s.refined_rms_m, s.within_3_sigma, s.coordinates);
  }
  EXPECT_GE(within, 0.95 * coordinates) << within << " of " << coordinates;
}

// Several flights through one station (one map, one survey; other paths and noise) see each
// beacon from more directions: the map's error falls further.
TEST(SurveyTest, SeveralFlightsOfOneStation) {
  for (const char* preset : {"free-flight", "station-box", "station-cylinder"}) {
    Case all = MakeCase(preset, 1, 600, 1);
    const SurveyResult one = AdjustMap(all.surveyed, all.sets, SurveyOptions{});
    for (std::uint64_t seed = 2; seed <= 4; ++seed) {
      const Case more = MakeCase(preset, seed, 600, 1);
      ASSERT_EQ(more.truth.rig.beacons_w[0], all.truth.rig.beacons_w[0]);  // the same station
      all.sets.insert(all.sets.end(), more.sets.begin(), more.sets.end());
    }
    const SurveyResult four = AdjustMap(all.surveyed, all.sets, SurveyOptions{});
    const Score s1 = ScoreMap(all, one, 20), s4 = ScoreMap(all, four, 20);
    std::printf("%s: one flight %.3f of the survey's error (%d beacons), four flights %.3f (%d beacons), %d/%d within 3 sigma\n",
                preset, s1.refined_rms_m / s1.surveyed_rms_m, s1.coordinates / 3, s4.refined_rms_m / s4.surveyed_rms_m,
                s4.coordinates / 3, s4.within_3_sigma, s4.coordinates);
    EXPECT_LT(s4.refined_rms_m / s4.surveyed_rms_m, s1.refined_rms_m / s1.surveyed_rms_m);
    // Issue 16: the refined map at most 1/3 of the survey's error (measured 0.25-0.30).
    EXPECT_LE(s4.refined_rms_m, s4.surveyed_rms_m / 3.0);
    EXPECT_GE(s4.within_3_sigma, 0.95 * s4.coordinates);
  }
}

// Issue 16 (a, d) on one flight: 2400 frame sets (2.2 min at 18.6 Hz) of each draw above bring
// the map to at most 1/3 of the survey's error (measured 0.19-0.31; 600 frame sets: 0.35-0.57,
// 1200: 0.25-0.39), the sigma honest. What remains is mostly the survey's own rigid error of
// the whole map (its mean translation and rotation), which no image sees.
TEST(SurveyTest, OneTwoMinuteFlightReachesAThirdOfTheSurveysError) {
#if defined(__SANITIZE_ADDRESS__)
  // 11 s in the host build, 44 s under the sanitizers' Debug build: the same AdjustMap path
  // runs there in the 600-frame-set tests above; this one measures the estimate, not memory.
  GTEST_SKIP() << "the 2400-frame-set flights run in the host build (the same code under ASan above)";
#endif
  for (const Draw& d : kMapDraws) {
    SCOPED_TRACE(std::string(d.preset) + " seed " + std::to_string(d.seed));
    const Case c = MakeCase(d.preset, d.seed, 2400);
    const SurveyResult r = AdjustMap(c.surveyed, c.sets, SurveyOptions{});
    const Score s = ScoreMap(c, r, 20);
    std::printf("%s seed %llu, 2400 frame sets: %d beacons, %.3f of the survey's error, %d/%d within 3 sigma\n",
                d.preset, static_cast<unsigned long long>(d.seed), s.coordinates / 3,
                s.refined_rms_m / s.surveyed_rms_m, s.within_3_sigma, s.coordinates);
    ASSERT_GT(s.coordinates, 30);
    EXPECT_LE(s.refined_rms_m, s.surveyed_rms_m / 3.0);
    EXPECT_GE(s.within_3_sigma, 0.95 * s.coordinates);
    EXPECT_EQ(s.moved, 0);
  }
}

TEST(SurveyTest, ABeaconMovedAfterTheSurveyIsFlagged) {
  Case c = MakeCase("free-flight", 4, 300);
  // The beacon seen most was moved 5 mm after the survey: the images see it at its new place.
  std::vector<int> seen(static_cast<std::size_t>(c.surveyed.num_beacons), 0);
  for (const SurveyFrameSet& f : c.sets)
    for (const SurveyObservation& o : f.observations) ++seen[static_cast<std::size_t>(o.beacon)];
  const auto moved = static_cast<std::size_t>(std::max_element(seen.begin(), seen.end()) - seen.begin());
  c.truth.rig.beacons_w[moved] += Eigen::Vector3d(3e-3, -4e-3, 0.0);
  Case m = MakeCase("free-flight", 4, 0);  // (rebuilt below from the moved truth)
  m.truth = c.truth;
  m.surveyed = c.surveyed;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  for (const FrameTruth& f : SimulateTrajectory(c.truth)) {
    const BlobFrameSet b = SimulateBlobs(c.truth, f);
    SurveyFrameSet s;
    for (std::size_t i = 0; i < b.blobs.size(); ++i)
      if (b.beacon[i] >= 0) s.observations.push_back({b.blobs[i].camera, b.beacon[i], b.blobs[i].uv_px});
    if (s.observations.size() < 3) continue;
    PoseDelta d;
    for (int k = 0; k < 6; ++k) d(k) = 2e-3 * n(rng);
    s.pose = Retract(f.pose, d);
    m.sets.push_back(std::move(s));
  }
  const SurveyResult r = AdjustMap(m.surveyed, m.sets, SurveyOptions{});
  ASSERT_GT(r.beacons[moved].frame_sets, 20);
  EXPECT_TRUE(r.beacons[moved].moved) << r.beacons[moved].shift_sigmas;
  EXPECT_LT((r.beacons[moved].refined_w - m.truth.rig.beacons_w[moved]).norm(), 1e-3);
  int others = 0;
  for (std::size_t b = 0; b < r.beacons.size(); ++b) others += b != moved && r.beacons[b].moved ? 1 : 0;
  EXPECT_EQ(others, 0);
}

// The mounting the survey should find for camera k when camera 0 is held (it defines the body
// frame b'): the true mounting seen from b', where camera 0 sits as believed.
void MountingInHeldFrame(const Rig& truth, const Rig& believed, int k, Eigen::Matrix3d* C_k_b, Eigen::Vector3d* r_b_bk) {
  const auto sk = static_cast<std::size_t>(k);
  const Eigen::Matrix3d C_bp_b = believed.cameras[0].C_k_b.transpose() * truth.cameras[0].C_k_b;  // b -> b'
  *C_k_b = truth.cameras[sk].C_k_b * C_bp_b.transpose();
  *r_b_bk = C_bp_b * (truth.cameras[sk].r_b_bk - truth.cameras[0].r_b_bk) + believed.cameras[0].r_b_bk;
}

// Squared Mahalanobis distance of a camera's refined mounting from the expected one, in the
// survey's perturbation coordinates; and the rotation error (rad) alone.
double MountingNees(const SurveyCamera& c, const Eigen::Matrix3d& C_k_b, const Eigen::Vector3d& r_b_bk, double* rot_rad,
                    double* pos_m) {
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = LogSO3(c.C_k_b * C_k_b.transpose());
  e.tail<3>() = c.r_b_bk - r_b_bk;
  *rot_rad = e.head<3>().norm();
  *pos_m = e.tail<3>().norm();
  return e.dot(c.covariance.ldlt().solve(e));
}

// The believed rig's cameras drawn about the truth as a calibration's sigma says: each Euler
// angle of C_k_b and each coordinate of r_b_bk off by its 1-sigma times a normal draw; the
// sigma set in the rig.
void DrawMountings(const Rig& truth, double sigma_rad, double sigma_m, std::uint64_t seed, Rig* believed) {
  std::mt19937_64 rng(seed * 104729 + 5);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < believed->num_cameras; ++k) {
    const auto sk = static_cast<std::size_t>(k);
    EulerAngles e = MatrixToEuler(truth.cameras[sk].C_k_b);
    e.phi += sigma_rad * n(rng);
    e.theta += sigma_rad * n(rng);
    e.psi += sigma_rad * n(rng);
    believed->cameras[sk].C_k_b = EulerToMatrix(e);
    believed->cameras[sk].r_b_bk = truth.cameras[sk].r_b_bk + sigma_m * Eigen::Vector3d(n(rng), n(rng), n(rng));
    believed->sigma[sk].euler = Eigen::Vector3d::Constant(sigma_rad);
    believed->sigma[sk].r_b_bk = Eigen::Vector3d::Constant(sigma_m);
  }
}

// --refine-cameras: believed mountings off by 0.03 deg per Euler angle and 0.3 mm per axis (a
// few of a good calibration's sigma), maps off by 0.4 mm. Without the rig's calibration sigma
// camera 0 is held and the others are found in its frame; with it each camera's calibration is
// its prior. Either way the cameras come out near the truth with honest covariances, and the
// map is better than with the cameras held at their errors.
TEST(SurveyTest, RefineCamerasFindsTheMountings) {
  const double rot = DegToRad(0.03), pos = 0.3e-3;
  const Draw draws[] = {{"free-flight", 1}, {"station-box", 2}, {"station-cylinder", 3}};
  double nees_sum = 0.0;
  int nees_n = 0;
  for (const Draw& d : draws) {
    Case c = MakeCase(d.preset, d.seed, 600);
    DrawMountings(c.truth.rig, rot, pos, d.seed, &c.surveyed);
    SCOPED_TRACE(std::string(d.preset) + " seed " + std::to_string(d.seed));
    for (const bool with_sigma : {false, true}) {
      Rig rig = c.surveyed;
      rig.has_sigma = with_sigma;
      SurveyOptions o;
      const SurveyResult held = AdjustMap(rig, c.sets, o);
      o.refine_cameras = true;
      const SurveyResult r = AdjustMap(rig, c.sets, o);
      ASSERT_EQ(r.cameras.size(), static_cast<std::size_t>(rig.num_cameras));
      const Score s_held = ScoreMap(c, held, 20), s = ScoreMap(c, r, 20);
      EXPECT_LT(s.refined_rms_m, s_held.refined_rms_m);
      EXPECT_LE(s.refined_rms_m, 0.6 * s.surveyed_rms_m);
      EXPECT_GE(s.within_3_sigma, 0.95 * s.coordinates);
      EXPECT_NEAR(r.sigma_px, 0.1, 0.02);
      for (int k = 0; k < rig.num_cameras; ++k) {
        const SurveyCamera& cam = r.cameras[static_cast<std::size_t>(k)];
        Eigen::Matrix3d C;
        Eigen::Vector3d p;
        if (with_sigma) {
          C = c.truth.rig.cameras[static_cast<std::size_t>(k)].C_k_b;
          p = c.truth.rig.cameras[static_cast<std::size_t>(k)].r_b_bk;
        } else {
          MountingInHeldFrame(c.truth.rig, rig, k, &C, &p);
        }
        const double before_rot = LogSO3(rig.cameras[static_cast<std::size_t>(k)].C_k_b * C.transpose()).norm();
        const double before_pos = (rig.cameras[static_cast<std::size_t>(k)].r_b_bk - p).norm();
        if (!with_sigma && k == 0) {
          EXPECT_FALSE(cam.refined);
          EXPECT_LT(before_rot, 1e-12);
          continue;
        }
        ASSERT_TRUE(cam.refined);
        double rot_err = 0, pos_err = 0;
        const double nees = MountingNees(cam, C, p, &rot_err, &pos_err);
        nees_sum += nees;
        ++nees_n;
        std::printf("%s seed %llu %s camera %d: rotation %.4f -> %.4f deg, position %.3f -> %.3f mm, NEES %.1f\n",
                    d.preset, static_cast<unsigned long long>(d.seed), with_sigma ? "prior" : "held 0", k,
                    RadToDeg(before_rot), RadToDeg(rot_err), 1e3 * before_pos, 1e3 * pos_err, nees);
        EXPECT_LT(nees, 30.0);  // 6 dof: p ~ 3e-5
        // The cameras' rotations relative to one another come out far better than given; with
        // priors alone fixing the body frame, their common rotation stays about as uncertain
        // as the priors (the NEES above holds it to its covariance).
        if (k == 0) continue;
        const auto sk = static_cast<std::size_t>(k);
        const auto relative = [&](const Eigen::Matrix3d& Ck, const Eigen::Matrix3d& C0) {
          const Eigen::Matrix3d& Tk = c.truth.rig.cameras[sk].C_k_b;
          const Eigen::Matrix3d& T0 = c.truth.rig.cameras[0].C_k_b;
          return LogSO3((Ck * C0.transpose()) * (Tk * T0.transpose()).transpose()).norm();
        };
        const double rel_before = relative(rig.cameras[sk].C_k_b, rig.cameras[0].C_k_b);
        const double rel_after = relative(cam.C_k_b, r.cameras[0].C_k_b);
        EXPECT_LT(rel_after, 0.25 * rel_before) << RadToDeg(rel_after) << " deg vs " << RadToDeg(rel_before);
      }
    }
  }
  // Honest covariances: the mean NEES of 6-dof errors is about 6 (15 cameras here).
  EXPECT_LT(nees_sum / nees_n, 10.0) << nees_n;
  EXPECT_GT(nees_sum / nees_n, 3.0) << nees_n;
}

// A turntable run (the demo's sweep: paper-turntable, one axis) sees every beacon from one
// place: with each pose free its beacons' depths rest on the lever arms alone. Its frame sets
// as one pivot group (the body turns about the turntable's centre) leave each pose its attitude
// only: on six map draws the map's error falls to 0.37-0.50 of the survey's (each pose free:
// 0.45-0.66), the sigma as honest. The fixed point is found where the sweep defines it (across
// its axis; along it, any point of the axis is one).
TEST(SurveyTest, TurntableRunsTurnAboutOneFixedPoint) {
  int coordinates = 0, within = 0;
  double pivot_sq = 0.0, free_sq = 0.0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    SCOPED_TRACE("paper-turntable seed " + std::to_string(seed));
    Case c = MakeCase("paper-turntable", seed, 300);
    const SurveyResult free_poses = AdjustMap(c.surveyed, c.sets, SurveyOptions{});
    for (SurveyFrameSet& f : c.sets) f.pivot_group = 0;
    const SurveyResult r = AdjustMap(c.surveyed, c.sets, SurveyOptions{});
    const Score s_free = ScoreMap(c, free_poses, 20), s = ScoreMap(c, r, 20);
    std::printf("paper-turntable seed %llu: surveyed %.3f mm, refined %.3f mm (%.2f), each pose free %.3f mm (%.2f)\n",
                static_cast<unsigned long long>(seed), 1e3 * s.surveyed_rms_m, 1e3 * s.refined_rms_m,
                s.refined_rms_m / s.surveyed_rms_m, 1e3 * s_free.refined_rms_m, s_free.refined_rms_m / s.surveyed_rms_m);
    ASSERT_EQ(s.coordinates, 30);
    EXPECT_LT(s.refined_rms_m, s_free.refined_rms_m);
    EXPECT_LE(s.refined_rms_m, 0.55 * s.surveyed_rms_m);
    pivot_sq += s.refined_rms_m * s.refined_rms_m;
    free_sq += s_free.refined_rms_m * s_free.refined_rms_m;
    EXPECT_NEAR(r.sigma_px, 0.1, 0.02);
    ASSERT_EQ(r.pivots.size(), 1u);
    EXPECT_EQ(r.pivots[0].frame_sets, static_cast<int>(c.sets.size()));
    const Eigen::Vector3d axis_w = c.truth.turntable.C_w_t.transpose().col(2);  // the main axis Zt in w
    const Eigen::Vector3d off = r.pivots[0].p_w - c.truth.turntable.r_w_wt;
    EXPECT_LT((off - off.dot(axis_w) * axis_w).norm(), 1e-3) << off.transpose();
    coordinates += s.coordinates;
    within += s.within_3_sigma;
  }
  EXPECT_GE(within, 0.95 * coordinates);
  EXPECT_LT(std::sqrt(pivot_sq), 0.85 * std::sqrt(free_sq));  // measured 0.81
}

// The turntable's placement as a user surveys it (the simulator's draw, SurveyTurntable, never
// the truth): its centre with the map's instrument, or with `centre_sigma` > 0 that draw scaled
// to this 1-sigma (a better instrument); its centre in the body, the mount's (0.05 mm: the
// caliper's, the mount defines the body frame); its axis levelled to 5 arcsec when `axis`.
TurntablePlacement SurveyedPlacement(const Scenario& truth, double centre_sigma, bool axis) {
  const SurveyedTurntable st = SurveyTurntable(truth);
  TurntablePlacement t;
  t.has_centre = t.has_centre_b = true;
  const double scale = centre_sigma > 0.0 ? centre_sigma / st.centre_sigma : 1.0;
  t.centre_w = truth.turntable.r_w_wt + scale * (st.centre_w - truth.turntable.r_w_wt);
  t.centre_sigma_m = scale * st.centre_sigma;
  t.centre_b = st.centre_b;
  t.centre_b_sigma_m = st.centre_b_sigma;
  t.has_axis = axis;
  t.axis_w = st.axis_w;
  t.axis_sigma_rad = st.axis_sigma;
  return t;
}

// Issue 16 on the demo's sweep with the turntable's surveyed placement (TurntablePlacement) as
// the extra information a turntable experiment has: the same six draws as above, one pivot
// group. Images place the map relative to the sweep's fixed point and axis, so the placement
// pins the map's rigid error only as well as it is itself known: a centre surveyed with the
// beacons' 0.4 mm is one more point beside the ten beacons (it changes the map's placement by
// 1/11 of its information: 0.39-0.52 of the survey's error, 0.37-0.50 without), an axis
// levelled to 5 arcsec fixes the map's two tilts (its own survey holds them to ~40 arcsec):
// 0.36-0.51. Even a perfectly known centre and axis leave the map's turn about the axis and
// its shape (0.17-0.33 of the survey's error after one sweep): 0.22-0.35, not 1/3 on every
// draw. Every posterior honest: >= 95 % of the coordinates within 3 sigma, the fixed point
// within 3 of its sigma of the turntable's true centre, its sigma within the prior's.
TEST(SurveyTest, TheTurntablesSurveyedPlacementPlacesTheMapAsWellAsItIsKnown) {
  struct Variant {
    const char* name;
    double centre_sigma;  // 0: the map's
    bool axis;
    double bound;  // of the refined map's error over the survey's, every draw
  };
  const Variant variants[] = {{"centre", 0.0, false, 0.55}, {"centre + axis", 0.0, true, 0.55},
                              {"centre (1 um) + axis", 1e-6, true, 0.37}};
  int coordinates[3] = {}, within[3] = {}, third[3] = {};
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    Case c = MakeCase("paper-turntable", seed, 300);
    for (SurveyFrameSet& f : c.sets) f.pivot_group = 0;
    for (std::size_t i = 0; i < 3; ++i) {
      const Variant& v = variants[i];
      SCOPED_TRACE(std::string(v.name) + ", paper-turntable seed " + std::to_string(seed));
      SurveyOptions o;
      o.turntables = {SurveyedPlacement(c.truth, v.centre_sigma, v.axis)};
      const SurveyResult r = AdjustMap(c.surveyed, c.sets, o);
      const Score s = ScoreMap(c, r, 20);
      const double ratio = s.refined_rms_m / s.surveyed_rms_m;
      const SurveyPivot& p = r.pivots[0];
      const Eigen::Vector3d off = p.p_w - c.truth.turntable.r_w_wt;
      const Eigen::Vector3d sigma = p.covariance.bottomRightCorner<3, 3>().diagonal().cwiseSqrt();
      std::printf("%s, seed %llu: %.3f of the survey's error, %d/%d within 3 sigma, centre off (%.3f, %.3f, %.3f) mm, "
                  "1-sigma %.3f mm\n", v.name, static_cast<unsigned long long>(seed), ratio, s.within_3_sigma,
                  s.coordinates, 1e3 * off.x(), 1e3 * off.y(), 1e3 * off.z(), 1e3 * sigma.maxCoeff());
      ASSERT_EQ(s.coordinates, 30);
      EXPECT_LE(ratio, v.bound);
      third[i] += ratio <= 1.0 / 3.0 ? 1 : 0;
      for (int k = 0; k < 3; ++k) EXPECT_LE(std::abs(off(k)), 3.0 * sigma(k)) << k;
      EXPECT_LE(sigma.maxCoeff(), o.turntables[0].centre_sigma_m * 1.0001);
      EXPECT_EQ(p.has_axis, v.axis);
      if (v.axis) {  // the refined axis within 3 sigma (across it: two directions) of the true one
        EXPECT_LT(std::acos(std::min(1.0, p.axis_w.z())), 3.0 * 1.5 * o.turntables[0].axis_sigma_rad);
      }
      EXPECT_NEAR(r.sigma_px, 0.1, 0.02);
      coordinates[i] += s.coordinates;
      within[i] += s.within_3_sigma;
    }
  }
  for (std::size_t i = 0; i < 3; ++i) {
    std::printf("%s: 1/3 of the survey's error on %d of 6 draws, %d/%d within 3 sigma\n", variants[i].name, third[i],
                within[i], coordinates[i]);
    EXPECT_GE(within[i], 0.95 * coordinates[i]) << variants[i].name;
  }
}

// The part of map errors e (at the true positions t) that one rigid motion of the whole map
// explains (linearised, a + w x t_i; least squares): images see a map's shape, not where the
// whole map sits or how it is turned in the world, which the survey alone says.
std::vector<Eigen::Vector3d> RigidPart(const std::vector<Eigen::Vector3d>& t, const std::vector<Eigen::Vector3d>& e) {
  const auto n = static_cast<Eigen::Index>(t.size());
  Eigen::MatrixXd A(3 * n, 6);
  Eigen::VectorXd b(3 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& ti = t[static_cast<std::size_t>(i)];
    A.block<3, 3>(3 * i, 0).setIdentity();
    A.block<3, 3>(3 * i, 3) = -Skew(ti);
    b.segment<3>(3 * i) = e[static_cast<std::size_t>(i)];
  }
  const Eigen::VectorXd fit = A * A.colPivHouseholderQr().solve(b);
  std::vector<Eigen::Vector3d> out;
  for (Eigen::Index i = 0; i < n; ++i) out.emplace_back(fit.segment<3>(3 * i));
  return out;
}

// RMS per coordinate of a - b (b empty: of a).
double Rms(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b = {}) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += (b.empty() ? a[i] : a[i] - b[i]).squaredNorm();
  return std::sqrt(sum / (3.0 * static_cast<double>(std::max<std::size_t>(1, a.size()))));
}

// A map's errors over its seen beacons: the whole and its rigid part (the rest is its shape's).
struct MapErrors {
  std::vector<Eigen::Vector3d> whole, rigid;
  double ShapeRms() const { return Rms(whole, rigid); }
};

MapErrors SeenMapErrors(const Case& c, const SurveyResult& r, bool refined) {
  std::vector<Eigen::Vector3d> t;
  MapErrors m;
  for (std::size_t b = 0; b < r.beacons.size(); ++b) {
    if (r.beacons[b].frame_sets == 0) continue;
    t.push_back(c.truth.rig.beacons_w[b]);
    m.whole.push_back((refined ? r.beacons[b].refined_w : r.beacons[b].surveyed_w) - t.back());
  }
  m.rigid = RigidPart(t, m.whole);
  return m;
}

// Issue 16 (a) on the demo's station (paper Table 4: ten beacons, 0.6-0.9 m from the
// turntable; the cameras 0.12 m from its centre). A sweep sees each beacon along about one ray,
// but the cameras' lever arm gives depth too: one sweep leaves 0.17-0.32 of the survey's error
// in the map's shape. A second placement (0.4 m along y, its own pivot group) sees each beacon
// from elsewhere: the shape's error falls on every draw (to 0.07-0.19), while the map's rigid
// error stays the survey's (within 0.01 of its RMS): ten beacons' survey errors hold 6 of their
// 30 degrees of freedom in it (expected sqrt(6/30) = 0.45 of the survey's RMS; 0.31-0.45 on
// these draws), so 1/3 over all coordinates in the world frame is out of reach of images of
// this station, however many placements (measured 0.34-0.47 with two).
TEST(SurveyTest, ASecondTurntablePlacementFixesTheShapeNotThePlacement) {
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    SCOPED_TRACE("paper-turntable seed " + std::to_string(seed));
    Case c = MakeCase("paper-turntable", seed, 300);
    for (SurveyFrameSet& f : c.sets) f.pivot_group = 0;
    const SurveyResult one = AdjustMap(c.surveyed, c.sets, SurveyOptions{});
    Scenario moved = c.truth;  // the same station and survey, the turntable moved; other noise
    moved.seed = seed + 100;
    moved.turntable.r_w_wt += Eigen::Vector3d(0.0, 0.4, 0.0);
    AddFrameSets(moved, 1, &c.sets);
    const SurveyResult two = AdjustMap(c.surveyed, c.sets, SurveyOptions{});
    const MapErrors survey = SeenMapErrors(c, two, false), e1 = SeenMapErrors(c, one, true),
                    e2 = SeenMapErrors(c, two, true);
    const double s = Rms(survey.whole);
    std::printf(
        "paper-turntable seed %llu: shape %.2f -> %.2f of the survey's error, whole %.2f -> %.2f, the survey's "
        "rigid part %.2f, the refined map's off it by %.2f\n",
        static_cast<unsigned long long>(seed), e1.ShapeRms() / s, e2.ShapeRms() / s, Rms(e1.whole) / s,
        Rms(e2.whole) / s, Rms(survey.rigid) / s, Rms(e2.rigid, survey.rigid) / s);
    ASSERT_EQ(e2.whole.size(), 10u);
    EXPECT_LT(e2.ShapeRms(), e1.ShapeRms());
    EXPECT_LE(e2.ShapeRms(), s / 3.0);
    EXPECT_LT(Rms(e2.rigid, survey.rigid), 0.05 * s);  // images do not move the whole map
    const Score sc = ScoreMap(c, two, 20);
    EXPECT_GE(sc.within_3_sigma, 0.95 * sc.coordinates);
    // Both placements' centres surveyed to 0.02 mm (a laser tracker's), their axes levelled to 5
    // arcsec: two known points 0.4 m apart and the vertical fix the map's rigid error too. Issue
    // 16's 1/3 on every draw (measured 0.12-0.24; 0.15-0.32 at 0.05 mm, 0.19-0.45 at 0.4 mm).
    SurveyOptions placed;
    placed.turntables = {SurveyedPlacement(c.truth, 0.02e-3, true), SurveyedPlacement(moved, 0.02e-3, true)};
    const Score sp = ScoreMap(c, AdjustMap(c.surveyed, c.sets, placed), 20);
    std::printf("paper-turntable seed %llu, two placements surveyed to 0.02 mm and 5 arcsec: %.3f, %d/%d within 3 sigma\n",
                static_cast<unsigned long long>(seed), sp.refined_rms_m / sp.surveyed_rms_m, sp.within_3_sigma,
                sp.coordinates);
    EXPECT_LE(sp.refined_rms_m, sp.surveyed_rms_m / 3.0);
    EXPECT_GE(sp.within_3_sigma, 0.95 * sp.coordinates);
  }
}

// Every cost's analytic Jacobians (image: pose, beacon, pivot and camera blocks; the turntable
// axis term; the priors, the cameras' calibration prior included) against central differences
// before each solve (SurveyOptions::check_gradients): on a short flight with every block in use
// (half the frame sets in a pivot group, the cameras refined under their calibration prior), and
// on the demo's sweep (40 frame sets, one pivot group, the turntable's centre, mount and axis
// surveyed), where Ceres's own checker had flagged the image Jacobians' world y and z columns by
// 0.6 % (its Ridders differences start from 0.32 m steps, at beacons 0.45 m from the cameras).
TEST(SurveyTest, JacobiansMatchNumericDifferences) {
  SurveyOptions o;
  o.check_gradients = true;
  o.refine_cameras = true;
  o.reweight_passes = 1;
  o.relinearise_passes = 2;
  Case c = MakeCase("free-flight", 1, 30);
  DrawMountings(c.truth.rig, DegToRad(0.03), 0.3e-3, 1, &c.surveyed);
  for (std::size_t i = 0; i < c.sets.size(); ++i) c.sets[i].pivot_group = i % 2 == 0 ? 0 : -1;
  ASSERT_TRUE(c.surveyed.has_sigma);
  EXPECT_NO_THROW(AdjustMap(c.surveyed, c.sets, o));
  // The turntable axis term's (pose, a_b, a_w) on the same pivot group with a surveyed centre
  // and axis (a flight does not turn about one axis: a loose wobble).
  o.refine_cameras = false;
  TurntablePlacement t;
  t.has_centre = t.has_axis = true;
  t.centre_sigma_m = 0.01;
  t.axis_sigma_rad = 0.1;
  o.turntables = {t};
  o.turntable_wobble_rad = 0.5;
  c.sets.resize(12);
  EXPECT_NO_THROW(AdjustMap(c.surveyed, c.sets, o));
  // The sweep.
  Case sweep = MakeCase("paper-turntable", 1, 40);
  for (SurveyFrameSet& f : sweep.sets) f.pivot_group = 0;
  SurveyOptions ts;
  ts.check_gradients = true;
  ts.reweight_passes = 1;
  ts.turntables = {SurveyedPlacement(sweep.truth, 0.0, true)};
  EXPECT_NO_THROW(AdjustMap(sweep.surveyed, sweep.sets, ts));
}

TEST(SurveyTest, TooFewObservationsKeepTheGivenSigma) {
  // Three beacons per frame set fit each pose exactly: no redundancy to estimate the noise from.
  Case c = MakeCase("free-flight", 1, 40);
  for (SurveyFrameSet& f : c.sets) f.observations.resize(3);
  c.sets.resize(4);
  SurveyOptions o;
  o.start_sigma_px = 0.2;
  const SurveyResult r = AdjustMap(c.surveyed, c.sets, o);
  EXPECT_FALSE(r.sigma_estimated);
  EXPECT_EQ(r.sigma_px, 0.2);
  const Case full = MakeCase("free-flight", 1, 40);
  EXPECT_TRUE(AdjustMap(full.surveyed, full.sets, o).sigma_estimated);
}

TEST(SurveyTest, BadInputIsRefusedNamingIt) {
  Case c = MakeCase("free-flight", 1, 20);
  Rig no_sigma = c.surveyed;
  no_sigma.beacon_sigma = 0.0;
  EXPECT_THROW(AdjustMap(no_sigma, c.sets, SurveyOptions{}), UserError);
  std::vector<SurveyFrameSet> bad = c.sets;
  bad[0].observations[0].beacon = c.surveyed.num_beacons;
  try {
    AdjustMap(c.surveyed, bad, SurveyOptions{});
    FAIL();
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("frame set 0"), std::string::npos) << e.what();
  }
  SurveyOptions o;
  o.huber_sigmas = -1;
  EXPECT_THROW(AdjustMap(c.surveyed, c.sets, o), UserError);
  std::vector<SurveyFrameSet> bad_group = c.sets;
  bad_group[1].pivot_group = -2;
  try {
    AdjustMap(c.surveyed, bad_group, SurveyOptions{});
    FAIL();
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("frame set 1: pivot group -2"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mfns::host
