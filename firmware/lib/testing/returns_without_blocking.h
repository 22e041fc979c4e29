// Test support: whether a call returns while FIFOs it might open sit in its way.
//
// fn runs on a thread. If it has not returned within `limit` (it blocks in open(2) or read(2)
// of one of `fifos`), each FIFO is opened for writing and closed, so a blocked reader sees end
// of file and fn can return (the test then fails instead of hanging). Test code: allocates.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <functional>
#include <future>
#include <string>
#include <thread>
#include <vector>

namespace mfns::fw::testing {

inline bool ReturnsWithoutBlocking(const std::function<void()>& fn, const std::vector<std::string>& fifos,
                                   std::chrono::milliseconds limit = std::chrono::milliseconds(3000)) {
  std::promise<void> done;
  std::future<void> finished = done.get_future();
  std::thread t([&] {
    fn();
    done.set_value();
  });
  const bool in_time = finished.wait_for(limit) == std::future_status::ready;
  // Unblock a stuck reader: a writer's open wakes it, the close gives it end of file.
  for (int i = 0; i < 500 && finished.wait_for(std::chrono::milliseconds(10)) != std::future_status::ready; ++i) {
    for (const std::string& f : fifos) {
      const int fd = ::open(f.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
      if (fd >= 0) ::close(fd);
    }
  }
  t.join();
  return in_time;
}

}  // namespace mfns::fw::testing
