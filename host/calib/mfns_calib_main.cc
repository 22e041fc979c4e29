// mfns-calib: calibration tools (DESIGN.md, "User-facing interfaces").
//   mfns-calib blob RIG.yaml --out FILE [--generation N]   rig file -> parameter blob
//   mfns-calib inspect BLOB                                 print a blob's header and contents
//   mfns-calib paper-rig --out FILE                         write the published rig (Tables 2-4)
//   mfns-calib rig DATASET_DIR --out DIR [--method ml|paper|opencv-handeye]   (app/calib_commands.h)
//   mfns-calib intrinsics --target checkerboard:COLSxROWS:SQUARE_MM IMAGE... --out DIR
//   mfns-calib survey --rig RIG.yaml --out DIR RECORDING...   refined beacon map (survey/survey_command.h)
// Exit 0 on success, 1 on a user error with a one-line reason on stderr.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "common/blob/param_blob.h"
#include "common/rig/infer_facing.h"
#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "firmware/modules/identify/map_repeats.h"
#include "host/calib/app/calib_commands.h"
#include "host/calib/survey/survey_command.h"
#include "host/rigio/rig_yaml.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

// The map check mfns-navd makes at start (its facing inferred the same way when the file has
// none), told before the blob is flashed: a warning, the blob is written all the same.
void WarnIfMapRepeats(const std::string& rig_path, Rig rig) {
  if (!rig.has_facing) InferFacing(InferFacingOptions{}, &rig);
  fw::MapRepeatsResult r;
  char line[512];
  if (fw::FindMapRepeats(rig, fw::MapRepeatsOptions{}, &r) && fw::DescribeMapRepeats(r, line, sizeof(line)))
    std::fprintf(stderr, "mfns-calib: warning: %s: %s\n", rig_path.c_str(), line);
}

void MakeBlob(const std::string& rig_path, const std::string& out_path, std::uint64_t generation) {
  const Rig rig = ReadRigYaml(rig_path);
  // A blob mfns-navd cannot navigate with would only fail on the flyer, after the flash.
  if (rig.num_beacons < limits::kMinNavBeacons) {
    throw UserError(rig_path + ": beacons_mm: " + std::to_string(rig.num_beacons) + " beacons; mfns-navd needs at least " +
                    std::to_string(limits::kMinNavBeacons) + " to navigate, no blob written");
  }
  std::vector<std::uint8_t> bytes(limits::kMaxBlobBytes);
  std::size_t written = 0;
  const BlobStatus s = EncodeParamBlob(rig, generation, bytes, &written);
  if (s != BlobStatus::kOk) throw UserError(rig_path + ": cannot encode: " + ToString(s));
  bytes.resize(written);
  WriteFileAtomic(out_path, bytes);
  std::fprintf(stderr, "mfns-calib: wrote %s (%zu bytes, rig %s, generation %llu)\n", out_path.c_str(), written,
               rig.rig_id.data(), static_cast<unsigned long long>(generation));
  WarnIfMapRepeats(rig_path, rig);
}

void Inspect(const std::string& blob_path) {
  const std::string data = ReadFile(blob_path, limits::kMaxBlobBytes);
  const std::span<const std::uint8_t> bytes(reinterpret_cast<const std::uint8_t*>(data.data()), data.size());
  Rig rig;
  BlobInfo info;
  const BlobStatus s = DecodeParamBlob(bytes, nullptr, &rig, &info);
  if (s != BlobStatus::kOk) throw UserError(blob_path + ": invalid blob: " + ToString(s));
  std::printf("blob %s: format v%u, rig %s, generation %llu, %zu bytes, payload crc32 %08x\n", blob_path.c_str(),
              info.format_version, info.rig_id.data(), static_cast<unsigned long long>(info.generation), data.size(),
              info.payload_crc32);
  for (int i = 0; i < rig.num_cameras; ++i) {
    const RigCamera& c = rig.cameras[static_cast<std::size_t>(i)];
    const EulerAngles e = MatrixToEuler(c.C_k_b);
    std::printf("  camera %-3s %dx%d alpha (%.3f, %.3f) pp (%.3f, %.3f) euler_deg (%.4f, %.4f, %.4f) r_b_bk_mm (%.3f, %.3f, %.3f)\n",
                c.name.data(), c.intrinsics.width, c.intrinsics.height, c.intrinsics.alpha_x, c.intrinsics.alpha_y,
                c.intrinsics.u0, c.intrinsics.v0, RadToDeg(e.phi), RadToDeg(e.theta), RadToDeg(e.psi),
                c.r_b_bk.x() * 1e3, c.r_b_bk.y() * 1e3, c.r_b_bk.z() * 1e3);
  }
  std::printf("  beacons %d (1-sigma %.4f mm%s), sigma %s, facing %s\n", rig.num_beacons, rig.beacon_sigma * 1e3,
              rig.has_beacon_sigmas ? " at most: one per beacon" : "", rig.has_sigma ? "present" : "absent",
              rig.has_facing ? "present" : "absent");
}

std::uint64_t NowSeconds() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

int Run(int argc, char** argv) {
  CLI::App app;
  CalibCommandLine cl;
  try {
    ParseCalibCommandLine(app, argc, argv, &cl);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 1;
  }
  if (cl.command == "blob") MakeBlob(cl.rig_path, cl.out_path, cl.generation_set ? cl.generation : NowSeconds());
  if (cl.command == "inspect") Inspect(cl.blob_path);
  if (cl.command == "paper-rig") WriteRigYaml(cl.out_path, PaperRig());
  if (cl.command == "rig") RunRigCommand(cl.rig, std::cerr);
  if (cl.command == "intrinsics") RunIntrinsicsCommand(cl.intrinsics, std::cerr);
  if (cl.command == "survey") {
    for (int i = 0; i < argc; ++i) cl.survey.command_line += (i == 0 ? "" : " ") + std::string(argv[i]);
    RunSurveyCommand(cl.survey, std::cerr);
  }
  return 0;
}

}  // namespace
}  // namespace mfns::host

int main(int argc, char** argv) {
  try {
    return mfns::host::Run(argc, argv);
  } catch (const std::exception& e) {
    // One line even for library errors (cv::Exception's what() spans several).
    std::string what = e.what();
    while (!what.empty() && (what.back() == '\n' || what.back() == ' ')) what.pop_back();
    for (char& c : what)
      if (c == '\n' || c == '\r') c = ' ';
    std::fprintf(stderr, "mfns-calib: %s\n", what.c_str());
    return 1;
  }
}
