// LD_PRELOAD library: counts the malloc-family calls of a whole process (every thread, C and
// C++: operator new ends in malloc) and writes the counts at exit, so allocations after start
// can be measured from outside an unmodified program:
//
//   MFNS_MALLOC_COUNT_OUT=FILE LD_PRELOAD=build/<dir>/lib/libmfns_malloc_count.so mfns-navd ...
//
// FILE (default: stderr) receives one line "malloc_calls=N bytes=B" (malloc, calloc, realloc,
// aligned_alloc, posix_memalign, memalign, valloc, pvalloc; realloc(p, 0) and frees are not
// counted). Running the program for two lengths and dividing the difference of the counts by
// the difference of the frame sets gives the allocations per frame set after start.
// The wrappers forward to glibc's __libc_* entry points (no dlsym, so no bootstrap problem).
// Host measurement tool, not flight code.
#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>

extern "C" {
void* __libc_malloc(std::size_t n);
void* __libc_calloc(std::size_t count, std::size_t n);
void* __libc_realloc(void* p, std::size_t n);
void* __libc_memalign(std::size_t alignment, std::size_t n);
void* __libc_valloc(std::size_t n);
void* __libc_pvalloc(std::size_t n);
}

namespace {

std::atomic<unsigned long long> g_calls{0};
std::atomic<unsigned long long> g_bytes{0};

void Count(std::size_t n) {
  g_calls.fetch_add(1, std::memory_order_relaxed);
  g_bytes.fetch_add(n, std::memory_order_relaxed);
}

// Writes the counts with write(2) only (no stdio buffers allocated at exit).
__attribute__((destructor)) void Report() {
  char line[96];
  const int len = std::snprintf(line, sizeof(line), "malloc_calls=%llu bytes=%llu\n", g_calls.load(), g_bytes.load());
  if (len <= 0) return;
  const char* path = std::getenv("MFNS_MALLOC_COUNT_OUT");
  int fd = 2;
  if (path != nullptr && path[0] != '\0') fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return;
  const ssize_t written = write(fd, line, static_cast<std::size_t>(len));
  (void)written;
  if (fd != 2) close(fd);
}

}  // namespace

extern "C" {

void* malloc(std::size_t n) noexcept {
  Count(n);
  return __libc_malloc(n);
}

void* calloc(std::size_t count, std::size_t n) noexcept {
  Count(count * n);
  return __libc_calloc(count, n);
}

void* realloc(void* p, std::size_t n) noexcept {
  if (n != 0) Count(n);
  return __libc_realloc(p, n);
}

void* memalign(std::size_t alignment, std::size_t n) noexcept {
  Count(n);
  return __libc_memalign(alignment, n);
}

void* aligned_alloc(std::size_t alignment, std::size_t n) noexcept {
  Count(n);
  return __libc_memalign(alignment, n);
}

int posix_memalign(void** out, std::size_t alignment, std::size_t n) noexcept {
  if (alignment % sizeof(void*) != 0 || (alignment & (alignment - 1)) != 0) return 22;  // EINVAL
  Count(n);
  void* p = __libc_memalign(alignment, n);
  if (p == nullptr) return 12;  // ENOMEM
  *out = p;
  return 0;
}

void* valloc(std::size_t n) noexcept {
  Count(n);
  return __libc_valloc(n);
}

void* pvalloc(std::size_t n) noexcept {
  Count(n);
  return __libc_pvalloc(n);
}

}  // extern "C"
