// KeepFreedMemoryForReuse: process-wide malloc settings for per-request image work.
#pragma once

namespace texfree {

// Every request (a query image, a pool frame) allocates the same large buffers again:
// decoded and undistorted images, label maps, ball-ness maps, accumulators, each a few
// hundred KB to a few MB. With glibc's defaults, freed buffers at the top of the heap are
// given back to the kernel and the next request faults every page of them in again
// (about 900 page faults per 640x480 pool frame; 112,000 over the pool benchmark's 60
// frames, 7,000 with this). This keeps blocks under 32 MiB (glibc's own ceiling for its
// moving threshold) on the heap and up to 512 MiB of freed memory mapped, so the next
// request reuses it; the document index's larger arrays are still mapped on their own.
// Resident memory stays at its high-water mark instead of shrinking between requests.
// Call once at start-up, before threads start; a no-op where the C library is not glibc.
void KeepFreedMemoryForReuse();

}  // namespace texfree
