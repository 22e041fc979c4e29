#include "host/calib/core/dataset.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>

#include "common/rotation/rotation.h"
#include "host/rigio/rig_yaml.h"
#include "host/rigio/yaml_fields.h"
#include "host/util/atomic_file.h"
#include "host/util/csv_table.h"

namespace mfns::host {
namespace {

constexpr double kMm = 1e-3;

bool ParseDouble(const std::string& s, double* v) {
  const char* b = s.data();
  const char* e = s.data() + s.size();
  if (b != e && *b == '+') ++b;
  const auto r = std::from_chars(b, e, *v);
  return r.ec == std::errc() && r.ptr == e && std::isfinite(*v);
}

bool ParseInt(const std::string& s, int* v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), *v);
  return !s.empty() && r.ec == std::errc() && r.ptr == s.data() + s.size();
}

Eigen::Matrix3d Matrix9(const YAML::Node& n, const YamlCtx& ctx) {
  const std::array<double, 9> a = Numbers<9>(n, ctx);
  Eigen::Matrix3d C;
  for (int i = 0; i < 9; ++i) C(i / 3, i % 3) = a[static_cast<std::size_t>(i)];
  if (!IsRotation(C, 1e-6)) ctx.Fail(n, "not a rotation matrix (orthonormal, det +1, 1e-6)");
  return C;
}

Eigen::Vector3d Vector3Mm(const YAML::Node& n, const YamlCtx& ctx) {
  const std::array<double, 3> a = Numbers<3>(n, ctx);
  return Eigen::Vector3d(a[0], a[1], a[2]) * kMm;
}

// One images.csv row; the header is kImagesCsvHeader, checked by the table.
DatasetImage ImageRow(const CsvTable& table, std::size_t row) {
  const auto fail = [&](const std::string& what) {
    throw UserError(table.source() + ":" + std::to_string(table.Line(row)) + ": " + what);
  };
  const auto cell = [&](const char* column) -> const std::string& { return table.Cell(row, table.Column(column)); };
  DatasetImage im;
  im.camera = cell("camera");
  im.image = cell("image");
  if (im.camera.empty() || im.camera.size() > static_cast<std::size_t>(limits::kMaxCameraNameChars))
    fail("camera: expected a name of 1.." + std::to_string(limits::kMaxCameraNameChars) + " characters");
  if (im.image.empty() || im.image.find('/') != std::string::npos) fail("image: expected a file stem");
  const std::string& kind = cell("kind");
  const std::string& main_deg = cell("main_deg");
  const std::string& aux_deg = cell("aux_deg");
  if (kind == "turntable") {
    im.kind = ImageKind::kTurntable;
    double m = 0, a = 0;
    if (!ParseDouble(main_deg, &m)) fail("main_deg: expected a number, got \"" + main_deg + "\"");
    if (!ParseDouble(aux_deg, &a)) fail("aux_deg: expected a number, got \"" + aux_deg + "\"");
    im.main_cmd = DegToRad(m);
    im.aux_cmd = DegToRad(a);
  } else if (kind == "free") {
    im.kind = ImageKind::kFree;
    if (!main_deg.empty() || !aux_deg.empty()) fail("a free image has no turntable angles");
  } else {
    fail("kind: expected turntable or free, got \"" + kind + "\"");
  }
  return im;
}

std::vector<DatasetImage> ReadImagesCsv(const std::filesystem::path& path) {
  // Cells trimmed and lines of spaces skipped, as images.csv has always been read.
  const CsvTable table = CsvTable::Read(path, {.trim = true, .columns = kImagesCsvHeader, .header_optional = false});
  std::vector<DatasetImage> images;
  for (std::size_t row = 0; row < table.size(); ++row) {
    const DatasetImage im = ImageRow(table, row);
    for (const DatasetImage& other : images)
      if (other.camera == im.camera && other.image == im.image)
        throw UserError(table.source() + ":" + std::to_string(table.Line(row)) + ": image " + im.camera + "/" +
                        im.image + " listed twice");
    images.push_back(im);
  }
  if (images.empty()) throw UserError(table.source() + ": lists no images");
  return images;
}

void ReadTruth(const std::filesystem::path& path, DatasetTruth* truth) {
  const std::string src = path.string();
  const YAML::Node root = LoadYaml(ReadFile(path), src);
  const YamlCtx ctx{src, ""};
  truth->mount.C_w_t = Matrix9(Require(root, "C_w_t", ctx), ctx.Sub("C_w_t"));
  truth->mount.r_w_wt = Vector3Mm(Require(root, "r_w_wt_mm", ctx), ctx.Sub("r_w_wt_mm"));
  truth->mount.C_p_b = Has(root, "C_p_b") ? Matrix9(root["C_p_b"], ctx.Sub("C_p_b")) : Eigen::Matrix3d::Identity();
  truth->mount.r_p_pb =
      Has(root, "r_p_pb_mm") ? Vector3Mm(root["r_p_pb_mm"], ctx.Sub("r_p_pb_mm")) : Eigen::Vector3d::Zero();
  truth->has_mount = true;
  truth->angle_sigma_arcsec = NumberOr(root, "turntable_angle_sigma_arcsec", -1.0, ctx);
  if (!Has(root, "images")) return;
  const YAML::Node list = root["images"];
  const YamlCtx lctx = ctx.Sub("images");
  if (!list.IsSequence()) lctx.Fail(list, "expected a list");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YAML::Node n = list[i];
    const YamlCtx c = lctx.Index(i);
    DatasetTruth::Image im;
    const std::string key = String(Require(n, "camera", c), c.Sub("camera")) + "/" + String(Require(n, "image", c), c.Sub("image"));
    const std::string kind = String(Require(n, "kind", c), c.Sub("kind"));
    if (kind == "turntable") {
      im.kind = ImageKind::kTurntable;
      im.main_true = DegToRad(Number(Require(n, "main_true_deg", c), c.Sub("main_true_deg")));
      im.aux_true = DegToRad(Number(Require(n, "aux_true_deg", c), c.Sub("aux_true_deg")));
    } else if (kind == "free") {
      im.kind = ImageKind::kFree;
      im.C_k_w = Matrix9(Require(n, "C_k_w", c), c.Sub("C_k_w"));
      im.r_w_wk = Vector3Mm(Require(n, "r_w_wk_mm", c), c.Sub("r_w_wk_mm"));
    } else {
      c.Sub("kind").Fail(n["kind"], "expected turntable or free");
    }
    truth->images[key] = im;
  }
}

CalibrationTarget ParseTarget(const std::string& text, const std::string& source);

}  // namespace

const char* ToString(ImageKind k) { return k == ImageKind::kTurntable ? "turntable" : "free"; }

CalibrationTarget ParseTargetYaml(const std::string& text, const std::string& source) {
  return CatchYamlErrors(source, [&] { return ParseTarget(text, source); });
}

namespace {

CalibrationTarget ParseTarget(const std::string& text, const std::string& source) {
  const YAML::Node root = LoadYaml(text, source);
  const YamlCtx ctx{source, ""};
  const std::string type = String(Require(root, "type", ctx), ctx.Sub("type"));
  try {
    if (type == "checkerboard") {
      RejectUnknownKeys(root, {"type", "cols", "rows", "square_mm", "border_mm"}, ctx);
      CheckerboardSpec s;
      s.cols = Integer(Require(root, "cols", ctx), ctx.Sub("cols"));
      s.rows = Integer(Require(root, "rows", ctx), ctx.Sub("rows"));
      s.square_m = Number(Require(root, "square_mm", ctx), ctx.Sub("square_mm")) * kMm;
      s.border_m = NumberOr(root, "border_mm", s.square_m / kMm, ctx) * kMm;
      return CalibrationTarget::Checkerboard(s);
    }
    if (type == "aprilgrid") {
      RejectUnknownKeys(root, {"type", "tag_cols", "tag_rows", "tag_size_mm", "tag_spacing", "first_id", "border_mm",
                               "corner_squares", "family"}, ctx);
      if (Has(root, "family") && String(root["family"], ctx.Sub("family")) != "tag36h11")
        ctx.Sub("family").Fail(root["family"], "only tag36h11 is supported");
      AprilGridSpec s;
      s.tag_cols = Integer(Require(root, "tag_cols", ctx), ctx.Sub("tag_cols"));
      s.tag_rows = Integer(Require(root, "tag_rows", ctx), ctx.Sub("tag_rows"));
      s.tag_size_m = Number(Require(root, "tag_size_mm", ctx), ctx.Sub("tag_size_mm")) * kMm;
      s.tag_spacing = Number(Require(root, "tag_spacing", ctx), ctx.Sub("tag_spacing"));
      s.first_id = IntegerOr(root, "first_id", 0, ctx);
      s.border_m = NumberOr(root, "border_mm", s.border_m / kMm, ctx) * kMm;
      s.corner_squares = BooleanOr(root, "corner_squares", false, ctx);
      return CalibrationTarget::AprilGrid(s);
    }
  } catch (const std::invalid_argument& e) {
    throw UserError(source + ": " + e.what());
  }
  ctx.Sub("type").Fail(root["type"], "expected checkerboard or aprilgrid, got \"" + type + "\"");
}

}  // namespace

std::string FormatTargetYaml(const CalibrationTarget& target) {
  std::ostringstream o;
  o.precision(15);
  if (target.type() == TargetType::kCheckerboard) {
    const CheckerboardSpec& s = target.checkerboard();
    o << "type: checkerboard\ncols: " << s.cols << "\nrows: " << s.rows << "\nsquare_mm: " << s.square_m / kMm
      << "\nborder_mm: " << s.border_m / kMm << "\n";
  } else {
    const AprilGridSpec& s = target.aprilgrid();
    o << "type: aprilgrid\nfamily: tag36h11\ntag_cols: " << s.tag_cols << "\ntag_rows: " << s.tag_rows << "\ntag_size_mm: " << s.tag_size_m / kMm
      << "\ntag_spacing: " << s.tag_spacing << "\nfirst_id: " << s.first_id << "\nborder_mm: " << s.border_m / kMm
      << "\ncorner_squares: " << (s.corner_squares ? "true" : "false") << "\n";
  }
  return o.str();
}

CalibrationTarget ParseTargetSpec(const std::string& spec) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream in(spec);
  while (std::getline(in, part, ':')) parts.push_back(part);
  const auto bad = [&](const std::string& why) -> UserError {
    return UserError("--target \"" + OneLine(spec) + "\": " + OneLine(why) +
                     " (expected checkerboard:COLSxROWS:SQUARE_MM or aprilgrid:COLSxROWS:TAG_MM:SPACING[:FIRST_ID])");
  };
  if (parts.size() < 3) throw bad("too few fields");
  const std::size_t x = parts[1].find('x');
  int cols = 0, rows = 0;
  if (x == std::string::npos || !ParseInt(parts[1].substr(0, x), &cols) || !ParseInt(parts[1].substr(x + 1), &rows))
    throw bad("COLSxROWS is not two integers");
  double size_mm = 0;
  if (!ParseDouble(parts[2], &size_mm) || size_mm <= 0) throw bad("size is not a positive number");
  try {
    if (parts[0] == "checkerboard") {
      if (parts.size() != 3) throw bad("too many fields");
      CheckerboardSpec s;
      s.cols = cols;
      s.rows = rows;
      s.square_m = size_mm * kMm;
      s.border_m = s.square_m;
      return CalibrationTarget::Checkerboard(s);
    }
    if (parts[0] == "aprilgrid") {
      if (parts.size() < 4 || parts.size() > 5) throw bad("wrong number of fields");
      AprilGridSpec s;
      s.tag_cols = cols;
      s.tag_rows = rows;
      s.tag_size_m = size_mm * kMm;
      if (!ParseDouble(parts[3], &s.tag_spacing) || s.tag_spacing <= 0) throw bad("SPACING is not a positive number");
      if (parts.size() == 5 && !ParseInt(parts[4], &s.first_id)) throw bad("FIRST_ID is not an integer");
      return CalibrationTarget::AprilGrid(s);
    }
  } catch (const std::invalid_argument& e) {
    throw bad(e.what());
  }
  throw bad("unknown target type \"" + parts[0] + "\"");
}

std::vector<Eigen::Vector3d> TargetPoints(const CalibrationTarget& target) {
  std::vector<Eigen::Vector3d> pts(target.corners().size(), Eigen::Vector3d::Zero());
  for (const TargetCorner& c : target.corners()) pts.at(static_cast<std::size_t>(c.id)) = c.P_w;
  return pts;
}

std::vector<CornerRow> ParseCornersCsv(const std::string& text, const std::string& source, int num_ids) {
  // Header optional and cells trimmed, as corners CSVs have always been read.
  const CsvTable table =
      CsvTable::Parse(text, source, {.trim = true, .columns = "camera,image,corner,u_px,v_px", .header_optional = true});
  std::vector<CornerRow> rows;
  std::map<std::string, std::map<int, int>> line_of;  // "camera/image" -> corner id -> line
  for (std::size_t r = 0; r < table.size(); ++r) {
    const std::vector<std::string> f = {table.Cell(r, 0), table.Cell(r, 1), table.Cell(r, 2), table.Cell(r, 3),
                                        table.Cell(r, 4)};
    const int line_no = table.Line(r);
    const std::string where = source + ":" + std::to_string(line_no) + ": ";
    CornerRow row;
    row.camera = f[0];
    row.image = f[1];
    row.line = line_no;
    CornerObs& c = row.corner;
    if (!ParseInt(f[2], &c.id) || c.id < 0 || c.id >= num_ids)
      throw UserError(where + "corner id \"" + OneLine(f[2]) + "\" is not one of the target's 0.." +
                      std::to_string(num_ids - 1));
    for (int a = 0; a < 2; ++a)
      if (!ParseDouble(f[static_cast<std::size_t>(3 + a)], &c.uv[a]) || !std::isfinite(c.uv[a]))
        throw UserError(where + (a == 0 ? "u_px" : "v_px") + ": bad pixel coordinate \"" +
                        OneLine(f[static_cast<std::size_t>(3 + a)]) + "\"");
    const auto [it, fresh] = line_of[f[0] + "/" + f[1]].emplace(c.id, line_no);
    if (!fresh)
      throw UserError(where + "corner: id " + f[2] + " of " + OneLine(f[0] + "/" + f[1]) + " repeats line " +
                      std::to_string(it->second));
    rows.push_back(std::move(row));
  }
  return rows;
}

CalibDataset ReadCalibDataset(const std::filesystem::path& dir) {
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) throw UserError(dir.string() + ": not a dataset directory");
  CalibDataset ds;
  ds.dir = dir;
  const std::filesystem::path target_path = dir / "target.yaml";
  ds.target = ParseTargetYaml(ReadFile(target_path), target_path.string());
  ds.images = ReadImagesCsv(dir / "images.csv");
  for (DatasetImage& im : ds.images) {
    im.path = dir / "images" / im.camera / (im.image + ".pgm");
    if (!std::filesystem::is_regular_file(im.path, ec))
      throw UserError((dir / "images.csv").string() + ": image " + im.camera + "/" + im.image + ": no file " + im.path.string());
    if (std::find(ds.cameras.begin(), ds.cameras.end(), im.camera) == ds.cameras.end()) ds.cameras.push_back(im.camera);
  }
  if (ds.cameras.size() > static_cast<std::size_t>(limits::kMaxCameras))
    throw UserError((dir / "images.csv").string() + ": " + std::to_string(ds.cameras.size()) + " cameras, at most " +
                    std::to_string(limits::kMaxCameras));
  if (std::filesystem::is_regular_file(dir / "truth-rig.yaml", ec)) {
    ds.truth.rig = ReadRigYaml(dir / "truth-rig.yaml");
    ds.truth.has_rig = true;
  }
  if (std::filesystem::is_regular_file(dir / "truth.yaml", ec))
    CatchYamlErrors((dir / "truth.yaml").string(), [&] { ReadTruth(dir / "truth.yaml", &ds.truth); });
  return ds;
}

}  // namespace mfns::host
