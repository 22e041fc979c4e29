#include "host/flash/process.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "host/util/user_error.h"

namespace mfns::host {
namespace {

// Closes fd if open and marks it closed.
void CloseFd(int* fd) {
  if (*fd >= 0) ::close(*fd);
  *fd = -1;
}

// Ignores SIGPIPE while alive (a child that exits before reading its stdin must not kill us).
class IgnoreSigpipe {
 public:
  IgnoreSigpipe() {
    struct sigaction ign {};
    ign.sa_handler = SIG_IGN;
    sigemptyset(&ign.sa_mask);
    ::sigaction(SIGPIPE, &ign, &old_);
  }
  ~IgnoreSigpipe() { ::sigaction(SIGPIPE, &old_, nullptr); }
  IgnoreSigpipe(const IgnoreSigpipe&) = delete;
  IgnoreSigpipe& operator=(const IgnoreSigpipe&) = delete;

 private:
  struct sigaction old_ {};
};

}  // namespace

ProcessResult RunProcess(const std::vector<std::string>& argv, const std::vector<std::uint8_t>& stdin_bytes,
                         int timeout_s) {
  if (argv.empty()) throw UserError("no program to run");
  IgnoreSigpipe guard;
  int in[2], out[2], err[2], exec_err[2];
  if (::pipe2(in, O_CLOEXEC) != 0 || ::pipe2(out, O_CLOEXEC) != 0 || ::pipe2(err, O_CLOEXEC) != 0 ||
      ::pipe2(exec_err, O_CLOEXEC) != 0) {
    throw UserError(std::string("cannot create pipes: ") + std::strerror(errno));
  }
  std::vector<std::string> args = argv;
  std::vector<char*> cargv;
  for (auto& a : args) cargv.push_back(a.data());
  cargv.push_back(nullptr);

  const pid_t pid = ::fork();
  if (pid < 0) throw UserError(std::string("cannot fork: ") + std::strerror(errno));
  if (pid == 0) {
    ::dup2(in[0], 0);
    ::dup2(out[1], 1);
    ::dup2(err[1], 2);
    ::execvp(cargv[0], cargv.data());
    const int e = errno;  // exec failed: tell the parent through the close-on-exec pipe
    if (::write(exec_err[1], &e, sizeof e) < 0) {}
    ::_exit(127);
  }
  CloseFd(&in[0]);
  CloseFd(&out[1]);
  CloseFd(&err[1]);
  CloseFd(&exec_err[1]);
  int exec_errno = 0;
  const ssize_t got = ::read(exec_err[0], &exec_errno, sizeof exec_errno);  // EOF at a successful exec
  CloseFd(&exec_err[0]);
  if (got == static_cast<ssize_t>(sizeof exec_errno)) {
    ::waitpid(pid, nullptr, 0);
    CloseFd(&in[1]);
    CloseFd(&out[0]);
    CloseFd(&err[0]);
    throw UserError("cannot run " + argv[0] + ": " + std::strerror(exec_errno));
  }

  ProcessResult r;
  std::size_t written = 0;
  ::fcntl(in[1], F_SETFL, O_NONBLOCK);
  if (stdin_bytes.empty()) CloseFd(&in[1]);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_s);
  while (out[0] >= 0 || err[0] >= 0 || in[1] >= 0) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      r.timed_out = true;
      break;
    }
    pollfd fds[3] = {{out[0], POLLIN, 0}, {err[0], POLLIN, 0}, {in[1], POLLOUT, 0}};
    const int n = ::poll(fds, 3, static_cast<int>(std::min<long long>(left.count(), 1000)));  // NOLINT
    if (n < 0 && errno != EINTR) break;
    if (n <= 0) continue;
    for (int i = 0; i < 2; ++i) {
      if (fds[i].fd < 0 || fds[i].revents == 0) continue;
      char buf[4096];
      const ssize_t k = ::read(fds[i].fd, buf, sizeof buf);
      if (k > 0) {
        (i == 0 ? r.out : r.err).append(buf, static_cast<std::size_t>(k));
      } else if (k == 0 || errno != EINTR) {
        CloseFd(i == 0 ? &out[0] : &err[0]);
      }
    }
    if (in[1] >= 0 && fds[2].revents != 0) {
      const ssize_t k = ::write(in[1], stdin_bytes.data() + written, stdin_bytes.size() - written);
      if (k > 0) written += static_cast<std::size_t>(k);
      // Done, or the child closed its stdin (EPIPE): either way no more to write.
      if (written == stdin_bytes.size() || (k < 0 && errno != EAGAIN && errno != EINTR)) CloseFd(&in[1]);
    }
  }
  CloseFd(&in[1]);
  CloseFd(&out[0]);
  CloseFd(&err[0]);
  if (r.timed_out) ::kill(pid, SIGKILL);
  int wstatus = 0;
  while (::waitpid(pid, &wstatus, 0) < 0 && errno == EINTR) {}
  if (WIFEXITED(wstatus)) r.exit_code = WEXITSTATUS(wstatus);
  if (WIFSIGNALED(wstatus)) r.signal = WTERMSIG(wstatus);
  return r;
}

}  // namespace mfns::host
