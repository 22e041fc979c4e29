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
#include <errno.h>
#include <fcntl.h>
#include <linux/v4l2-dv-timings.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#define kBuffers 4

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

static int SetUp(int fd, enum v4l2_buf_type type, unsigned w, unsigned h, void** maps, size_t* lengths) {
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
  r.count = kBuffers;
  r.type = type;
  r.memory = V4L2_MEMORY_MMAP;
  if (ioctl(fd, VIDIOC_REQBUFS, &r) < 0 || r.count != kBuffers) return Fail("REQBUFS");
  for (unsigned i = 0; i < kBuffers; ++i) {
    struct v4l2_buffer b;
    memset(&b, 0, sizeof(b));
    b.type = type;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = i;
    if (ioctl(fd, VIDIOC_QUERYBUF, &b) < 0) return Fail("QUERYBUF");
    maps[i] = mmap(NULL, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, b.m.offset);
    if (maps[i] == MAP_FAILED) return Fail("mmap");
    lengths[i] = b.length;
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
    struct v4l2_buffer b;
    memset(&b, 0, sizeof(b));
    b.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    b.memory = V4L2_MEMORY_MMAP;
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

int main(int argc, char** argv) {
  const int feed = argc == 5 && strcmp(argv[1], "feed") == 0;
  if (!feed && !(argc == 4 && strcmp(argv[1], "check") == 0)) {
    printf("usage: board-loop check CAPTURE OUTPUT | board-loop feed CAPTURE OUTPUT FRAME.pgm\n");
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
    struct v4l2_buffer b;
    memset(&b, 0, sizeof(b));
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
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
