// Test of KeepFreedMemoryForReuse: a request's worth of image buffers, freed and
// allocated again, does not fault its pages in again.
#include "common/allocator.h"

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cstdlib>
#include <cstring>
#include <vector>

namespace texfree {
namespace {

long MinorPageFaults() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_minflt;
}

// Eight 1 MiB buffers (a 640x480 frame's images and maps), written and freed.
void OneRequest() {
  std::vector<char*> buffers;
  for (int i = 0; i < 8; ++i) {
    buffers.push_back(static_cast<char*>(std::malloc(1 << 20)));
    std::memset(buffers.back(), i, 1 << 20);
  }
  for (char* b : buffers) std::free(b);
}

TEST(AllocatorTest, LaterRequestsReuseTheFirstOnesMemory) {
#if !defined(__GLIBC__)
  GTEST_SKIP() << "malloc settings are glibc's";
#endif
  KeepFreedMemoryForReuse();
  OneRequest();  // maps the memory once
  const long before = MinorPageFaults();
  for (int i = 0; i < 5; ++i) OneRequest();
  // Without reuse each request faults 2,048 pages in again (10,240 in all).
  EXPECT_LT(MinorPageFaults() - before, 200);
}

}  // namespace
}  // namespace texfree
