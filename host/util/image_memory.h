// Allocator policy for host tools that work through many images (calibration detection,
// rendering). Host only: the firmware allocates nothing after start.
#pragma once

namespace mfns::host {

// Makes glibc keep freed multi-megabyte blocks in the process for the next image instead of
// returning them to the kernel: blocks up to 32 MiB come from the heap (M_MMAP_THRESHOLD,
// glibc's largest) and freed memory is trimmed only above 512 MiB (M_TRIM_THRESHOLD). Why:
// glibc serves a block above its mmap threshold with a fresh mapping and unmaps it when it is
// freed; OpenCV's findChessboardCornersSB allocates and frees many such blocks per image, and
// the page faults of every fresh mapping (each page zeroed by the kernel) cost more than the
// detection itself (CalibSlow.RenderedImagesTwentySeeds: 32 s of 60 in the kernel before).
// Cost: the process keeps its peak heap until it exits. Process-wide and idempotent (the
// first call sets it; later calls do nothing); thread-safe. Returns false when glibc refused
// a setting (the process then runs as before, only slower).
bool KeepImageBuffers();

}  // namespace mfns::host
