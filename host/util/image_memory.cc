#include "host/util/image_memory.h"

#include <malloc.h>

#include <mutex>

namespace mfns::host {

bool KeepImageBuffers() {
  static std::once_flag once;
  static bool ok = false;
  std::call_once(once, [] {
    constexpr int kMmapThreshold = 32 << 20;  // glibc's maximum (HEAP_MAX_SIZE / 2 on 64-bit)
    constexpr int kTrimThreshold = 512 << 20;
    ok = mallopt(M_MMAP_THRESHOLD, kMmapThreshold) == 1 && mallopt(M_TRIM_THRESHOLD, kTrimThreshold) == 1;
  });
  return ok;
}

}  // namespace mfns::host
