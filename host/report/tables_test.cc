#include "host/report/tables.h"

#include <gtest/gtest.h>

#include <sstream>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "host/report/report_command.h"
#include "host/report/report_test_util.h"
#include "host/rigio/rig_yaml.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

// The line of `text` that starts with `prefix` ("" when none).
std::string LineStarting(const std::string& text, const std::string& prefix) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(prefix, 0) == 0) return line;
  return "";
}

TEST(Tables, Table5HasThePaperAndEachRun) {
  PoseSummary s;
  s.frames = 10;
  s.used = 8;
  s.axes[0] = {0.1234, 1.5, 1.6, 0.07, 8};
  s.axes[5] = {-0.0042, 0.0123, 0.013, 0.005, 8};
  PoseSummary empty;
  const std::string t = FormatTable5({{"ours", s}, {"given", empty}});
  const std::string x = LineStarting(t, "  x_mm");
  // paper -0.0553 1.6043 | ours 0.1234 1.5000 0.0700 | given - - -
  EXPECT_NE(x.find("-0.0553"), std::string::npos) << t;
  EXPECT_NE(x.find("1.6043"), std::string::npos);
  EXPECT_NE(x.find("0.1234"), std::string::npos);
  EXPECT_NE(x.find("1.5000"), std::string::npos);
  EXPECT_NE(x.find("0.0700"), std::string::npos);
  EXPECT_NE(x.find(" - "), std::string::npos);
  const std::string yaw = LineStarting(t, "  yaw_deg");
  EXPECT_NE(yaw.find("0.1729"), std::string::npos);
  EXPECT_NE(yaw.find("-0.0042"), std::string::npos);
  EXPECT_NE(t.find("ours: 10 frame sets, 8 in the statistics"), std::string::npos);
}

TEST(Tables, Table3HasEveryCameraMethodAndThePaperSigma) {
  CameraCalibError x;
  x.name = "x";
  x.euler_error_deg = {0.0012, -0.0034, 0.0005};
  x.euler_sigma_deg = {0.003, 0.004, 0.002};
  x.rotation_deg = 0.0042;
  x.position_error_mm = {0.05, -0.07, 0.01};
  x.position_sigma_mm = {0.02, 0.03, 0.04};
  x.position_mm = 0.087;
  x.has_sigma = true;
  CameraCalibError xp = x;
  xp.has_sigma = false;
  xp.euler_error_deg.x() = -0.0400;
  const std::string t = FormatTable3({{"ml", {x}}, {"paper", {xp}}}, PaperRig());
  const std::string phi = LineStarting(t, "  x      phi_deg");
  EXPECT_NE(phi.find("+0.0012 (0.0030)"), std::string::npos) << t;
  EXPECT_NE(phi.find("-0.0400"), std::string::npos);
  EXPECT_NE(phi.find("| 0.0413"), std::string::npos);  // Table 3, C_b_x phi sigma
  const std::string ry = LineStarting(t, "  x      r_y_mm");
  EXPECT_NE(ry.find("-0.0700 (0.0300)"), std::string::npos);
  EXPECT_NE(ry.find("| 0.4498"), std::string::npos);  // Table 3, r_bx_b y sigma
  EXPECT_NE(LineStarting(t, "  x      |rotation|_deg").find("+0.0042"), std::string::npos);
}

// The HTML report's cells are the text's values, one per cell: each row's cells appear, in
// order, in the text line of the same row.
void ExpectCellsInText(const CellTable& t, const std::string& text, const std::string& prefix_of_row0) {
  ASSERT_FALSE(t.rows.empty());
  for (const auto& row : t.rows) EXPECT_EQ(row.size(), t.header.size());
  EXPECT_EQ(text.rfind(t.caption + "\n", 0), 0u) << text;
  std::istringstream in(text);
  std::string line;
  std::size_t r = 0;
  while (std::getline(in, line) && r < t.rows.size()) {
    if (r == 0 && line.rfind(prefix_of_row0, 0) != 0) continue;
    std::size_t at = 0;
    for (const std::string& cell : t.rows[r]) {
      at = line.find(cell, at);
      ASSERT_NE(at, std::string::npos) << "row " << r << " cell '" << cell << "' in: " << line;
      at += cell.size();
    }
    ++r;
  }
  EXPECT_EQ(r, t.rows.size());
  for (const std::string& n : t.notes) EXPECT_NE(text.find("  " + n + "\n"), std::string::npos) << n;
}

TEST(Tables, CellsHoldTheTextsValues) {
  PoseSummary s;
  s.frames = 10;
  s.used = 8;
  for (int a = 0; a < 6; ++a) s.axes[static_cast<std::size_t>(a)] = {0.1234 * a - 0.3, 1.5 + a, 1.6, 0.07 * a, 8};
  const std::vector<NamedPoseSummary> runs{{"ours", s}, {"given", PoseSummary{}}};
  const CellTable t5 = Table5Cells(runs);
  EXPECT_EQ(t5.header.size(), 3u + 2 * 3);
  EXPECT_EQ(t5.rows.size(), 6u);
  EXPECT_EQ(t5.rows[0][3], "-0.3000");
  EXPECT_EQ(t5.rows[5][8], "-");
  ExpectCellsInText(t5, FormatTable5(runs), "  x_mm");

  CameraCalibError x;
  x.name = "x";
  x.euler_error_deg = {0.0012, -0.0034, 0.0005};
  x.euler_sigma_deg = {0.003, 0.004, 0.002};
  x.position_error_mm = {0.05, -0.07, 0.01};
  x.position_sigma_mm = {0.02, 0.03, 0.04};
  x.has_sigma = true;
  CameraCalibError y = x;
  y.name = "y";
  y.has_sigma = false;
  const std::vector<NamedCalibration> methods{{"ml", {x, y}}, {"paper", {y}}};
  const CellTable t3 = Table3Cells(methods, PaperRig());
  EXPECT_EQ(t3.header.size(), 2u + 2 + 1);
  EXPECT_EQ(t3.rows.size(), 16u);  // 2 cameras x 8 quantities
  EXPECT_EQ(t3.rows[0][2], "+0.0012 (0.0030)");
  EXPECT_EQ(t3.rows[0][3], "-");  // the paper method has no camera x
  EXPECT_EQ(t3.rows[0][4], "0.0413");
  ExpectCellsInText(t3, FormatTable3(methods, PaperRig()), "  x      phi_deg");
}

TEST(ReportCommand, PrintsBothTablesAndWritesTheHtml) {
  const auto d = FreshTestDir("cmd");
  WriteText(d / "truth.csv", "frame,t_ns,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n0,1,0,0,0,0,0,0\n1,2,0,0,0,0,0,1\n");
  WriteText(d / "poses.csv",
            "frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px\n"
            "0,1,fix,0.5,0,0,0,0,0,3,0.1\n1,2,fix,1.5,0,0,0,0,1,3,0.1\n");
  Rig truth = PaperRig();
  WriteRigYaml(d / "truth-rig.yaml", truth);
  truth.cameras[1].r_b_bk.z() += 0.00025;
  WriteRigYaml(d / "ml-rig.yaml", truth);
  ReportOptions o;
  o.sim_dir = d.string();
  o.poses = {"navd=" + (d / "poses.csv").string()};
  o.truth_rig = (d / "truth-rig.yaml").string();
  o.calib = {"ml=" + (d / "ml-rig.yaml").string()};
  o.html = (d / "report.html").string();
  std::ostringstream out;
  RunReport(o, out);
  const std::string x = LineStarting(out.str(), "  x_mm");
  EXPECT_NE(x.find("1.0000"), std::string::npos) << out.str();   // mean of 0.5 and 1.5
  EXPECT_NE(x.find("0.7071"), std::string::npos) << out.str();   // their sample std
  EXPECT_NE(LineStarting(out.str(), "  y      r_z_mm").find("+0.2500"), std::string::npos) << out.str();
  const std::string html = ReadFile(d / "report.html");
  EXPECT_NE(html.find("<table id=\"table5\">"), std::string::npos);
  EXPECT_NE(html.find("<table id=\"table3\">"), std::string::npos);
  EXPECT_EQ(html.find("<pre"), std::string::npos);
  EXPECT_NE(html.find("<td>1.0000</td><td>0.7071</td>"), std::string::npos) << html;  // x_mm: mean, std
  EXPECT_NE(html.find("<li>statistics over status fix and degraded (every frame set with a pose)</li>"), std::string::npos);

  o.sim_dir.clear();
  EXPECT_THROW(RunReport(o, out), UserError);  // --poses without --sim
  ReportOptions none;
  EXPECT_THROW(RunReport(none, out), UserError);
}

}  // namespace
}  // namespace mfns::host
