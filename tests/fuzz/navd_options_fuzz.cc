// libFuzzer target for mfns-navd's command line (firmware/app/navd/navd_options.h): the input
// is split at NUL bytes into at most 32 arguments; whatever they are, ParseNavdOptions gives a
// status and, on an error, a NUL-terminated one-line reason within its buffer.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "firmware/app/navd/navd_options.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  constexpr std::size_t kMaxBytes = 4096;
  constexpr int kMaxArgs = 32;
  static std::array<char, kMaxBytes + 1> text;
  const std::size_t n = size < kMaxBytes ? size : kMaxBytes;
  std::memcpy(text.data(), data, n);
  text[n] = '\0';
  std::array<char*, kMaxArgs + 2> argv{};
  static char name[] = "mfns-navd";
  int argc = 0;
  argv[static_cast<std::size_t>(argc++)] = name;
  for (std::size_t i = 0; i < n + 1 && argc <= kMaxArgs;) {
    char* arg = text.data() + i;
    argv[static_cast<std::size_t>(argc++)] = arg;
    i += std::strlen(arg) + 1;
  }
  argv[static_cast<std::size_t>(argc)] = nullptr;
  mfns::fw::NavdOptions opt;
  std::array<char, 256> why{};
  why.back() = 'x';  // must be overwritten by a terminator when a reason is written
  const mfns::fw::OptionsStatus s = mfns::fw::ParseNavdOptions(argc, argv.data(), &opt, why.data(), why.size() - 1);
  if (s == mfns::fw::OptionsStatus::kError && std::memchr(why.data(), '\0', why.size() - 1) == nullptr) std::abort();
  return 0;
}
