#include "vgeo/core/process_memory.h"

#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <climits>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <cstring>

namespace vgeo {

uint64_t peak_rss_bytes() {
  if (std::FILE* f = std::fopen("/proc/self/status", "r")) {
    char line[256];
    unsigned long long kib = 0;
    bool found = false;
    while (!found && std::fgets(line, sizeof line, f))
      found = std::strncmp(line, "VmHWM:", 6) == 0 && std::sscanf(line + 6, "%llu", &kib) == 1;
    std::fclose(f);
    if (found) return uint64_t(kib) * 1024;
  }
  struct rusage usage {};
  return getrusage(RUSAGE_SELF, &usage) == 0 ? uint64_t(usage.ru_maxrss) * 1024 : 0;
}

// The PMD-level huge page of x86-64 and arm64 with 4 KiB pages. Where it is larger, the advice
// only covers less than it could; where THP is off, it does nothing.
constexpr uintptr_t kHugePageBytes = uintptr_t(2) << 20;

void advise_huge_pages(void* data, size_t bytes) {
#ifdef MADV_HUGEPAGE
  const uintptr_t begin = reinterpret_cast<uintptr_t>(data);
  const uintptr_t first = (begin + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
  const uintptr_t last = (begin + bytes) & ~(kHugePageBytes - 1);
  if (!data || last <= first) return;
  (void)madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
#else
  (void)data;
  (void)bytes;
#endif
}

namespace {

// Allocations up to this size come from the heap, not from mmap: a build allocates and frees
// arrays of the mesh's size (MBs to hundreds of MBs) on every level, and glibc's default
// (mmap above 128 KiB, raised only up to 32 MiB as chunks are freed) hands each back to the
// kernel, so the next one is faulted in and zeroed again. Measured on the 1M sphere, one
// thread: 0.2 s less system time and 0.1-0.3 s less user time (about 8% of the build),
// peak RSS +2% (docs/acceptance/issue23_buildspeed.md). Larger arrays (beyond 32 MiB: the
// import's file buffer, the leaf adjacency and index arrays of multi-million-triangle meshes) are
// mmapped and go back to the kernel when freed: kept in the heap they left holes the layout's
// arrays could not fit in, and the 4M sphere peaked at 445 MiB, 1.25x the peer's 356 (407 MiB
// now; CPU medians 8.45 -> 8.31 s, the 1M sphere's arrays all lie below: unchanged;
// docs/acceptance/issue23_stop33.md; 256 MiB and 32 MiB measured the same CPU side by side).
constexpr int kBuildMmapThresholdBytes = 32 << 20;
// Freed heap memory is kept, not trimmed back to the kernel (glibc trims the top once 128 KiB
// are free there): the next level's arrays and the layout's reuse it instead of faulting it
// in again, and the peak RSS is the high-water mark either way. Measured on the 1M sphere, one
// thread, with the layout reusing the levels' memory: 43.9k → 26.5k page faults, system time
// 0.73-0.82 → 0.34-0.41 s, peak RSS 112 → 114 MiB (docs/acceptance/issue23_dagfast.md).
constexpr int kBuildTrimThresholdBytes = INT_MAX;
// The heap grows by at least this much beyond each request (glibc's M_TOP_PAD, default
// 128 KiB), and the first step, taken when the build starts, is advised for transparent huge
// pages: a first touch inside an advised, untouched, aligned 2 MiB stretch maps all of it with
// one fault (a fault costs ~10-14 us on the virtual machine of docs/acceptance/issue23_write.md,
// one per 4 KiB page otherwise). The import's and clustering's arrays, the first memory a build
// fills, lie there. A stretch the heap only partly uses is resident whole, so the step trades
// page faults against peak RSS. Armadillo's .vgeodag build, one thread (page faults / median
// peak RSS; baseline 3,162 / 9.6 MiB): steps of 4, 6, 8, 10 MiB 2,651 / 9.9, 2,116 / 10.1,
// 1,745 / 10.1, 1,711 / 10.7 MiB; bunny00's 8, 10, 16 MiB 2,519 / 12.7, 1,986 / 12.8, 2,008 /
// 13.6 MiB (baseline ~4,300 / 12.4 MiB). Growing and advising the heap again after each
// release_free_heap saved no faults (the later phases reuse memory the trims split into small
// pages) and put armadillo's page-format peak at 15.1 MiB in 3 of 9 runs (12.8-13.3 without;
// docs/acceptance/issue23_heap.md). The 1M and 4M spheres' large arrays advise themselves
// (reserve_huge_pages); their heaps grow past the step.
constexpr int kBuildHeapStepBytes = 8 << 20;
// The advice covers only the stretches below this many bytes per input file byte above the
// heap's start: memory the build is sure to fill before its peak. A huge page is resident whole
// from its first touch, so one that the heap's high-water mark falls inside adds the rest of it
// to the peak: 0-2 MiB depending on where the heap's randomized start puts the 2 MiB boundaries
// (armadillo's .vgeodag peak spread over 9.1-10.9 MiB with the whole step advised). An OFF
// mesh's build fills ~4.0 bytes of heap per file byte by the end of its leaf pass (armadillo:
// 6.2 MiB for 1.55 MiB; the file buffer and the mesh alone are 1.6x); binary files fill more per
// byte, so the bound leaves them fewer huge pages than they could have, never a partly used one.
constexpr double kFilledHeapPerInputByte = 3.5;

}  // namespace

void prepare_build_heap(uint64_t input_bytes) {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, kBuildMmapThresholdBytes);
  mallopt(M_TRIM_THRESHOLD, kBuildTrimThresholdBytes);
#if __GLIBC_PREREQ(2, 33)
  mallopt(M_TOP_PAD, kBuildHeapStepBytes);
  // The heap is made to span a step of free space at its top, and what it then spans beyond
  // its current end is advised. A request larger than all free memory cannot be served from a
  // free chunk: malloc extends the heap by the request (less the top chunk) plus M_TOP_PAD;
  // freed, the block merges back into the top chunk, which the trim threshold keeps. Only
  // address space is added: the pages fault in when used.
  const uintptr_t begin = reinterpret_cast<uintptr_t>(sbrk(0));
  const struct mallinfo2 info = mallinfo2();
  if (info.keepcost < size_t(kBuildHeapStepBytes)) {  // keepcost: the top chunk's size
    // +64: above any free chunk's size after malloc's header and rounding. volatile: the
    // compiler may not drop the pair as dead code.
    void* volatile block = std::malloc(info.fordblks + 64);
    std::free(block);
  }
  const uintptr_t filled = begin + uintptr_t(kFilledHeapPerInputByte * double(input_bytes));
  const uintptr_t end = std::min(reinterpret_cast<uintptr_t>(sbrk(0)), filled);
  if (end > begin) advise_huge_pages(reinterpret_cast<void*>(begin), end - begin);
#endif
#endif
}

void advise_thread_heap(size_t bytes) {
  // In blocks of half the heap's mmap threshold (prepare_build_heap), held until all are
  // advised: each comes from the heap, next to the one before it, where one block of more than
  // the threshold would be mapped apart and unmapped when freed (the 4M sphere's ~40 MB).
  constexpr size_t kBlockBytes = size_t(kBuildMmapThresholdBytes) / 2;
  std::vector<void*> blocks;
  for (size_t left = bytes; left > 0;) {
    const size_t size = std::min(left, kBlockBytes);
    void* block = std::malloc(size);
    if (!block) break;
    advise_huge_pages(block, size);
    blocks.push_back(block);
    left -= size;
  }
  for (void* block : blocks) std::free(block);
}

void release_free_heap() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

uint64_t free_heap_bytes() {
#if defined(__GLIBC__) && __GLIBC_PREREQ(2, 33)
  const struct mallinfo2 info = mallinfo2();
  return uint64_t(info.fordblks - std::min(info.fordblks, info.keepcost));
#else
  return 0;
#endif
}

namespace {
// Where free_huge_pages finds the mapping: a header in front of the returned block (which
// stays aligned to max_align_t; the mapping starts on a huge-page boundary).
struct HugeHeader {
  void* base;
  size_t length;
};
constexpr size_t kHugeHeaderBytes = alignof(std::max_align_t) > sizeof(HugeHeader) ? alignof(std::max_align_t)
                                                                                   : sizeof(HugeHeader);
}  // namespace

void* allocate_huge_pages(size_t bytes) {
  const size_t length = (bytes + kHugeHeaderBytes + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
  if (length < bytes) return nullptr;  // overflow
  // Mapped one huge page longer, then cut to a huge-page boundary at both ends.
  void* raw = ::mmap(nullptr, length + kHugePageBytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) return nullptr;
  const uintptr_t start = reinterpret_cast<uintptr_t>(raw);
  const uintptr_t aligned = (start + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
  if (aligned > start) ::munmap(raw, aligned - start);
  if (start + kHugePageBytes > aligned) ::munmap(reinterpret_cast<void*>(aligned + length), start + kHugePageBytes - aligned);
  void* base = reinterpret_cast<void*>(aligned);
  advise_huge_pages(base, length);  // advice only: small pages where it is refused
  auto* header = static_cast<HugeHeader*>(base);
  header->base = base, header->length = length;
  return static_cast<char*>(base) + kHugeHeaderBytes;
}

void free_huge_pages(void* p) {
  if (!p) return;
  const auto* header = reinterpret_cast<const HugeHeader*>(static_cast<char*>(p) - kHugeHeaderBytes);
  ::munmap(header->base, header->length);
}

}  // namespace vgeo
