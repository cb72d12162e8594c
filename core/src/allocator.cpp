#include "pplvo/core/allocator.h"

#include <atomic>
#include <cstdlib>  // defines __GLIBC__ on glibc
#include <thread>
#include <vector>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace pplvo {

bool keepFrameBuffersMapped() {
#if defined(__GLIBC__)
  // 32 MiB is glibc's upper limit for the mmap threshold on 64-bit (HEAP_MAX_SIZE / 2): every
  // frame buffer is below it. Setting it also stops glibc's dynamic threshold adjustment.
  const bool mmap_ok = mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024) == 1;
  // Keep up to 1 GiB of freed heap mapped instead of trimming it after each frame.
  const bool trim_ok = mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024) == 1;
  return mmap_ok && trim_ok;
#else
  return false;
#endif
}

namespace {

constexpr size_t kPrefaultBlock = 8 * 1024 * 1024;  // below the mmap threshold: from the heap

/// Allocates `bytes` in heap blocks and writes every page; the caller frees them.
bool mapBlocks(size_t bytes, std::vector<void*>* blocks) {
  for (size_t done = 0; done < bytes; done += kPrefaultBlock) {
    auto* block = static_cast<volatile unsigned char*>(std::malloc(kPrefaultBlock));
    if (!block) return false;
    for (size_t i = 0; i < kPrefaultBlock; i += 4096) block[i] = 0;  // volatile: kept
    blocks->push_back(const_cast<unsigned char*>(block));
  }
  return true;
}

void freeBlocks(const std::vector<void*>& blocks) {
  for (void* b : blocks) std::free(b);
}

}  // namespace

bool prefaultHeap(size_t bytes) {
  // All blocks held at once so that they extend the heap instead of reusing one another.
  std::vector<void*> blocks;
  const bool ok = mapBlocks(bytes, &blocks);
  freeBlocks(blocks);
  return ok;
}

bool prefaultThreadArenas(int threads, size_t bytes_each) {
  // glibc gives each thread that allocates while the others are alive and holding memory an
  // arena of its own; when the threads end, the arenas (with the pages mapped here) wait on
  // its free list for the next new threads. Both barriers keep the threads overlapping.
  std::atomic<int> started{0}, mapped{0};
  std::atomic<bool> ok{true};
  std::vector<std::thread> pool;
  for (int i = 0; i < threads; ++i) {
    pool.emplace_back([&] {
      ++started;
      while (started.load() < threads) std::this_thread::yield();
      std::vector<void*> blocks;
      if (!mapBlocks(bytes_each, &blocks)) ok = false;
      ++mapped;
      while (mapped.load() < threads) std::this_thread::yield();
      freeBlocks(blocks);
    });
  }
  for (std::thread& t : pool) t.join();
  return ok;
}

bool prefaultForStreaming(size_t mib) {
  if (mib == 0) return true;
  const size_t bytes = mib << 20;
  const bool heap_ok = prefaultHeap(bytes);
  return prefaultThreadArenas(8, bytes / 4) && heap_ok;
}

}  // namespace pplvo
