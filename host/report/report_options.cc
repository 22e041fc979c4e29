#include "host/report/report_options.h"

namespace mfns::host {

void AddReportOptions(CLI::App& app, ReportCommandsOptions* o) {
  ReportOptions* ro = &o->report;
  CLI::App* report = app.add_subcommand("report", "Replication tables (paper Tables 3 and 5) and the HTML report");
  report->add_option("--sim", ro->sim_dir, "Directory written by `mfns-sim render` (truth.csv, crb.csv)");
  report->add_option("--poses", ro->poses, "[LABEL=]poses CSV (mfns-navd --log, mfns-sim solve-given); repeatable");
  report->add_option("--truth-rig", ro->truth_rig, "True rig of the calibration (DATASET/truth-rig.yaml)");
  report->add_option("--calib", ro->calib, "LABEL=rig.yaml of a calibration (mfns-calib rig); repeatable");
  report->add_option("--html", ro->html, "Write the HTML report with plots here");
  report->add_flag("--fix-only", ro->fix_only, "Statistics over status fix only (default: fix and degraded)");
  report->add_flag("--common-frames", ro->common_frames, "Table 5 over the frame sets that every --poses run posed");

  MergeRigOptions* mo = &o->merge;
  CLI::App* merge = app.add_subcommand("merge-rig", "Calibrated cameras + a surveyed beacon map -> the flyer's rig file");
  merge->add_option("--cameras", mo->cameras, "Rig file with the cameras (mfns-calib rig's rig.yaml)")->required();
  merge->add_option("--beacons", mo->beacons, "Rig file with the beacon map (e.g. render's believed-rig.yaml)")->required();
  merge->add_option("--out", mo->out, "Output rig file")->required();

  SolveGivenCommandOptions* go = &o->given;
  CLI::App* given = app.add_subcommand("solve-given", "The paper's pipeline: Newton on the true correspondences (blobs.csv)");
  given->add_option("dir", go->dir, "Directory written by `mfns-sim render` (truth.csv, blobs.csv)")->required();
  given->add_option("--rig", go->rig, "Rig the navigator believes (cameras and beacon map)")->required();
  given->add_option("--out", go->out, "Output poses CSV")->required();
  given->add_flag("--geometric", go->opt.use_geometric, "Use the noise-free projections (u_geom_px)");
  given->add_option("--sigma-px", go->opt.sigma_px, "Centroid 1-sigma (px) for the covariance")->check(CLI::PositiveNumber);
}

}  // namespace mfns::host
