#include "host/calib/core/dataset.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "common/rotation/rotation.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

namespace fs = std::filesystem;

class DatasetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("calib_dataset_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "images" / "z");
    WriteFileAtomic(dir_ / "target.yaml", "type: checkerboard\ncols: 9\nrows: 7\nsquare_mm: 30.0\n");
    WriteFileAtomic(dir_ / "images" / "z" / "000.pgm", "P5\n1 1\n255\n\x10");
    WriteFileAtomic(dir_ / "images" / "z" / "001.pgm", "P5\n1 1\n255\n\x10");
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Error(const std::string& csv) {
    WriteFileAtomic(dir_ / "images.csv", csv);
    try {
      ReadCalibDataset(dir_);
    } catch (const UserError& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

TEST_F(DatasetTest, ReadsImagesTargetAndTruth) {
  WriteFileAtomic(dir_ / "images.csv", "camera,image,kind,main_deg,aux_deg\nz,000,turntable,1.5,-2.0\nz,001,free,,\n");
  WriteFileAtomic(dir_ / "truth.yaml",
                  "C_w_t: [1,0,0, 0,-1,0, 0,0,-1]\nr_w_wt_mm: [10, 20, 685]\nr_p_pb_mm: [0, 0, 108]\nimages:\n"
                  "  - {camera: z, image: \"000\", kind: turntable, main_true_deg: 1.501, aux_true_deg: -2.0}\n");
  const CalibDataset ds = ReadCalibDataset(dir_);
  ASSERT_EQ(ds.images.size(), 2u);
  EXPECT_EQ(ds.cameras, std::vector<std::string>{"z"});
  EXPECT_EQ(ds.images[0].kind, ImageKind::kTurntable);
  EXPECT_NEAR(ds.images[0].main_cmd, DegToRad(1.5), 1e-15);
  EXPECT_NEAR(ds.images[0].aux_cmd, DegToRad(-2.0), 1e-15);
  EXPECT_EQ(ds.images[1].kind, ImageKind::kFree);
  EXPECT_EQ(ds.target.type(), TargetType::kCheckerboard);
  EXPECT_EQ(ds.target.checkerboard().cols, 9);
  EXPECT_DOUBLE_EQ(ds.target.checkerboard().square_m, 0.03);
  ASSERT_TRUE(ds.truth.has_mount);
  EXPECT_DOUBLE_EQ(ds.truth.mount.r_p_pb.z(), 0.108);
  EXPECT_DOUBLE_EQ(ds.truth.mount.C_w_t(2, 2), -1.0);
  EXPECT_NEAR(ds.truth.images.at("z/000").main_true, DegToRad(1.501), 1e-15);
}

TEST_F(DatasetTest, ErrorsNameTheFileLineAndField) {
  EXPECT_NE(Error("camera,image,kind\nz,000,free\n").find("images.csv:1: expected the header"), std::string::npos);
  EXPECT_NE(Error("camera,image,kind,main_deg,aux_deg\nz,000,turntable,x,0\n").find("images.csv:2: main_deg"),
            std::string::npos);
  EXPECT_NE(Error("camera,image,kind,main_deg,aux_deg\nz,000,spin,0,0\n").find("images.csv:2: kind"), std::string::npos);
  EXPECT_NE(Error("camera,image,kind,main_deg,aux_deg\nz,007,free,,\n").find("no file"), std::string::npos);
  EXPECT_NE(Error("camera,image,kind,main_deg,aux_deg\nz,000,free,,\nz,000,free,,\n").find("listed twice"),
            std::string::npos);
  EXPECT_NE(Error("camera,image,kind,main_deg,aux_deg\nz,000,free,1,\n").find("no turntable angles"), std::string::npos);
}

TEST(TargetSpec, ParsesTheCommandLineForms) {
  const CalibrationTarget cb = ParseTargetSpec("checkerboard:9x7:30");
  EXPECT_EQ(cb.checkerboard().cols, 9);
  EXPECT_EQ(cb.checkerboard().rows, 7);
  EXPECT_DOUBLE_EQ(cb.checkerboard().square_m, 0.03);
  const CalibrationTarget ag = ParseTargetSpec("aprilgrid:6x5:40:0.3:10");
  EXPECT_EQ(ag.aprilgrid().tag_cols, 6);
  EXPECT_EQ(ag.aprilgrid().tag_rows, 5);
  EXPECT_EQ(ag.aprilgrid().first_id, 10);
  EXPECT_DOUBLE_EQ(ag.aprilgrid().tag_spacing, 0.3);
  for (const char* bad : {"checkerboard:9:30", "checkerboard:9x7", "checkerboard:9x7:-1", "circles:9x7:30",
                          "checkerboard:1x7:30", "aprilgrid:6x6:40"})
    EXPECT_THROW(ParseTargetSpec(bad), UserError) << bad;
}

// Issue 14, defect 5: counts and ids that overflowed int arithmetic (SIGSEGV) or allocated
// gigabytes are refused first, with one line naming the spec or file and the field.
std::string SpecError(const std::string& spec) {
  try {
    ParseTargetSpec(spec);
  } catch (const UserError& e) {
    return e.what();
  }
  return "";
}

TEST(TargetSpec, OutOfBoundsFieldsAreNamedNotOverflowed) {
  const struct {
    const char* spec;
    const char* field;
  } cases[] = {{"aprilgrid:6x6:10:0.3:2147483647", "first_id"},
               {"aprilgrid:6x6:10:0.3:-1", "first_id"},
               {"aprilgrid:65536x65536:10:0.3", "tag_cols"},
               {"aprilgrid:500x500:10:0.3", "tag_cols x tag_rows"},
               {"aprilgrid:25x24:10:0.3", "tag_cols x tag_rows"},  // 600 tags, 587 codes
               {"aprilgrid:6x6:10:1e300", "tag_spacing"},
               {"aprilgrid:6x6:1e300:0.3", "tag_size_mm"},
               {"checkerboard:1000000000x7:30", "cols"},
               {"checkerboard:9x2147483647:30", "rows"},
               {"checkerboard:9x7:1e300", "square_mm"},
               {"checkerboard:9x7:0.00001", "square_mm"}};
  for (const auto& c : cases) {
    const std::string what = SpecError(c.spec);
    EXPECT_NE(what.find(std::string("--target \"") + c.spec + "\""), std::string::npos) << c.spec << ": " << what;
    EXPECT_NE(what.find(std::string(": ") + c.field + ": "), std::string::npos) << c.spec << ": " << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
  // Found by calib_dataset_fuzz: a spec holding a newline was echoed raw, a two-line error.
  const std::string two_lines = SpecError("aprilgrid:6x6\n:10:0.3");
  EXPECT_EQ(two_lines.find('\n'), std::string::npos) << two_lines;
  EXPECT_NE(two_lines.find("--target \"aprilgrid:6x6\\n:10:0.3\""), std::string::npos) << two_lines;
  // The largest legal grids still work.
  EXPECT_EQ(ParseTargetSpec("aprilgrid:1x587:10:0.3").corners().size(), 4u * 587u);
  EXPECT_EQ(ParseTargetSpec("aprilgrid:1x1:10:0.3:586").corners().size(), 4u);
  EXPECT_EQ(ParseTargetSpec("checkerboard:200x200:1").corners().size(), 200u * 200u);
}

TEST(TargetYaml, OutOfBoundsFieldsAreNamedWithTheFile) {
  const struct {
    const char* yaml;
    const char* field;
  } cases[] = {
      {"type: checkerboard\ncols: 1000000000\nrows: 7\nsquare_mm: 30\n", "cols"},
      {"type: checkerboard\ncols: 9\nrows: 7\nsquare_mm: 30\nborder_mm: 1e300\n", "border_mm"},
      {"type: aprilgrid\ntag_cols: 6\ntag_rows: 6\ntag_size_mm: 10\ntag_spacing: 0.3\nfirst_id: 2147483647\n", "first_id"},
      {"type: aprilgrid\ntag_cols: 65536\ntag_rows: 65536\ntag_size_mm: 10\ntag_spacing: 0.3\n", "tag_cols"},
  };
  for (const auto& c : cases) {
    std::string what;
    try {
      ParseTargetYaml(c.yaml, "d/target.yaml");
    } catch (const UserError& e) {
      what = e.what();
    }
    EXPECT_EQ(what.rfind("d/target.yaml: ", 0), 0u) << what;
    EXPECT_NE(what.find(std::string(": ") + c.field + ": "), std::string::npos) << c.yaml << ": " << what;
  }
}

TEST_F(DatasetTest, TargetYamlWithAnOverflowingFirstIdIsAUserError) {
  WriteFileAtomic(dir_ / "target.yaml",
                  "type: aprilgrid\ntag_cols: 6\ntag_rows: 6\ntag_size_mm: 10\ntag_spacing: 0.3\nfirst_id: 2147483647\n");
  const std::string what = Error("camera,image,kind,main_deg,aux_deg\nz,000,free,,\n");
  EXPECT_NE(what.find("target.yaml: aprilgrid: first_id: 2147483647 outside 0..586"), std::string::npos) << what;
}

TEST(TargetYaml, RoundTripsAndGivesCornerPositions) {
  for (const CalibrationTarget& t : {ParseTargetSpec("checkerboard:9x7:30"), ParseTargetSpec("aprilgrid:6x5:40:0.3:10")}) {
    const CalibrationTarget back = ParseTargetYaml(FormatTargetYaml(t), "t.yaml");
    ASSERT_EQ(back.corners().size(), t.corners().size());
    const std::vector<Eigen::Vector3d> pts = TargetPoints(back);
    for (const TargetCorner& c : t.corners()) EXPECT_LT((pts[static_cast<std::size_t>(c.id)] - c.P_w).norm(), 1e-12);
  }
  // Checkerboard id i * cols + j sits at (j q, i q).
  const std::vector<Eigen::Vector3d> pts = TargetPoints(ParseTargetSpec("checkerboard:9x7:30"));
  EXPECT_LT((pts[2 * 9 + 5] - Eigen::Vector3d(0.15, 0.06, 0.0)).norm(), 1e-12);
  EXPECT_THROW(ParseTargetYaml("type: checkerboard\ncols: 9\nrows: 7\nsquare: 30\n", "t.yaml"), UserError);
}

}  // namespace
}  // namespace mfns::host

namespace {
std::string CornersError(const std::string& text) {
  try {
    mfns::host::ParseCornersCsv(text, "c.csv", 54);
  } catch (const mfns::host::UserError& e) {
    return e.what();
  }
  return "(no error)";
}
}  // namespace

// The corners CSV reader (moved here from mfns-calib so that calib_dataset_fuzz reaches it):
// rows by camera and image with their lines; every error one line naming the line and field,
// also when a field holds control characters.
TEST(CornersCsv, ParsesRowsAndNamesTheLineAndField) {
  const auto rows = mfns::host::ParseCornersCsv("camera,image,corner,u_px,v_px\r\nx,0001,3,10.5,20\ny,0002,53,1,2\n", "c.csv", 54);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].camera, "x");
  EXPECT_EQ(rows[0].image, "0001");
  EXPECT_EQ(rows[0].corner.id, 3);
  EXPECT_DOUBLE_EQ(rows[0].corner.uv.x(), 10.5);
  EXPECT_EQ(rows[1].line, 3);
  EXPECT_EQ(CornersError("x,1,54,1,2\n"), "c.csv:1: corner id \"54\" is not one of the target's 0..53");
  EXPECT_EQ(CornersError("x,1,2,nan,2\n"), "c.csv:1: u_px: bad pixel coordinate \"nan\"");
  EXPECT_EQ(CornersError("x,1,2,1\n"), "c.csv:1: expected 5 cells (camera,image,corner,u_px,v_px), got 4");
  EXPECT_EQ(CornersError("x,1,2,1,2\nx,1,2,3,4\n"), "c.csv:2: corner: id 2 of x/1 repeats line 1");
  EXPECT_EQ(CornersError("x,1,2,1,2\x1b[2J\n"), "c.csv:1: v_px: bad pixel coordinate \"2\\x1b[2J\"");
}
