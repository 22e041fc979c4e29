#include "host/sim/navmatrix/matrix.h"

#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <thread>
#include <tuple>

#include "common/limits.h"
#include "common/rotation/rotation.h"

namespace mfns::host {
namespace {

YAML::Node PresetNode(const std::string& preset) {
  std::string text;
  try {
    text = PresetYaml(preset);
  } catch (const UserError& e) {
    throw UserError(std::string("--presets: ") + e.what());
  }
  return YAML::Load(text);
}

// A generated map (beacons: {layout: ...}) takes beacons.count, .seed and .facing.
bool HasGeneratedMap(const YAML::Node& root) {
  const YAML::Node& r = root;  // const lookups insert nothing
  return r["beacons"].IsDefined() && r["beacons"].IsMap();
}

Scenario ParseOverridden(const YAML::Node& root, const std::string& preset) {
  YAML::Emitter out;
  out << root;
  return ParseScenarioYaml(out.c_str(), "preset " + preset + " with navmatrix overrides", ".");
}

std::string Trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  const auto e = s.find_last_not_of(" \t");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

// A seed, preset or count given twice would run (and count) the same runs twice.
template <typename T>
void RefuseRepeats(std::vector<T> values, const char* option) {
  std::sort(values.begin(), values.end());
  const auto twice = std::adjacent_find(values.begin(), values.end());
  if (twice == values.end()) return;
  std::ostringstream value;
  value << *twice;
  throw UserError(std::string(option) + ": '" + OneLine(value.str()) + "' given twice");
}

std::uint64_t ParseSeed(const std::string& text, const std::string& whole) {
  const std::string t = Trim(text);
  if (t.empty() || t.find_first_not_of("0123456789") != std::string::npos || t.size() > 18)
    throw UserError("--seeds: expected seeds like 1-5 or 1,3,8, got '" + OneLine(whole) + "'");
  return std::stoull(t);
}

}  // namespace

Scenario MatrixScenario(const RunSpec& r) {
  YAML::Node root = PresetNode(r.preset);
  root["frames"] = r.frames;
  root["seed"] = r.seed;
  if (HasGeneratedMap(root)) {
    root["beacons"]["seed"] = r.seed;  // a new seed, a new station (mfns-sim --seed)
    if (r.count > 0) root["beacons"]["count"] = r.count;
    root["beacons"]["facing"] = r.facing;
    if (!r.layout.empty()) root["beacons"]["layout"] = r.layout;
    if (r.jitter >= 0.0) root["beacons"]["jitter"] = r.jitter;
  }
  root["clutter"]["spurious"]["count"] = r.spurious;
  if (r.static_reflections > 0) root["clutter"]["spurious"]["static_reflections"] = r.static_reflections;
  if (!r.rig.empty()) root["rig"] = r.rig;
  return ParseOverridden(root, r.preset);
}

std::vector<std::uint64_t> ParseSeeds(const std::string& text) {
  std::vector<std::uint64_t> seeds;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    const std::size_t dash = item.find('-');
    if (dash == std::string::npos) {
      seeds.push_back(ParseSeed(item, text));
    } else {
      const std::uint64_t a = ParseSeed(item.substr(0, dash), text), b = ParseSeed(item.substr(dash + 1), text);
      if (b < a || b - a >= kMaxSeeds)
        throw UserError("--seeds: range '" + OneLine(Trim(item)) + "' must go up, " + std::to_string(kMaxSeeds) +
                        " seeds at most");
      for (std::uint64_t s = a; s <= b; ++s) seeds.push_back(s);
    }
    // In total too, not only per range: "1-9999,10000-19999,..." grew without bound.
    if (seeds.size() > kMaxSeeds)
      throw UserError("--seeds: more than " + std::to_string(kMaxSeeds) + " seeds in '" + OneLine(text) + "'");
    start = comma + 1;
  }
  return seeds;
}

std::vector<RunSpec> ExpandMatrix(const MatrixSpec& m) {
  if (m.presets.empty()) throw UserError("--presets: give at least one preset");
  if (m.seeds.empty()) throw UserError("--seeds: give at least one seed");
  if (m.frames < 1 || m.frames > 1000000) throw UserError("--frames: must be 1..1000000");
  if (m.spurious < 0 || m.spurious > 100) throw UserError("--spurious: must be 0..100");
  if (m.static_reflections < 0 || m.static_reflections > limits::kMaxBeacons)
    throw UserError("--static-reflections: must be 0.." + std::to_string(limits::kMaxBeacons));
  for (const int c : m.counts)
    if (c < 10 || c > limits::kMaxBeacons)
      throw UserError("--counts: " + std::to_string(c) + " is outside 10.." + std::to_string(limits::kMaxBeacons));
  if (!m.layout.empty() && m.layout != "jittered-grid" && m.layout != "random")
    throw UserError("--layout: expected jittered-grid or random, got '" + OneLine(m.layout) + "'");
  if (m.jitter > 0.5 || std::isnan(m.jitter)) throw UserError("--jitter: must be 0..0.5 (a fraction of the cell)");
  RefuseRepeats(m.presets, "--presets");
  RefuseRepeats(m.counts, "--counts");
  RefuseRepeats(m.seeds, "--seeds");
  std::vector<RunSpec> runs;
  for (const std::string& preset : m.presets) {
    const YAML::Node root = PresetNode(preset);
    const bool generated = HasGeneratedMap(root);
    const Scenario s = MatrixScenario({.preset = preset, .seed = m.seeds.front(), .frames = 1, .rig = m.rig});
    if (s.rig.num_beacons < 4) throw UserError("--presets: '" + preset + "' has no beacon map to navigate by");
    if (generated && m.counts.empty()) throw UserError("--counts: '" + preset + "' needs at least one beacon count");
    const std::vector<int> counts = generated ? m.counts : std::vector<int>{0};
    std::vector<bool> facings{true, false};
    if (!s.rig.has_facing || m.facing == FacingMode::kYes) facings = {true};
    if (s.rig.has_facing && m.facing == FacingMode::kNo) facings = {false};
    const std::size_t preset_runs = counts.size() * facings.size() * m.seeds.size();
    if (runs.size() + preset_runs > kMaxRuns)
      throw UserError("--presets x --counts x --seeds: more than " + std::to_string(kMaxRuns) + " runs");
    runs.reserve(runs.size() + preset_runs);
    for (const int count : counts)
      for (const bool facing : facings)
        for (const std::uint64_t seed : m.seeds)
          runs.push_back({.preset = preset,
                          .count = count,
                          .seed = seed,
                          .facing = facing,
                          .map_has_facing = s.rig.has_facing,
                          .map_beacons = count > 0 ? count : s.rig.num_beacons,
                          .frames = m.frames,
                          .spurious = m.spurious,
                          .static_reflections = s.module.shape != ModuleShape::kNone ? m.static_reflections : 0,
                          .rig = m.rig,
                          .layout = generated ? m.layout : std::string(),
                          .jitter = generated ? m.jitter : -1.0});
  }
  return runs;
}

namespace {

std::string Describe(const RunSpec& r) {
  std::string d = r.preset;
  if (r.count > 0) d += " " + std::to_string(r.count);
  if (r.map_has_facing) d += r.facing ? " facing" : " no-facing";
  return d + " seed " + std::to_string(r.seed);
}

// One progress line, rewritten in place on a terminal, one line per run otherwise.
class Progress {
 public:
  Progress(std::ostream* out, int total) : out_(out), total_(total), tty_(isatty(STDERR_FILENO) != 0) {}
  void Done(const RunSpec& spec, const RunResult& r) {
    if (out_ == nullptr) return;
    const std::lock_guard<std::mutex> lock(mutex_);
    ++done_;
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    char line[256];
    std::snprintf(line, sizeof line, "navmatrix: %d/%d runs, %.0f s; last: %s, first fix %d, wrong fixes %d", done_,
                  total_, s, Describe(spec).c_str(), r.first_fix, r.wrong_fixes);
    *out_ << (tty_ ? "\r\033[K" : "") << line << (tty_ && done_ < total_ ? "" : "\n") << std::flush;
  }

 private:
  std::ostream* out_;
  int total_, done_ = 0;
  bool tty_;
  std::mutex mutex_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace

std::vector<RunResult> RunMatrix(const std::vector<RunSpec>& runs, const NavMatrixOptions& o, int jobs,
                                 std::ostream* progress, std::vector<std::vector<FrameRecord>>* traces) {
  std::vector<RunResult> results(runs.size());
  if (traces != nullptr) traces->assign(runs.size(), {});
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  Progress bar(progress, static_cast<int>(runs.size()));
  const auto work = [&] {
    for (std::size_t i = next++; i < runs.size(); i = next++) {
      try {
        results[i] = RunNavigation(MatrixScenario(runs[i]), o, traces != nullptr ? &(*traces)[i] : nullptr);
        bar.Done(runs[i], results[i]);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        next = runs.size();  // stop the others at their next run
      }
    }
  };
  const int n = std::max(1, std::min(jobs, static_cast<int>(runs.size())));
  std::vector<std::thread> threads;
  for (int t = 1; t < n; ++t) threads.emplace_back(work);
  work();
  for (std::thread& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  return results;
}

std::string FormatTraceCsv(const std::vector<RunSpec>& runs, const std::vector<std::vector<FrameRecord>>& traces) {
  std::string out =
      "preset,count,facing,seed,frame,in_view,blobs,status,reason,source,beacons,position_error_mm,"
      "attitude_error_deg,position_sigma_mm,rms_px,wrong_ids,step_ms,in_view_per_camera,lis,acquisition_poses\n";
  char line[512];
  for (std::size_t i = 0; i < runs.size() && i < traces.size(); ++i) {
    const RunSpec& r = runs[i];
    for (std::size_t k = 0; k < traces[i].size(); ++k) {
      const FrameRecord& f = traces[i][k];
      std::string per_camera;
      for (std::size_t c = 0; c < f.in_view_per_camera.size(); ++c)
        per_camera += (c == 0 ? "" : "+") + std::to_string(f.in_view_per_camera[c]);
      std::snprintf(line, sizeof line, "%s,%d,%s,%llu,%zu,%d,%d,%s,%s,%s,%d,%.3f,%.4f,%.3f,%.3f,%d,%.3f,%s,%s,%d\n",
                    r.preset.c_str(),
                    r.map_beacons, r.map_has_facing ? (r.facing ? "yes" : "no") : "none",
                    static_cast<unsigned long long>(r.seed), k, f.in_view, f.num_blobs, fw::ToString(f.status),
                    fw::ToString(f.reason), fw::ToString(f.source), f.num_beacons, f.position_error_m * 1e3,
                    RadToDeg(f.attitude_error_rad), f.position_sigma_m * 1e3, f.rms_px, f.wrong_ids, f.step_s * 1e3,
                    per_camera.c_str(), f.lis_run ? fw::ToString(f.lis_status) : "-", f.acquisition_poses);
      out += line;
    }
  }
  return out;
}

namespace {

void AddRun(const RunResult& r, const MatrixLimits& limits, MatrixRow* row) {
  ++row->runs;
  if (r.HasLag()) row->lags.push_back(r.Lag());
  row->lag_exceeded += r.LagExceeds(limits.max_lag);
  if (r.HasHeldLag()) row->held_lags.push_back(r.HeldLag());
  row->held_lag_exceeded += r.HeldLagExceeds(limits.max_lag);
  row->never_fixed += r.NeverFixed();
  row->no_view4 += r.first_in_view < 0;
  if (r.first_fix >= 0) {
    ++row->fixed_runs;
    row->min_posed_share = std::min(row->min_posed_share, r.PosedShare());
  }
  row->eligible += r.eligible_after_fix;
  row->posed += r.posed_after_fix;
  row->fixes += r.fixes;
  row->degraded += r.degraded;
  row->wrong_fixes += r.wrong_fixes;
  row->wrong_degraded += r.wrong_degraded;
  row->worst_fix_position_m = std::max(row->worst_fix_position_m, r.worst_fix_position_m);
  row->worst_fix_attitude_rad = std::max(row->worst_fix_attitude_rad, r.worst_fix_attitude_rad);
  row->worst_step_s = std::max(row->worst_step_s, r.worst_step_s);
  row->total_step_s += r.total_step_s;
  row->mean_in_view = (row->mean_in_view * static_cast<double>(row->frames) + r.mean_in_view * r.frames) /
                      static_cast<double>(row->frames + r.frames);
  row->frames += r.frames;
  row->slips += r.slips;
  row->slow += r.slow;
}

}  // namespace

std::vector<MatrixRow> Summarise(const std::vector<RunSpec>& runs, const std::vector<RunResult>& results,
                                 const MatrixLimits& limits) {
  std::vector<MatrixRow> rows;
  std::map<std::tuple<std::string, int, bool>, std::size_t> index;
  for (std::size_t i = 0; i < runs.size() && i < results.size(); ++i) {
    const RunSpec& r = runs[i];
    const auto key = std::make_tuple(r.preset, r.count, r.facing);
    auto it = index.find(key);
    if (it == index.end()) {
      it = index.emplace(key, rows.size()).first;
      MatrixRow row;
      row.preset = r.preset;
      row.count = r.count;
      row.facing = r.facing;
      row.map_has_facing = r.map_has_facing;
      row.map_beacons = r.map_beacons;
      rows.push_back(row);
    }
    AddRun(results[i], limits, &rows[it->second]);
  }
  return rows;
}

namespace {

std::string Fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string Short(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string LagCell(std::vector<int> lags) {
  if (lags.empty()) return "—";
  std::sort(lags.begin(), lags.end());
  const std::size_t n = lags.size();
  const double median = n % 2 == 1 ? lags[n / 2] : 0.5 * (lags[n / 2 - 1] + lags[n / 2]);
  return Short(median) + " / " + std::to_string(lags.back());
}

// Min over the runs with a first fix / over all their frame sets; nothing to show without one.
std::string PosedCell(const MatrixRow& r) {
  if (r.fixed_runs == 0) return "— (no fix)";
  const double all = r.eligible == 0 ? 1.0 : static_cast<double>(r.posed) / static_cast<double>(r.eligible);
  return Fixed(100.0 * r.min_posed_share, 2) + " % / " + Fixed(100.0 * all, 2) + " %";
}

std::string FacingCell(const MatrixRow& r) {
  if (!r.map_has_facing) return "none in map";
  return r.facing ? "yes" : "no";
}

std::string CountCell(const MatrixRow& r) { return std::to_string(r.map_beacons) + (r.count > 0 ? "" : " (own map)"); }

}  // namespace

std::string FormatMatrixTable(const std::vector<MatrixRow>& rows, const MatrixLimits& limits, double frame_period_s,
                              const NavMatrixOptions& o) {
  const std::string slip_ms = Fixed(frame_period_s * 1e3, 1), slow_ms = Short(o.slow_frame_s * 1e3);
  const std::string max_lag = std::to_string(limits.max_lag);
  std::string t = "| preset | beacons | facing in map | runs | in view (mean) | first-fix lag median / max | late > " +
                  max_lag + " / never | from a held view: lag median / max, late > " + max_lag +
                  " | posed after first fix: min run / all | fixes / degraded | wrong fixes | wrong degraded | "
                  "worst fix error mm / deg | Step ms worst / mean | slips > " +
                  slip_ms + " ms | > " + slow_ms + " ms |\n";
  t += "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const MatrixRow& r : rows) {
    t += "| " + r.preset + " | " + CountCell(r) + " | " + FacingCell(r) + " | " + std::to_string(r.runs) + " | " +
         Fixed(r.mean_in_view, 1) + " | " + LagCell(r.lags) + " | " + std::to_string(r.lag_exceeded) + " / " +
         std::to_string(r.never_fixed) + " | " + LagCell(r.held_lags) + ", " + std::to_string(r.held_lag_exceeded) +
         " | " + PosedCell(r) + " | " + std::to_string(r.fixes) + " / " +
         std::to_string(r.degraded) + " | " + std::to_string(r.wrong_fixes) + " | " + std::to_string(r.wrong_degraded) +
         " | " + Fixed(r.worst_fix_position_m * 1e3, 1) + " / " + Fixed(RadToDeg(r.worst_fix_attitude_rad), 2) + " | " +
         Fixed(r.worst_step_s * 1e3, 1) + " / " +
         Fixed(r.frames == 0 ? 0.0 : r.total_step_s * 1e3 / static_cast<double>(r.frames), 2) + " | " +
         std::to_string(r.slips) + " | " + std::to_string(r.slow) + " |\n";
  }
  int no_view4 = 0;
  for (const MatrixRow& r : rows) no_view4 += r.no_view4;
  t += "\nFirst-fix lag: frame set of the first fix minus the first frame set with >= 4 beacons in view (truth); "
       "late: more than " +
       std::to_string(limits.max_lag) +
       " frame sets (never: no fix at all in the run). From a held view: the same lag timed from the first frame "
       "set of the first stretch of " +
       std::to_string(o.held_view_frames) +
       " frame sets in a row with >= 4 beacons in view (the tracker acquires no shorter view: steady blobs, then "
       "an acquisition over frame sets); a run late only by the first measure lacked a view, not a search (not a "
       "requirement). Posed: share of the frame sets with >= 3 beacons in view, "
       "from the first fix on, that carry a pose (fix or degraded). Wrong: off by more than max(20 mm, 10 x the "
       "published largest per-axis 1-sigma) in position or 1 deg in attitude. Step ms: CPU time of "
       "Navigator::Step per frame set. Runs that never had >= 4 beacons in view: " +
       std::to_string(no_view4) + ".\n";
  return t;
}

std::vector<std::string> RequirementFailures(const std::vector<MatrixRow>& rows, const MatrixLimits& limits) {
  std::vector<std::string> failures;
  int wrong = 0;
  for (const MatrixRow& r : rows) {
    const std::string name = r.preset + (r.count > 0 ? " " + std::to_string(r.count) : std::string()) +
                             (r.map_has_facing ? (r.facing ? " facing yes" : " facing no") : "");
    if (r.lag_exceeded > 0)
      failures.push_back(name + ": first fix more than " + std::to_string(limits.max_lag) +
                         " frame sets after the first with >= 4 beacons in view in " + std::to_string(r.lag_exceeded) +
                         " of " + std::to_string(r.runs) + " runs (" + std::to_string(r.never_fixed) + " never fixed)");
    if (r.min_posed_share < limits.min_posed_share)
      failures.push_back(name + ": a run posed " + Fixed(100.0 * r.min_posed_share, 2) + " %" +
                         " of its frame sets with >= 3 beacons in view after the first fix (requirement " +
                         Short(100.0 * limits.min_posed_share) + " %)");
    wrong += r.wrong_fixes;
  }
  if (wrong > limits.max_wrong_fixes)
    failures.push_back(std::to_string(wrong) + " wrong fixes over the matrix (requirement " +
                       std::to_string(limits.max_wrong_fixes) + ")");
  return failures;
}

}  // namespace mfns::host
