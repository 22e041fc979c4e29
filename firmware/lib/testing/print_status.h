// Test support: GoogleTest prints SourceStatus by name ("timeout") instead of raw bytes.
#pragma once

#include <ostream>

#include "firmware/lib/frame_source.h"

namespace mfns::fw {
inline void PrintTo(SourceStatus s, std::ostream* os) { *os << ToString(s); }
}  // namespace mfns::fw
