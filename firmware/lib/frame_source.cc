#include "firmware/lib/frame_source.h"

namespace mfns::fw {

const char* ToString(SourceStatus s) {
  switch (s) {
    case SourceStatus::kOk: return "ok";
    case SourceStatus::kTimeout: return "timeout";
    case SourceStatus::kDropped: return "dropped";
    case SourceStatus::kMissingFrame: return "missing frame";
    case SourceStatus::kBadFrame: return "bad frame";
    case SourceStatus::kError: return "driver error";
    case SourceStatus::kEndOfStream: return "end of stream";
    case SourceStatus::kNotStarted: return "not started";
    case SourceStatus::kBadCamera: return "bad camera index";
    case SourceStatus::kBusy: return "frame still held";
    case SourceStatus::kBadConfig: return "bad configuration";
    case SourceStatus::kOpenFailed: return "open failed";
    case SourceStatus::kNotCapture: return "not a streaming capture device";
    case SourceStatus::kFormatRefused: return "size or format refused";
    case SourceStatus::kNoBuffers: return "buffer setup failed";
    case SourceStatus::kStreamFailed: return "stream start failed";
  }
  return "unknown";
}

void SequenceTracker::Observe(std::uint32_t sequence, SourceCounters* counters) {
  if (has_last_) {
    // Unsigned difference: correct across the 2^32 wrap. A "gap" of more than 2^31 frames is a
    // step backwards (the driver restarted its counter), not ~4e9 lost frames.
    const std::uint32_t gap = sequence - last_ - 1U;
    if (gap < 0x80000000U) {
      counters->drops += gap;
    } else {
      ++counters->sequence_resets;
    }
  }
  has_last_ = true;
  last_ = sequence;
}

FrameSource::FrameSource(int num_cameras)
    : num_cameras_(num_cameras < 0 ? 0
                   : num_cameras > limits::kMaxCameras ? limits::kMaxCameras
                                                       : num_cameras) {}

const SourceCounters& FrameSource::counters(int camera) const {
  static const SourceCounters kZero{};
  return ValidCamera(camera) ? counters_[static_cast<unsigned>(camera)] : kZero;
}

}  // namespace mfns::fw
