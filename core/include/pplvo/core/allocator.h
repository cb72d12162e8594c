#pragma once
#include <cstddef>

namespace pplvo {

/// Tunes glibc's malloc for a process that allocates and frees frame-sized buffers (images,
/// depth maps, LCM message payloads of 0.3-5 MB) on every frame.
///
/// By default glibc serves such blocks with mmap and gives them back with munmap, so every
/// frame pays a fresh page fault per 4 KiB touched; on a virtual machine that cost more than
/// the C-GM filter itself (docs/decisions/0006).
/// Here large blocks stay in the heap and freed memory is not trimmed back to the kernel, so
/// the next frame reuses pages already mapped. Call once at the start of main(), before any
/// thread starts. Returns false if the allocator refused a setting (other C libraries).
bool keepFrameBuffersMapped();

/// Maps `bytes` of heap now: allocates them, writes every page and frees them again, so that
/// (after keepFrameBuffersMapped(), which keeps freed heap mapped) the buffers of the first
/// frames come from pages already mapped. For processes that start before their input
/// streams: a VM pays about 10 us per first touch of a page, several ms per frame while the
/// window and feature buffers fill. Returns false if the allocation failed.
bool prefaultHeap(size_t bytes);

/// The same for the malloc arenas of worker threads: `threads` threads at once each map
/// `bytes_each` in their own arena, which glibc hands to later threads when these end.
bool prefaultThreadArenas(int threads, size_t bytes_each);

/// What a node process calls before its input streams: `mib` MiB of main heap and 8 worker
/// arenas of mib / 4 each (3 x mib in all stays mapped). With 64, tried in pplvo-run (every
/// node in one process), its first 20 frames take ~80 page faults instead of ~11 000.
bool prefaultForStreaming(size_t mib);

}  // namespace pplvo
