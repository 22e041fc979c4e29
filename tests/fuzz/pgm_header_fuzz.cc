// libFuzzer target for the PGM header parser (firmware/drivers/replay/pgm.h), which reads every
// replayed frame's header: whatever the bytes, a typed status; a header that parses kOk has
// sizes within the limits and a raster offset inside the bytes it was given.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "common/limits.h"
#include "firmware/drivers/replay/pgm.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  mfns::fw::PgmHeader h;
  if (mfns::fw::ParsePgmHeader(data, size, &h) != mfns::fw::PgmStatus::kOk) return 0;
  if (h.width <= 0 || h.height <= 0 || h.width > mfns::limits::kMaxImageWidth ||
      h.height > mfns::limits::kMaxImageHeight || h.header_bytes > size ||
      (h.maxval != 255 && h.maxval != 65535) ||
      h.raster_bytes != static_cast<std::size_t>(h.width) * static_cast<std::size_t>(h.height) * (h.maxval > 255 ? 2u : 1u))
    std::abort();  // a header the parser accepted must be usable as it is
  return 0;
}
