// Images of the simulator and their file format (DESIGN.md, "Frames on disk").
//
// An image is a cv::Mat, always single-channel and continuous:
//   CV_8UC1  mono8  (digital numbers 0..255),
//   CV_16UC1 mono16 (digital numbers 0..65535),
//   CV_64FC1 a "signal" image: expected photo-electrons per pixel before the sensor
//            (sensor.h turns it into mono8/mono16).
// Pixel (u, v) = (column, row) is centred at integer coordinates (OpenCV's and the camera
// model's convention), so pixel u covers [u - 0.5, u + 0.5].
//
// Files are binary PGM (netpbm "P5"): mono8 is written with maxval 255, mono16 with maxval
// 65535 and two bytes per sample, most significant byte first (the PGM specification).
#pragma once

#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>

namespace mfns::host {

// Every PGM read or write failure (I/O error, malformed or unsupported file).
class PgmError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// True for the two image types the simulator writes (CV_8UC1, CV_16UC1), non-empty.
bool IsMonoImage(const cv::Mat& image);

// Writes a CV_8UC1 or CV_16UC1 image to `path` atomically: the bytes go to a temporary file in
// the same directory that is renamed over `path`, so a reader never sees a partial file. The
// image may be non-continuous (a ROI). Throws PgmError (wrong type, I/O failure); on failure
// `path` is untouched and no temporary file is left behind.
void WritePgm(const std::string& path, const cv::Mat& image);

// Encodes to / decodes from PGM bytes (the file contents of WritePgm / ReadPgm).
std::string EncodePgm(const cv::Mat& image);

// Decodes a single binary PGM image. Accepts header comments ('#' to end of line) and any
// maxval 1..65535: maxval <= 255 gives CV_8UC1, above gives CV_16UC1 (samples kept as stored,
// not rescaled). Rejects with PgmError: a magic other than "P5", missing or non-numeric
// fields, width/height outside 1..65535 or above 2^28 pixels, maxval 0 or > 65535, no single
// whitespace after maxval, a truncated raster, a sample above maxval, and trailing bytes
// after the raster (MFNS files hold one image).
cv::Mat DecodePgm(const std::string& bytes);

// Reads and decodes `path`; throws PgmError when it cannot be read or is malformed.
cv::Mat ReadPgm(const std::string& path);

}  // namespace mfns::host
