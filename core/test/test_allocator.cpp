// keepFrameBuffersMapped(): frame-sized blocks come from the heap (no mmap per frame) and stay
// mapped after free. Its own executable: the settings are process-wide.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>  // defines __GLIBC__ on glibc
#include <cstring>
#include <thread>
#include <vector>

#include "pplvo/core/allocator.h"

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

long minorFaults() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_minflt;
}

/// Page faults taken while allocating, writing and freeing `n` frame buffers at once.
long faultsForFrameBuffers(int n) {
  const long before = minorFaults();
  std::vector<void*> blocks;
  for (int i = 0; i < n; ++i) {
    void* p = std::malloc(kFrameBytes);
    if (p) std::memset(p, 1, kFrameBytes);
    blocks.push_back(p);
  }
  for (void* p : blocks) std::free(p);
  return minorFaults() - before;
}

TEST(Allocator, PrefaultedHeapServesTheFirstFramesWithoutPageFaults) {
  ASSERT_TRUE(keepFrameBuffersMapped());
  const long pages_per_buffer = static_cast<long>(kFrameBytes) / 4096;
  // Beyond the heap mapped so far (the test above left about 4 buffers): a fault per page.
  const long fresh = faultsForFrameBuffers(16);
  EXPECT_GT(fresh, 8 * pages_per_buffer);
  // After prefaultHeap, far more buffers than the heap held come from pages already mapped.
  ASSERT_TRUE(prefaultHeap(64 * kFrameBytes));
  const long prefaulted = faultsForFrameBuffers(48);
  EXPECT_LT(prefaulted, pages_per_buffer) << "fresh buffers took " << fresh << " faults";
}

/// `n` threads at once each allocate and write 3 frame buffers, hold them until all have, and
/// free them (so that each uses an arena of its own); the most page faults one of them took.
long maxFaultsInConcurrentThreads(int n) {
  std::atomic<int> started{0}, written{0};
  std::vector<long> faults(n, 0);
  std::vector<std::thread> pool;
  for (int i = 0; i < n; ++i) {
    pool.emplace_back([&, i] {
      ++started;
      while (started.load() < n) std::this_thread::yield();
      rusage before{}, after{};
      getrusage(RUSAGE_THREAD, &before);
      std::vector<void*> blocks;
      for (int k = 0; k < 3; ++k) {
        void* p = std::malloc(kFrameBytes);
        if (p) std::memset(p, 1, kFrameBytes);
        blocks.push_back(p);
      }
      getrusage(RUSAGE_THREAD, &after);
      faults[i] = after.ru_minflt - before.ru_minflt;
      ++written;
      while (written.load() < n) std::this_thread::yield();
      for (void* p : blocks) std::free(p);
    });
  }
  for (std::thread& t : pool) t.join();
  return *std::max_element(faults.begin(), faults.end());
}

TEST(Allocator, PrefaultedArenasServeNewWorkerThreads) {
  ASSERT_TRUE(keepFrameBuffersMapped());
  const long pages = 3 * static_cast<long>(kFrameBytes) / 4096;
  // Two new threads: new arenas, a fault per page.
  EXPECT_GT(maxFaultsInConcurrentThreads(2), pages / 2);
  // Eight threads after prefaultThreadArenas(8, ...): every one finds an arena already mapped
  // (without it, six of them would start new arenas).
  ASSERT_TRUE(prefaultThreadArenas(8, 16 << 20));
  EXPECT_LT(maxFaultsInConcurrentThreads(8), pages / 10);
}

}  // namespace
}  // namespace pplvo
#endif
