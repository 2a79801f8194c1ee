#pragma once
// The process's peak memory, as the builder's report and `vgeo bench build` state it.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace vgeo {

// Peak resident set of this process image, in bytes: VmHWM of /proc/self/status (Linux), the
// high-water mark of the address space since exec. getrusage's ru_maxrss is the fallback: it
// also counts the address space the process had before exec, so a process started by vfork or
// posix_spawn from a larger one reports its parent's peak (`vgeo bench build`'s children did:
// 39 MiB for bunny00 against 20 MiB measured by /usr/bin/time).
uint64_t peak_rss_bytes();

// Sets the allocator up for one build (`vgeo build`; call once, before the build's first large
// allocation; a no-op without glibc): large arrays up to 32 MiB come from the heap, freed
// memory stays there for the next level to reuse, and the heap grows in steps of 8 MiB, the
// first of which is advised for transparent huge pages, so that the import's and clustering's
// fresh memory costs one page fault per 2 MiB instead of one per 4 KiB page
// (docs/acceptance/issue23_heap.md). The advice stops below what a build of an input file of
// `input_bytes` is sure to fill (0: no advice), so that no huge page lies across the heap's
// high-water mark (docs/acceptance/issue23_rss37.md). Where THP is off or refused the advice
// does nothing, and the steps are address space, not memory.
void prepare_build_heap(uint64_t input_bytes);

// Hands the heap's free pages back to the kernel (glibc's malloc_trim: the free space at the
// heap's top and the whole pages inside free chunks; a no-op elsewhere). Called where a phase has
// freed most of what it allocated and the next phase allocates less: the freed pages then stop
// counting towards the resident set while the next phase faults in its code and arrays, which
// would otherwise add to the earlier phase's high-water mark. Costs one page fault per returned
// page that is used again (docs/acceptance/issue23_smallrss.md).
void release_free_heap();

// Bytes of freed memory the heap holds for reuse (glibc's mallinfo2: its free chunks, less the
// top chunk, whose step of address space above the live data is mostly never touched); 0
// elsewhere. A phase whose allocations fit in it reuses pages that are already resident.
uint64_t free_heap_bytes();

// Asks the kernel to back [data, data + bytes) with transparent huge pages (MADV_HUGEPAGE; Linux
// with THP in `madvise` or `always` mode, a no-op elsewhere) when it covers at least one whole
// aligned huge page (kHugePageBytes). For large arrays that are filled completely: a first
// touch then costs one fault per 2 MiB instead of one per 4 KiB page, and the array's accesses
// miss the TLB far less (docs/acceptance/issue23_dagpar.md measures both on the 4M sphere).
void advise_huge_pages(void* data, size_t bytes);

// Advises the heap memory that the calling thread's next allocations of up to `bytes` in all
// will use (advise_huge_pages), for a phase that fills that much fresh memory on each thread:
// blocks of `bytes` in all are allocated, advised and freed, and the allocations that follow
// reuse their address range (the build's heap settings, prepare_build_heap: blocks up to 32 MiB
// come from the heap, and freed memory is not trimmed). For a pool thread's own heap (glibc gives
// each further thread an arena of its own, never advised, whose pages a first touch faults in
// one by one) and for the main heap above prepare_build_heap's first step.
void advise_thread_heap(size_t bytes);

// v.reserve(n), the reserved storage advised as above: for a fresh array of n elements that is
// then sized and filled.
template <class T>
void reserve_huge_pages(std::vector<T>& v, size_t n) {
  v.reserve(n);
  advise_huge_pages(v.data(), n * sizeof(T));
}

// Memory for a large table that is written whole and probed at random (zstd's match-finder
// tables, which it clears at every reset): its own mapping, aligned to and advised for 2 MiB
// transparent huge pages (Linux MADV_HUGEPAGE, where the kernel allows them; small pages
// otherwise). One fault then maps 2 MiB instead of 4 KiB: on a machine whose page faults are
// slow (~11 us each on the virtual machine of docs/acceptance/issue23_write.md) zstd's 3.7 MB
// workspace cost ~750 faults; and random probes miss the TLB less. The resident size rounds up
// to whole huge pages. Returns null when no mapping can be made; free with free_huge_pages.
void* allocate_huge_pages(size_t bytes);
void free_huge_pages(void* p);

}  // namespace vgeo
