// keepFrameBuffersMapped(): frame-sized blocks come from the heap (no mmap per frame) and stay
// mapped after free. Its own executable: the settings are process-wide.
#include "pplvo/core/allocator.h"

#include <gtest/gtest.h>

#include <cstdlib>  // defines __GLIBC__ on glibc
#include <cstring>

#if defined(__GLIBC__)
#include <malloc.h>

namespace pplvo {
namespace {

constexpr size_t kFrameBytes = 640 * 480 * 4 * 2;  // a depth map with its variance

size_t mmappedBlocksWhileHolding(size_t bytes, size_t* arena_after_free) {
  void* p = std::malloc(bytes);
  if (!p) return 0;
  std::memset(p, 1, bytes);
  const size_t blocks = mallinfo2().hblks;
  std::free(p);
  if (arena_after_free) *arena_after_free = mallinfo2().arena;
  return blocks;
}

TEST(Allocator, FrameBuffersComeFromTheHeapAndStayMappedAfterFree) {
  // Default glibc: a fresh 2.4 MB block is mmapped (and unmapped again on free).
  ASSERT_GE(mmappedBlocksWhileHolding(kFrameBytes, nullptr), 1u);
  ASSERT_TRUE(keepFrameBuffersMapped());
  size_t arena_after_free = 0;
  EXPECT_EQ(mmappedBlocksWhileHolding(4 * kFrameBytes, &arena_after_free), 0u);
  EXPECT_GE(arena_after_free, 4 * kFrameBytes) << "freed frame memory was trimmed";
}

}  // namespace
}  // namespace pplvo
#endif
