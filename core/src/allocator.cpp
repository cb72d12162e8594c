#include "pplvo/core/allocator.h"

#include <cstdlib>  // defines __GLIBC__ on glibc
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

bool prefaultHeap(size_t bytes) {
  // In blocks below the mmap threshold (so they come from the heap and stay there when freed),
  // all held at once so that they extend the heap instead of reusing one another.
  constexpr size_t kBlock = 8 * 1024 * 1024;
  std::vector<void*> blocks;
  bool ok = true;
  for (size_t done = 0; done < bytes; done += kBlock) {
    auto* block = static_cast<volatile unsigned char*>(std::malloc(kBlock));
    if (!block) {
      ok = false;
      break;
    }
    for (size_t i = 0; i < kBlock; i += 4096) block[i] = 0;  // volatile: not optimised away
    blocks.push_back(const_cast<unsigned char*>(block));
  }
  for (void* b : blocks) std::free(b);
  return ok;
}

}  // namespace pplvo
