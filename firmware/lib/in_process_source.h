// A frame source fed by its caller (tests, the simulator): the caller pushes per-camera frames
// (pixel pointer, size, stride, format, timestamp, sequence) or scripted outcomes, and Acquire
// hands them out in order, as a driver would. FrameSource's contract applies
// (firmware/lib/frame_source.h).
//
// Each camera has a fixed queue of limits::kMaxCaptureBuffers entries (no heap). Acquire never
// waits: an empty queue is kTimeout, or kEndOfStream once Close() was called. Pushed pixels
// are owned by the caller and must stay valid until the frame is released.
#pragma once

#include <array>

#include "common/limits.h"
#include "firmware/lib/frame_source.h"

namespace mfns::fw {

class InProcessSource final : public FrameSource {
 public:
  explicit InProcessSource(int num_cameras);

  // Queues a frame for `camera`. frame.camera is overwritten with `camera`; sequence gaps
  // between pushed frames count as drops, as for a driver. False (nothing queued) when the
  // camera index is bad, the queue is full, or the frame is empty (null data, size <= 0,
  // stride below width * bytes per pixel).
  bool Push(int camera, const FrameView& frame);
  // Queues an outcome other than kOk (kTimeout, kDropped, kMissingFrame, kBadFrame, kError) for
  // `camera`; Acquire returns it in turn and counts it as the matching driver failure. False
  // for kOk, other statuses, a bad camera or a full queue.
  bool PushStatus(int camera, SourceStatus status);
  // After the queued entries drain, Acquire returns kEndOfStream.
  void Close() { closed_ = true; }

  // Push, PushStatus and Close may come before Start. Start keeps queued entries and zeroes
  // the counters.
  SourceStatus Start() override;
  SourceStatus Acquire(int camera, int timeout_ms, FrameView* out) override;
  void Release(int camera) override;
  SourceStatus Reset(int camera) override;  // drops camera's queued entries
  void Stop() override;

 private:
  struct Entry {
    SourceStatus status = SourceStatus::kOk;
    FrameView frame;
  };
  struct Queue {
    std::array<Entry, limits::kMaxCaptureBuffers> entries{};
    int head = 0;
    int size = 0;
    bool held = false;
    SequenceTracker sequence;
  };
  bool Enqueue(int camera, const Entry& e);

  bool started_ = false;
  bool closed_ = false;
  std::array<Queue, limits::kMaxCameras> queues_{};
};

}  // namespace mfns::fw
