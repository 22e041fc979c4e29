// board-ctl: set one V4L2 control by its name on the emulated board (scripts/test-board.sh,
// docs/board.md). The guest has no v4l2-ctl; this is built statically with the cross compiler.
//   board-ctl DEVICE 'Control Name' VALUE      VALUE: a number, or a menu item's name
// A button control (vivid's Disconnect) is pressed whatever VALUE is. Exits 0 when the driver
// took the value, 1 with a reason on stderr otherwise.
#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/ioctl.h>
#include <unistd.h>

static int Fail(const char* what, const char* arg) {
  fprintf(stderr, "board-ctl: %s %s: %s\n", what, arg, strerror(errno));
  return 1;
}

int main(int argc, char** argv) {
  if (argc != 4) {
    fprintf(stderr, "usage: board-ctl DEVICE 'Control Name' VALUE\n");
    return 1;
  }
  const int fd = open(argv[1], O_RDWR);
  if (fd < 0) return Fail("open", argv[1]);
  struct v4l2_query_ext_ctrl q;
  memset(&q, 0, sizeof(q));
  q.id = V4L2_CTRL_FLAG_NEXT_CTRL;
  int found = 0;
  while (ioctl(fd, VIDIOC_QUERY_EXT_CTRL, &q) == 0) {
    if (q.type != V4L2_CTRL_TYPE_CTRL_CLASS && strcasecmp(q.name, argv[2]) == 0) {
      found = 1;
      break;
    }
    q.id |= V4L2_CTRL_FLAG_NEXT_CTRL;
  }
  if (!found) {
    fprintf(stderr, "board-ctl: %s has no control '%s'\n", argv[1], argv[2]);
    return 1;
  }
  char* end = NULL;
  long long value = strtoll(argv[3], &end, 0);
  if (*argv[3] == '\0' || *end != '\0') {  // a menu item's name
    if (q.type != V4L2_CTRL_TYPE_MENU) {
      fprintf(stderr, "board-ctl: '%s' is not a menu, '%s' not a number\n", argv[2], argv[3]);
      return 1;
    }
    found = 0;
    for (long long i = q.minimum; i <= q.maximum && !found; ++i) {
      struct v4l2_querymenu m;
      memset(&m, 0, sizeof(m));
      m.id = q.id;
      m.index = (unsigned)i;
      if (ioctl(fd, VIDIOC_QUERYMENU, &m) == 0 && strcasecmp((const char*)m.name, argv[3]) == 0) {
        value = i;
        found = 1;
      }
    }
    if (!found) {
      fprintf(stderr, "board-ctl: menu '%s' has no item '%s'\n", argv[2], argv[3]);
      return 1;
    }
  }
  if (q.type == V4L2_CTRL_TYPE_BUTTON) value = 1;
  struct v4l2_ext_control c;
  memset(&c, 0, sizeof(c));
  c.id = q.id;
  if (q.type == V4L2_CTRL_TYPE_INTEGER64) c.value64 = value;
  else c.value = (int)value;
  struct v4l2_ext_controls cs;
  memset(&cs, 0, sizeof(cs));
  cs.which = V4L2_CTRL_WHICH_CUR_VAL;
  cs.count = 1;
  cs.controls = &c;
  if (ioctl(fd, VIDIOC_S_EXT_CTRLS, &cs) < 0) return Fail("VIDIOC_S_EXT_CTRLS", argv[2]);
  close(fd);
  return 0;
}
