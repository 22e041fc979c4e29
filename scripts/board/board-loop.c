// board-loop: frames into vivid's video output, out of its video capture (vivid's loopback;
// scripts/test-board.sh, docs/board.md). Built statically with the cross compiler; the guest
// has no v4l2-ctl. Both modes set the DMT DV timings of 1280x1024p60 on the instance's HDMI
// capture and output nodes and GREY 1280x1024 on the output; vivid's "Loop Video" control must
// be on.
//   board-loop check CAPTURE OUTPUT   streams a known pattern out (MMAP), captures and compares;
//                                     one line; exit 0 when a captured frame equals the pattern
//   board-loop feed CAPTURE OUTPUT FRAME.pgm
//                                     streams the PGM (1280x1024, 8-bit) out until SIGTERM, so
//                                     that whoever captures from CAPTURE (mfns-navd) gets it
//   board-loop sweep PERIOD_MS N CAPTURE OUTPUT DIR [CAPTURE OUTPUT DIR]...
//                                     frame sets DIR/000000.pgm..DIR/<N-1>.pgm, one per capture:
//                                     the captures run at PERIOD_MS (custom CVT timings, below);
//                                     each output holds a frame until its capture has taken one
//                                     frame of it, then the next (docs/board.md, "The sweep").
//                                     Prints "ready" once frame 0 is on every output, then a
//                                     "capture K SEQUENCE T_NS SET" line per capture it saw (K the
//                                     camera's place in the arguments); on SIGTERM one line per
//                                     camera; exit 0 when every frame set was captured on every
//                                     camera and every capture was one of them
#define _GNU_SOURCE  // sched_setaffinity, CPU_SET
#include <errno.h>
#include <fcntl.h>
#include <linux/v4l2-dv-timings.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#define kBuffers 4

static struct v4l2_buffer Buffer(enum v4l2_buf_type type, unsigned index) {  // an MMAP buffer
  struct v4l2_buffer b;
  memset(&b, 0, sizeof(b));
  b.type = type;
  b.memory = V4L2_MEMORY_MMAP;
  b.index = index;
  return b;
}

static int Fail(const char* what) {
  printf("board-loop: %s: %s\n", what, strerror(errno));
  return 1;
}

static unsigned char Pattern(unsigned x, unsigned y) { return (unsigned char)((x * 7u + y * 13u + (x * y >> 6)) & 0xffu); }

static const unsigned char* g_image;  // feed: the PGM's pixels; check: NULL (the pattern)

static int SetTimings(int fd, const char* which) {
  struct v4l2_dv_timings t = V4L2_DV_BT_DMT_1280X1024P60;
  if (ioctl(fd, VIDIOC_S_DV_TIMINGS, &t) < 0) return Fail(which);
  return 0;
}

// 1280x1024 progressive at about one frame per period_ms. vivid's HDMI capture takes its list of
// standard timings (all 24 Hz or faster) or timings that v4l2_detect_cvt() recognises as CVT
// from their total lines, line frequency and vsync width, and keeps the detected timings. CVT
// with reduced blanking v2 (vsync 8, HSYNC+ polarity) keeps the active width as given and needs
// 14 blanking lines: 1038 lines, 1360 pixels a line. On Debian's 6.1 kernel 100 ms is accepted
// and 250 ms refused (EINVAL), as a check that the detected timings are within vivid's limits
// (pixel clock at least 14 MHz: 14 MHz / 1360 / 1038 is 9.9 Hz) would do. Kernels without RB v2
// get plain CVT (vsync 7 is 5:4, 1280x1024; 1040 lines). The request's own pixel clock is the
// line frequency times a wide line (5840 pixels); the period comes out within 1 % of period_ms
// (the detected pixel clock is rounded); PeriodMs() reports it.
static int SetSlowTimings(int fd, unsigned period_ms) {
  for (int rb2 = 1; rb2 >= 0; --rb2) {
    struct v4l2_dv_timings t;
    memset(&t, 0, sizeof(t));
    t.type = V4L2_DV_BT_656_1120;
    t.bt.width = 1280;
    t.bt.height = 1024;
    t.bt.hfrontporch = 2560;  // the widest line v4l2_valid_dv_timings allows: 5840 pixels
    t.bt.hsync = 1000;
    t.bt.hbackporch = 1000;
    t.bt.polarities = rb2 ? V4L2_DV_HSYNC_POS_POL : V4L2_DV_VSYNC_POS_POL;
    t.bt.vsync = rb2 ? 8 : 7;
    t.bt.vfrontporch = rb2 ? 1 : 3;
    t.bt.vbackporch = rb2 ? 5 : 6;
    const unsigned lines = 1024 + t.bt.vfrontporch + t.bt.vsync + t.bt.vbackporch;
    const unsigned hfreq = (lines * 1000u + period_ms / 2) / period_ms;
    t.bt.pixelclock = (unsigned long long)hfreq * 5840u;
    t.bt.standards = V4L2_DV_BT_STD_CVT;
    if (ioctl(fd, VIDIOC_S_DV_TIMINGS, &t) == 0) return 0;
  }
  return Fail("S_DV_TIMINGS capture (CVT at the sweep's period)");
}

static double PeriodMs(int fd) {  // the capture's frame period as vivid streams it
  struct v4l2_streamparm p;
  memset(&p, 0, sizeof(p));
  p.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (ioctl(fd, VIDIOC_G_PARM, &p) < 0 || p.parm.capture.timeperframe.denominator == 0) return 0.0;
  return 1000.0 * p.parm.capture.timeperframe.numerator / p.parm.capture.timeperframe.denominator;
}

// GREY w x h, field none, no row padding; then `count` MMAP buffers mapped into maps/lengths.
static int GreyBuffers(int fd, enum v4l2_buf_type type, unsigned w, unsigned h, unsigned count, void** maps,
                       size_t* lengths) {
  struct v4l2_format f;
  memset(&f, 0, sizeof(f));
  f.type = type;
  f.fmt.pix.width = w;
  f.fmt.pix.height = h;
  f.fmt.pix.pixelformat = V4L2_PIX_FMT_GREY;
  f.fmt.pix.field = V4L2_FIELD_NONE;
  if (ioctl(fd, VIDIOC_S_FMT, &f) < 0) return Fail("S_FMT");
  if (f.fmt.pix.width != w || f.fmt.pix.height != h || f.fmt.pix.pixelformat != V4L2_PIX_FMT_GREY ||
      f.fmt.pix.bytesperline != w) {
    printf("board-loop: %s format set to %ux%u %.4s stride %u\n", type == V4L2_BUF_TYPE_VIDEO_OUTPUT ? "output" : "capture",
           f.fmt.pix.width, f.fmt.pix.height, (const char*)&f.fmt.pix.pixelformat, f.fmt.pix.bytesperline);
    return 1;
  }
  struct v4l2_requestbuffers r;
  memset(&r, 0, sizeof(r));
  r.count = count;
  r.type = type;
  r.memory = V4L2_MEMORY_MMAP;
  if (ioctl(fd, VIDIOC_REQBUFS, &r) < 0 || r.count != count) return Fail("REQBUFS");
  for (unsigned i = 0; i < count; ++i) {
    struct v4l2_buffer b = Buffer(type, i);
    if (ioctl(fd, VIDIOC_QUERYBUF, &b) < 0) return Fail("QUERYBUF");
    maps[i] = mmap(NULL, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, b.m.offset);
    if (maps[i] == MAP_FAILED) return Fail("mmap");
    lengths[i] = b.length;
  }
  return 0;
}

static int SetUp(int fd, enum v4l2_buf_type type, unsigned w, unsigned h, void** maps, size_t* lengths) {
  if (GreyBuffers(fd, type, w, h, kBuffers, maps, lengths) != 0) return 1;
  for (unsigned i = 0; i < kBuffers; ++i) {
    struct v4l2_buffer b = Buffer(type, i);
    if (type == V4L2_BUF_TYPE_VIDEO_OUTPUT) {
      unsigned char* p = maps[i];
      if (g_image != NULL) memcpy(p, g_image, (size_t)w * h);
      else
        for (unsigned y = 0; y < h; ++y)
          for (unsigned x = 0; x < w; ++x) p[y * w + x] = Pattern(x, y);
      b.bytesused = w * h;
    }
    if (ioctl(fd, VIDIOC_QBUF, &b) < 0) return Fail("QBUF");
  }
  int on = type;
  if (ioctl(fd, VIDIOC_STREAMON, &on) < 0) return Fail("STREAMON");
  return 0;
}

static int Requeue(int out, unsigned w, unsigned h) {  // output buffers the driver has shown
  struct pollfd p = {out, POLLOUT, 0};
  while (poll(&p, 1, 0) > 0 && (p.revents & POLLOUT)) {
    struct v4l2_buffer b = Buffer(V4L2_BUF_TYPE_VIDEO_OUTPUT, 0);
    if (ioctl(out, VIDIOC_DQBUF, &b) < 0) break;
    b.bytesused = w * h;
    if (ioctl(out, VIDIOC_QBUF, &b) < 0) return Fail("QBUF output");
  }
  return 0;
}

static unsigned char* ReadPgm(const char* path, unsigned w, unsigned h) {
  FILE* f = fopen(path, "rb");
  unsigned fw = 0, fh = 0, maxval = 0;
  if (f == NULL || fscanf(f, "P5 %u %u %u", &fw, &fh, &maxval) != 3 || fgetc(f) == EOF || fw != w || fh != h || maxval != 255) {
    printf("board-loop: %s: not an 8-bit %ux%u PGM\n", path, w, h);
    return NULL;
  }
  unsigned char* p = malloc((size_t)w * h);
  if (p == NULL || fread(p, 1, (size_t)w * h, f) != (size_t)w * h) {
    printf("board-loop: %s: short\n", path);
    return NULL;
  }
  fclose(f);
  return p;
}


#define kMaxCams 4
#define kMaxSets 200
#define kOutBuffers 3

static volatile sig_atomic_t g_stop;
static void OnTerm(int sig) { (void)sig; g_stop = 1; }

struct SweepCam {
  int index;                // its place in the arguments
  const char *cap_path, *out_path, *dir;
  int cap, out;
  void* maps[kOutBuffers];
  size_t lengths[kOutBuffers];
  int set_of[kOutBuffers];  // the frame set in each queued output buffer, -1: free
  int content[kOutBuffers]; // the frame set each output buffer holds (kept once released)
  int fifo[kOutBuffers];    // the queued output buffers, the shown one first
  int queued;
  int next;                 // the next frame set to queue
  uint64_t last_ns;         // the newest capture seen
  int captures[kMaxSets];   // captures of each frame set
  uint32_t seq[kMaxSets];   // the sequence number and stamp of its capture
  uint64_t t_ns[kMaxSets];
  int unknown;              // captures equal to none of the queued frame sets
  int has_buffers;          // navd's capture buffers exist (QUERYBUF answered at the last look)
  int waiting;              // captures seen that navd has not dequeued yet (DONE flag)
  int poll_error;           // the last poll of the capture said POLLERR (not streaming)
  const unsigned char* cap_maps[32];  // the capturing process's buffers, mapped read-only here
  size_t cap_lengths[32];
};

static int QueueSet(struct SweepCam* c, int set, unsigned w, unsigned h) {
  int i = kOutBuffers;  // the free buffer with the oldest frame set: the last one shown is kept
  for (int j = 0; j < kOutBuffers; ++j)
    if (c->set_of[j] < 0 && (i == kOutBuffers || c->content[j] < c->content[i])) i = j;
  if (i == kOutBuffers) {
    printf("board-loop: %s: no free output buffer\n", c->out_path);
    return 1;
  }
  char path[512];
  snprintf(path, sizeof(path), "%s/%06d.pgm", c->dir, set);
  unsigned char* img = ReadPgm(path, w, h);
  if (img == NULL) return 1;
  memcpy(c->maps[i], img, (size_t)w * h);
  free(img);
  struct v4l2_buffer b = Buffer(V4L2_BUF_TYPE_VIDEO_OUTPUT, (unsigned)i);
  b.bytesused = w * h;
  if (ioctl(c->out, VIDIOC_QBUF, &b) < 0) return Fail("QBUF output");
  c->set_of[i] = set;
  c->content[i] = set;
  c->fifo[c->queued++] = i;
  return 0;
}

// The output shows its first queued buffer; vivid releases it at an output frame (60 Hz) once
// another is queued. Released buffers are free again.
static int Shown(struct SweepCam* c) {
  for (;;) {
    struct v4l2_buffer b = Buffer(V4L2_BUF_TYPE_VIDEO_OUTPUT, 0);
    if (ioctl(c->out, VIDIOC_DQBUF, &b) < 0) {
      if (errno == EAGAIN) return 0;
      return Fail("DQBUF output");
    }
    if (c->queued == 0 || c->fifo[0] != (int)b.index) {
      printf("board-loop: %s: output buffer %u released out of order\n", c->out_path, b.index);
      return 1;
    }
    c->set_of[b.index] = -1;
    memmove(c->fifo, c->fifo + 1, sizeof(int) * (size_t)(--c->queued));
  }
}

// New captures on CAPTURE since the last look, from the driver's bookkeeping of the capturing
// process's buffers: QUERYBUF and mmap are allowed on any file handle (vb2 reserves only
// REQBUFS, QBUF, DQBUF and STREAMON to the queue's owner), and a buffer filled since carries a
// later stamp and its sequence number. Each is then compared, pixel for pixel, with the frame
// sets in the output buffers: the frame set the capture took. The stamp lasts only until navd
// queues the buffer again (vb2 zeroes a capture buffer's timestamp at QBUF): the window is
// navd's DQBUF, detection and QBUF of that camera, a few ms. Sweep() therefore waits in poll()
// on the capture nodes too, and wakes when the driver hands a buffer over, before navd (on the
// same CPU, below this process's SCHED_FIFO) can dequeue it.
static int NewCaptures(struct SweepCam* c, unsigned w, unsigned h, int* newest_set) {
  int fresh = 0;
  uint64_t newest = c->last_ns;
  *newest_set = -1;
  c->has_buffers = 0;
  c->waiting = 0;
  for (unsigned i = 0; i < 32; ++i) {
    struct v4l2_buffer b = Buffer(V4L2_BUF_TYPE_VIDEO_CAPTURE, i);
    if (ioctl(c->cap, VIDIOC_QUERYBUF, &b) < 0) break;  // no (more) buffers: not streaming yet
    c->has_buffers = 1;
    const uint64_t t = (uint64_t)b.timestamp.tv_sec * 1000000000ull + (uint64_t)b.timestamp.tv_usec * 1000ull;
    if (t <= c->last_ns) {
      c->waiting += t != 0 && (b.flags & V4L2_BUF_FLAG_DONE) != 0;
      continue;
    }
    c->waiting += (b.flags & V4L2_BUF_FLAG_DONE) != 0;
    ++fresh;
    if (c->cap_maps[i] == NULL) {
      void* m = mmap(NULL, b.length, PROT_READ, MAP_SHARED, c->cap, b.m.offset);
      if (m == MAP_FAILED) return -Fail("mmap capture");
      c->cap_maps[i] = m;
      c->cap_lengths[i] = b.length;
    }
    int set = -1;
    for (int q = 0; q < kOutBuffers && set < 0; ++q)  // the one shown, the next, the one before
      if (c->content[q] >= 0 && memcmp(c->cap_maps[i], c->maps[q], (size_t)w * h) == 0) set = c->content[q];
    printf("capture %d %u %llu %d\n", c->index, b.sequence, (unsigned long long)t, set);
    if (set < 0) {
      ++c->unknown;
    } else {
      if (c->captures[set] == 0) {
        c->seq[set] = b.sequence;
        c->t_ns[set] = t;
      }
      ++c->captures[set];
    }
    if (t > newest) {
      newest = t;
      *newest_set = set;
    }
  }
  c->last_ns = newest;
  return fresh;
}

// Sleeps until a capture node has a buffer for navd (POLLIN: vb2 lets any handle poll) or 4 ms
// have passed (the outputs' releases, cameras not polled). A camera is polled only while navd's
// buffers exist (a poll of a queue without buffers would start vb2's read emulation on this
// handle and take the camera from navd), not when the last poll said POLLERR (streaming
// stopped or not started: it would return at once; polled again after one timeout), and not
// while a capture already seen waits for navd's DQBUF (poll would return at once until then;
// looked at every 1 ms instead, well within navd's DQBUF, detection and QBUF of the next one).
static void WaitForCaptures(struct SweepCam* cams, int ncams) {
  struct pollfd p[kMaxCams];
  int which[kMaxCams], np = 0, waiting = 0;
  for (int k = 0; k < ncams; ++k) {
    struct SweepCam* c = &cams[k];
    waiting += c->waiting > 0;
    if (c->has_buffers && !c->waiting && !c->poll_error) {
      p[np].fd = c->cap;
      p[np].events = POLLIN;
      p[np].revents = 0;
      which[np++] = k;
    }
    c->poll_error = 0;
  }
  if (poll(p, (nfds_t)np, waiting ? 1 : 4) <= 0) return;
  for (int i = 0; i < np; ++i)
    if (p[i].revents & (POLLERR | POLLHUP | POLLNVAL)) cams[which[i]].poll_error = 1;
}

static int Sweep(int argc, char** argv) {
  const unsigned w = 1280, h = 1024;
  const long period_ms = strtol(argv[2], NULL, 10), n = strtol(argv[3], NULL, 10);
  const int ncams = (argc - 4) / 3;
  if (period_ms < 50 || period_ms > 100 || n < 1 || n > kMaxSets || ncams < 1 || ncams > kMaxCams ||
      (argc - 4) % 3 != 0) {
    printf("board-loop: sweep: PERIOD_MS 50..100, N 1..%d, 1..%d CAPTURE OUTPUT DIR triples\n", kMaxSets,
           kMaxCams);
    return 1;
  }
  static struct SweepCam cams[kMaxCams];
  for (int k = 0; k < ncams; ++k) {
    struct SweepCam* c = &cams[k];
    memset(c, 0, sizeof(*c));
    c->index = k;
    c->cap_path = argv[4 + 3 * k];
    c->out_path = argv[5 + 3 * k];
    c->dir = argv[6 + 3 * k];
    c->cap = open(c->cap_path, O_RDWR | O_NONBLOCK);
    c->out = open(c->out_path, O_RDWR | O_NONBLOCK);
    if (c->cap < 0 || c->out < 0) return Fail("open");
    if (SetSlowTimings(c->cap, (unsigned)period_ms) != 0 || SetTimings(c->out, "S_DV_TIMINGS output") != 0)
      return 1;
    if (GreyBuffers(c->out, V4L2_BUF_TYPE_VIDEO_OUTPUT, w, h, kOutBuffers, c->maps, c->lengths) != 0) return 1;
    for (unsigned i = 0; i < kOutBuffers; ++i) c->set_of[i] = c->content[i] = -1;
    // vivid starts an output stream with two buffers queued: frame set 0 twice.
    if (QueueSet(c, 0, w, h) != 0 || QueueSet(c, 0, w, h) != 0) return 1;
    int on = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    if (ioctl(c->out, VIDIOC_STREAMON, &on) < 0) return Fail("STREAMON output");
    c->next = 1;
  }
  signal(SIGTERM, OnTerm);
  // Ahead of navd, on its CPU (checks.sh runs navd with taskset 1): whenever navd runs, this
  // polls within 4 ms of that CPU's time, so it sees every capture navd dequeues before navd
  // can have it refilled or, at the end, exit and free it, however long the host stalls a
  // vCPU. A frame set captured again is one whose capture came before the next was shown
  // (vivid catching up after a stall of the whole board).
  cpu_set_t cpu0;
  CPU_ZERO(&cpu0);
  CPU_SET(0, &cpu0);
  if (sched_setaffinity(0, sizeof(cpu0), &cpu0) != 0) printf("board-loop: not on CPU 0: %s\n", strerror(errno));
  struct sched_param sp = {.sched_priority = 10};
  if (sched_setscheduler(0, SCHED_FIFO, &sp) != 0) printf("board-loop: no SCHED_FIFO: %s\n", strerror(errno));
  printf("board-loop: ready: frame set 0 of %ld on %d outputs; capture periods", n, ncams);
  for (int k = 0; k < ncams; ++k) printf(" %.3f", PeriodMs(cams[k].cap));
  printf(" ms\n");
  fflush(stdout);
  while (!g_stop) {
    WaitForCaptures(cams, ncams);
    for (int k = 0; k < ncams; ++k) {
      struct SweepCam* c = &cams[k];
      if (Shown(c) != 0) return 1;
      int newest_set = -1;
      const int fresh = NewCaptures(c, w, h, &newest_set);
      if (fresh < 0) return 1;
      // The newest queued frame set has been captured: the next one goes out.
      if (fresh > 0 && newest_set >= 0 && newest_set == c->next - 1 && c->next < n) {
        if (QueueSet(c, c->next, w, h) != 0) return 1;
        ++c->next;
      }
    }
  }
  // Done: what each capture took, and the capture node back at 60 Hz for whoever comes next.
  int ok = 1;
  for (int k = 0; k < ncams; ++k) {
    struct SweepCam* c = &cams[k];
    int once = 0, twice = 0, missed = 0;
    double dmin = 1e30, dmax = 0.0;
    for (int i = 0; i < n; ++i) {
      once += c->captures[i] == 1;
      twice += c->captures[i] > 1;
      missed += c->captures[i] == 0;
      if (i > 0 && c->captures[i] > 0 && c->captures[i - 1] > 0) {
        const double d = (double)(c->t_ns[i] - c->t_ns[i - 1]) / 1e6;
        if (d < dmin) dmin = d;
        if (d > dmax) dmax = d;
      }
    }
    const int good = missed == 0 && c->unknown == 0;
    ok = ok && good;
    printf("board-loop: %s %s: %d of %ld frame sets captured once (sequences %u..%u), %d more than once (the "
           "last stays shown after the sweep), %d never, %d captures equal to none; ",
           good ? "ok" : "bad", c->cap_path, once, n, c->seq[0], c->seq[n - 1], twice, missed, c->unknown);
    if (dmin <= dmax) printf("%.1f-%.1f ms apart\n", dmin, dmax);
    else printf("no two consecutive frame sets captured\n");
    int off = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    ioctl(c->out, VIDIOC_STREAMOFF, &off);
    close(c->out);
    for (int i = 0; i < 32; ++i)
      if (c->cap_maps[i] != NULL) munmap((void*)c->cap_maps[i], c->cap_lengths[i]);
    // A fresh handle: should a poll after navd's exit have started vb2's read emulation on
    // this one (see WaitForCaptures), closing it ends that, and the timings can be set.
    close(c->cap);
    c->cap = open(c->cap_path, O_RDWR | O_NONBLOCK);
    if (c->cap < 0 || SetTimings(c->cap, "S_DV_TIMINGS capture (back to 60 Hz)") != 0) ok = 0;
    if (c->cap >= 0) close(c->cap);
  }
  return ok ? 0 : 1;
}

int main(int argc, char** argv) {
  if (argc >= 7 && strcmp(argv[1], "sweep") == 0) return Sweep(argc, argv);
  const int feed = argc == 5 && strcmp(argv[1], "feed") == 0;
  if (!feed && !(argc == 4 && strcmp(argv[1], "check") == 0)) {
    printf("usage: board-loop check CAPTURE OUTPUT | board-loop feed CAPTURE OUTPUT FRAME.pgm |\n"
           "       board-loop sweep PERIOD_MS N CAPTURE OUTPUT DIR [CAPTURE OUTPUT DIR]...\n");
    return 1;
  }
  const unsigned w = 1280, h = 1024;
  const int cap = open(argv[2], O_RDWR), out = open(argv[3], O_RDWR);
  if (cap < 0 || out < 0) return Fail("open");
  if (SetTimings(cap, "S_DV_TIMINGS capture") != 0 || SetTimings(out, "S_DV_TIMINGS output") != 0) return 1;
  void* out_maps[kBuffers];
  void* cap_maps[kBuffers];
  size_t out_len[kBuffers], cap_len[kBuffers];
  if (feed) {
    g_image = ReadPgm(argv[4], w, h);
    if (g_image == NULL) return 1;
    close(cap);  // the capture node is navd's
    if (SetUp(out, V4L2_BUF_TYPE_VIDEO_OUTPUT, w, h, out_maps, out_len) != 0) return 1;
    printf("board-loop: feeding %s to %s\n", argv[4], argv[3]);
    fflush(stdout);
    for (;;) {
      if (Requeue(out, w, h) != 0) return 1;
      usleep(5000);
    }
  }
  if (SetUp(out, V4L2_BUF_TYPE_VIDEO_OUTPUT, w, h, out_maps, out_len) != 0) return 1;
  if (SetUp(cap, V4L2_BUF_TYPE_VIDEO_CAPTURE, w, h, cap_maps, cap_len) != 0) return 1;
  long best = -1;
  int frames = 0;
  for (int n = 0; n < 30; ++n) {
    if (Requeue(out, w, h) != 0) return 1;
    struct pollfd c = {cap, POLLIN, 0};
    if (poll(&c, 1, 2000) <= 0) return Fail("poll capture");
    struct v4l2_buffer b = Buffer(V4L2_BUF_TYPE_VIDEO_CAPTURE, 0);
    if (ioctl(cap, VIDIOC_DQBUF, &b) < 0) return Fail("DQBUF capture");
    ++frames;
    const unsigned char* q = cap_maps[b.index];
    long bad = 0;
    for (unsigned y = 0; y < h; ++y)
      for (unsigned x = 0; x < w; ++x) bad += q[y * w + x] != Pattern(x, y);
    if (best < 0 || bad < best) best = bad;
    if (ioctl(cap, VIDIOC_QBUF, &b) < 0) return Fail("QBUF capture");
    if (bad == 0 && n >= 3) break;
  }
  printf("%s -> %s GREY %ux%u: %s after %d captured frames (fewest differing pixels %ld of %u)\n", argv[3], argv[2], w, h,
         best == 0 ? "pixel-exact" : "NOT looped", frames, best, w * h);
  return best == 0 ? 0 : 1;
}
