#include "host/sim/analysis/analyze_command.h"

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <stdexcept>

#include "common/rotation/rotation.h"
#include "host/sim/analysis/svg_plot.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

constexpr std::array<ErrorFigure, 3> kFigures{ErrorFigure::kBeaconPosition, ErrorFigure::kCameraPosition,
                                              ErrorFigure::kCameraAttitude};

Eigen::Vector2d RangeMm(const std::vector<double>& r, const char* option) {
  if (r.size() != 2 || !std::isfinite(r[0]) || !std::isfinite(r[1]) || !(r[1] > r[0]))
    throw UserError(std::string(option) + ": expected two finite numbers MIN MAX with MIN < MAX (mm)");
  return {r[0] * 1e-3, r[1] * 1e-3};
}

double MaxMagnitude(const AnalyzeOptions& o, ErrorFigure f) {
  switch (f) {
    case ErrorFigure::kBeaconPosition: return o.fig4_max_mm;
    case ErrorFigure::kCameraPosition: return o.fig5_max_mm;
    case ErrorFigure::kCameraAttitude: return o.fig6_max_deg;
  }
  return 0.0;
}

const char* MaxOption(ErrorFigure f) {
  switch (f) {
    case ErrorFigure::kBeaconPosition: return "--fig4-max-mm";
    case ErrorFigure::kCameraPosition: return "--fig5-max-mm";
    case ErrorFigure::kCameraAttitude: return "--fig6-max-deg";
  }
  return "";
}

std::string Describe(ErrorFigure f) {
  switch (f) {
    case ErrorFigure::kBeaconPosition: return "beacon position error";
    case ErrorFigure::kCameraPosition: return "camera-to-body position error";
    case ErrorFigure::kCameraAttitude: return "camera-to-body attitude error";
  }
  return "";
}

SvgPlot MakePlot(const FigureResult& r, const AnalysisSetup& s) {
  const ErrorFigure f = r.figure;
  SvgPlot p;
  p.title = "Figure " + std::to_string(static_cast<int>(f)) + ": RMS pixel error of u vs " + Describe(f);
  p.x_label = Describe(f) + " (" + DisplayUnit(f) +
              (s.draw == ErrorDraw::kGaussian ? ", 1-sigma per axis)" : ", norm)");
  p.y_label = "RMS error of u (px)";
  p.dots_legend = "Monte Carlo (" + std::to_string(r.points.empty() ? 0 : r.points.front().trials) + " trials/point)";
  p.line_legend = "first-order analytic";
  for (const PointResult& pt : r.points) {
    p.dots_x.push_back(ToDisplayUnit(f, pt.magnitude));
    p.dots_y.push_back(pt.mc_rms_px);
  }
  const double x_end = r.points.empty() ? 0.0 : r.points.back().magnitude;
  p.line_x = {0.0, ToDisplayUnit(f, x_end)};
  p.line_y = {0.0, r.analytic_slope * x_end};
  return p;
}

void PrintSummary(const AnalyzeOptions& o, const AnalyzeResult& res, std::ostream& out) {
  const AnalysisSetup& s = res.setup;
  char line[512];
  std::snprintf(line, sizeof line,
                "mfns-sim analyze: camera alpha %.0f px, (u0, v0) = (%.0f, %.0f), %dx%d; beacons X [%g, %g] Y [%g, %g] "
                "Z [%g, %g] mm, depth >= %g mm, %s (%.2f%% of the box kept); error draw %s; %" PRId64
                " trials/point, seed %" PRIu64 "\n",
                s.camera.alpha_x, s.camera.u0, s.camera.v0, s.camera.width, s.camera.height, o.beacon_x_range_mm[0],
                o.beacon_x_range_mm[1], o.beacon_y_range_mm[0], o.beacon_y_range_mm[1], o.beacon_z_range_mm[0],
                o.beacon_z_range_mm[1], o.min_depth_mm, s.fov_gate ? "in the image" : "no image gate",
                100.0 * KeptFraction(s), ToString(s.draw), o.trials, o.seed);
  out << line;
  for (const FigureResult& r : res.figures) {
    const ErrorFigure f = r.figure;
    const double k = FromDisplayUnit(f, 1.0);  // SI per display unit
    std::snprintf(line, sizeof line,
                  "figure %d (%s): slope MC %.4f px/%s, analytic %.4f px/%s, MC/analytic %.4f; at %g %s: MC %.3f px\n",
                  static_cast<int>(f), Describe(f).c_str(), r.mc_slope * k, DisplayUnit(f), r.analytic_slope * k,
                  DisplayUnit(f), r.analytic_slope > 0 ? r.mc_slope / r.analytic_slope : 0.0,
                  ToDisplayUnit(f, r.points.back().magnitude), DisplayUnit(f), r.points.back().mc_rms_px);
    out << line;
  }
  // The paper's conclusion: < 1 mm camera position and < 0.17 deg attitude give a few pixels.
  const double pos_px = res.figures[1].mc_slope * 1e-3;
  const double att_px = res.figures[2].mc_slope * DegToRad(0.17);
  const bool holds = pos_px <= o.few_px && att_px <= o.few_px;
  std::snprintf(line, sizeof line,
                "paper's conclusion (position < 1 mm and attitude < 0.17 deg keep u within a few pixels): "
                "1 mm -> %.2f px, 0.17 deg -> %.2f px RMS (MC slope); %s (few = <= %g px)\n",
                pos_px, att_px, holds ? "holds" : "does not hold", o.few_px);
  out << line;
}

}  // namespace

std::string FigureStem(ErrorFigure f) {
  switch (f) {
    case ErrorFigure::kBeaconPosition: return "fig4_beacon_position";
    case ErrorFigure::kCameraPosition: return "fig5_camera_position";
    case ErrorFigure::kCameraAttitude: return "fig6_camera_attitude";
  }
  return "fig";
}

AnalysisSetup SetupFromOptions(const AnalyzeOptions& o) {
  if (o.out_dir.empty()) throw UserError("--out: an output directory is required");
  if (o.trials < 1 || o.trials > 100000000) throw UserError("--trials: must be in [1, 100000000]");
  if (o.points < 2 || o.points > 1000) throw UserError("--points: must be in [2, 1000]");
  if (!std::isfinite(o.min_depth_mm) || o.min_depth_mm < 0.0) throw UserError("--min-depth-mm: must be >= 0");
  if (!(o.few_px > 0.0)) throw UserError("--few-px: must be > 0");
  for (const ErrorFigure f : kFigures) {
    const double m = MaxMagnitude(o, f);
    if (!std::isfinite(m) || !(m > 0.0)) throw UserError(std::string(MaxOption(f)) + ": must be > 0");
  }
  AnalysisSetup s = PaperTable1Setup();
  s.x_range = RangeMm(o.beacon_x_range_mm, "--beacon-x-range-mm");
  s.y_range = RangeMm(o.beacon_y_range_mm, "--beacon-y-range-mm");
  s.z_range = RangeMm(o.beacon_z_range_mm, "--beacon-z-range-mm");
  s.min_depth = o.min_depth_mm * 1e-3;
  s.fov_gate = !o.no_fov_gate;
  if (o.error_draw == "gaussian") {
    s.draw = ErrorDraw::kGaussian;
  } else if (o.error_draw == "sphere") {
    s.draw = ErrorDraw::kSphere;
  } else {
    throw UserError("--error-draw: '" + OneLine(o.error_draw) + "' is not one of gaussian, sphere");
  }
  try {
    ValidateSetup(s);
  } catch (const std::invalid_argument& e) {
    throw UserError(std::string("beacon region: ") + e.what());
  }
  return s;
}

AnalyzeResult RunAnalyze(const AnalyzeOptions& o, std::ostream& summary, std::ostream& progress) {
  AnalyzeResult res;
  res.setup = SetupFromOptions(o);
  const std::filesystem::path dir(o.out_dir);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw UserError(o.out_dir + ": cannot create the output directory" + (ec ? ": " + ec.message() : ""));

  for (std::size_t i = 0; i < kFigures.size(); ++i) {
    const ErrorFigure f = kFigures[i];
    const auto report = [&](int k, int n, const PointResult& p) {
      char line[256];
      std::snprintf(line, sizeof line,
                    "analyze: figure %d point %d/%d: %g %s, MC %.4f px, analytic %.4f px (%" PRId64 " trials, %" PRId64
                    " candidates drawn)\n",
                    static_cast<int>(f), k + 1, n, ToDisplayUnit(f, p.magnitude), DisplayUnit(f), p.mc_rms_px,
                    p.analytic_rms_px, p.trials, p.draws);
      progress << line << std::flush;
    };
    try {
      res.figures[i] =
          RunFigure(res.setup, f, FromDisplayUnit(f, MaxMagnitude(o, f)), o.points, o.trials, o.seed, report);
    } catch (const std::invalid_argument& e) {
      throw UserError(std::string("analyze: ") + e.what());
    }
    const std::string stem = FigureStem(f);
    WriteFileAtomic(dir / (stem + ".csv"), FigureCsv(res.figures[i]));
    WriteFileAtomic(dir / (stem + ".svg"), RenderSvg(MakePlot(res.figures[i], res.setup)));
  }
  PrintSummary(o, res, summary);
  return res;
}

void AddAnalyzeCommand(CLI::App& app) {
  auto o = std::make_shared<AnalyzeOptions>();
  AddAnalyzeOptions(app, o.get())->callback([o]() { RunAnalyze(*o, std::cout, std::cerr); });
}

}  // namespace mfns::host
