#include "firmware/lib/in_process_source.h"

namespace mfns::fw {

InProcessSource::InProcessSource(int num_cameras) : FrameSource(num_cameras) {}

bool InProcessSource::Enqueue(int camera, const Entry& e) {
  if (!ValidCamera(camera)) return false;
  Queue& q = queues_[static_cast<unsigned>(camera)];
  if (q.size >= limits::kMaxCaptureBuffers) return false;
  const int tail = (q.head + q.size) % limits::kMaxCaptureBuffers;
  q.entries[static_cast<unsigned>(tail)] = e;
  ++q.size;
  return true;
}

bool InProcessSource::Push(int camera, const FrameView& frame) {
  if (frame.data == nullptr || frame.width <= 0 || frame.height <= 0 ||
      frame.stride_bytes < frame.width * BytesPerPixel(frame.format)) {
    return false;
  }
  Entry e;
  e.frame = frame;
  e.frame.camera = camera;
  return Enqueue(camera, e);
}

bool InProcessSource::PushStatus(int camera, SourceStatus status) {
  switch (status) {
    case SourceStatus::kTimeout:
    case SourceStatus::kDropped:
    case SourceStatus::kMissingFrame:
    case SourceStatus::kBadFrame:
    case SourceStatus::kError:
      break;
    default:
      return false;
  }
  Entry e;
  e.status = status;
  return Enqueue(camera, e);
}

SourceStatus InProcessSource::Start() {
  for (Queue& q : queues_) {
    q.held = false;
    q.sequence.Reset();
  }
  ResetCounters();
  started_ = true;
  return SourceStatus::kOk;
}

SourceStatus InProcessSource::Acquire(int camera, int /*timeout_ms*/, FrameView* out) {
  if (!started_) return SourceStatus::kNotStarted;
  if (!ValidCamera(camera)) return SourceStatus::kBadCamera;
  Queue& q = queues_[static_cast<unsigned>(camera)];
  if (q.held) return SourceStatus::kBusy;
  SourceCounters& c = mutable_counters(camera);
  if (q.size == 0) {
    if (closed_) return SourceStatus::kEndOfStream;
    ++c.timeouts;
    return SourceStatus::kTimeout;
  }
  const Entry& e = q.entries[static_cast<unsigned>(q.head)];
  q.head = (q.head + 1) % limits::kMaxCaptureBuffers;
  --q.size;
  switch (e.status) {
    case SourceStatus::kOk:
      q.sequence.Observe(e.frame.sequence, &c);
      *out = e.frame;
      q.held = true;
      ++c.frames;
      break;
    case SourceStatus::kTimeout: ++c.timeouts; break;
    case SourceStatus::kDropped: ++c.error_buffers; break;
    case SourceStatus::kMissingFrame: ++c.missing_files; break;
    case SourceStatus::kBadFrame: ++c.bad_files; break;
    default: ++c.driver_errors; break;  // kError (PushStatus admits nothing else)
  }
  return e.status;
}

void InProcessSource::Release(int camera) {
  if (ValidCamera(camera)) queues_[static_cast<unsigned>(camera)].held = false;
}

SourceStatus InProcessSource::Reset(int camera) {
  if (!started_) return SourceStatus::kNotStarted;
  if (!ValidCamera(camera)) return SourceStatus::kBadCamera;
  queues_[static_cast<unsigned>(camera)] = Queue{};
  return SourceStatus::kOk;
}

void InProcessSource::Stop() {
  started_ = false;
  for (Queue& q : queues_) q.held = false;
}

}  // namespace mfns::fw
