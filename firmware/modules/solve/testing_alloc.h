// Test-only: counts global operator new calls in a test binary (link testing_alloc.cc into
// it), so a test can assert that a stretch of flight code never touches the heap.
#pragma once

namespace mfns::fw::testing_alloc {

// operator new / new[] calls (every alignment variant) since the program started.
long Count();

}  // namespace mfns::fw::testing_alloc
