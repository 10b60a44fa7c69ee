// KeepFreedMemoryForReuse: glibc mallopt thresholds.
#include "common/allocator.h"

#include <cstdlib>  // defines __GLIBC__ under glibc
#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace texfree {

void KeepFreedMemoryForReuse() {
#if defined(__GLIBC__)
  // Fixed thresholds also switch off glibc's dynamic mmap threshold.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
#endif
}

}  // namespace texfree
