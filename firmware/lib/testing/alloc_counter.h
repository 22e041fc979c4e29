// Test support: counts calls of the global operator new in a test binary, so a test can prove
// that code after Start() allocates nothing (DESIGN.md "Firmware rules"). Compile
// alloc_counter.cc into the test binary, or link mfns_fw_alloc_counter (it replaces the global
// operator new/delete, every alignment and nothrow variant).
// Counts only operator new (C++ containers, new-expressions); malloc called directly by libc
// is not seen.
#pragma once

#include <cstdint>

namespace mfns::fw::testing {

// Number of operator new / new[] calls since the program started.
std::uint64_t AllocationCount();

}  // namespace mfns::fw::testing
