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
