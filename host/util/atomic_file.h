// Crash-safe output files for host tools: write to a temp name beside the target, fsync,
// rename over the target, fsync the directory. A reader never sees a half-written file and a
// failed write leaves the old file as it was (DESIGN.md, "User-facing interfaces").
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>

#include "host/util/user_error.h"  // the UserError these functions throw

namespace mfns::host {

// Writes bytes to path atomically. Creates no directories. Throws UserError on failure.
void WriteFileAtomic(const std::filesystem::path& path, std::span<const std::uint8_t> bytes);
void WriteFileAtomic(const std::filesystem::path& path, std::string_view text);

// Reads a whole file, refusing files above max_bytes ("too large (N bytes, limit max_bytes)").
// Throws UserError on failure, saying which: "no such file", "is a directory, expected a
// file", "not a regular file (a FIFO, socket or device)" (never blocks on a FIFO), or the
// system's reason.
std::string ReadFile(const std::filesystem::path& path, std::size_t max_bytes = 256u << 20);

}  // namespace mfns::host
