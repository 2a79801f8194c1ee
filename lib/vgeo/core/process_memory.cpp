#include "vgeo/core/process_memory.h"

#include <sys/mman.h>
#include <sys/resource.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <cstdio>
#include <cstdint>
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

void release_free_heap() {
#if defined(__GLIBC__)
  malloc_trim(0);
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
