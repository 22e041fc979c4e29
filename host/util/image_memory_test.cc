// KeepImageBuffers: a 24 MiB block, which glibc maps afresh by default (above its 128 KiB
// initial mmap threshold), comes from the heap after the call, and freeing it keeps it there.
#include "host/util/image_memory.h"

#include <gtest/gtest.h>
#include <malloc.h>

#include <cstdlib>
#include <cstring>

namespace mfns::host {
namespace {

std::size_t MappedBytes() { return mallinfo2().hblkhd; }

void* TouchedBlock(std::size_t n) {  // written, so that the allocation cannot be dropped
  void* p = std::malloc(n);
  if (p != nullptr) std::memset(p, 1, n);
  return p;
}

TEST(KeepImageBuffers, BigBlocksComeFromTheHeapAndStayAfterFree) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "ASan's allocator replaces glibc's (mallopt and mallinfo2 say nothing of it)";
#endif
  constexpr std::size_t kBlock = 24u << 20;
  // glibc's default, in this process that has freed no mapped block yet (a free would raise
  // its dynamic threshold): a mapping of its own. Kept until the end for that reason.
  const std::size_t mapped0 = MappedBytes();
  void* before = TouchedBlock(kBlock);
  ASSERT_NE(before, nullptr);
  EXPECT_GE(MappedBytes(), mapped0 + kBlock);

  ASSERT_TRUE(KeepImageBuffers());
  EXPECT_TRUE(KeepImageBuffers());  // idempotent
  const std::size_t mapped1 = MappedBytes();
  void* after = TouchedBlock(kBlock);
  ASSERT_NE(after, nullptr);
  EXPECT_LT(MappedBytes(), mapped1 + kBlock);  // from the heap
  std::free(after);
  EXPECT_GE(mallinfo2().arena, kBlock);  // freed, it stays in the process (no trim below 512 MiB)
  std::free(before);
}

}  // namespace
}  // namespace mfns::host
