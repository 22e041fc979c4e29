// board-now: CLOCK_MONOTONIC in nanoseconds (busybox's date has no %N). With QEMU's
// -icount shift=0 the guest's clock advances one nanosecond per instruction executed, so the
// difference of two readings counts instructions (scripts/test-board.sh --icount).
#include <stdio.h>
#include <time.h>

int main(void) {
  struct timespec t;
  if (clock_gettime(CLOCK_MONOTONIC, &t) != 0) return 1;
  printf("%lld\n", (long long)t.tv_sec * 1000000000LL + t.tv_nsec);
  return 0;
}
