#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "support/sanitizer.h"
#include "vgeo/core/process_memory.h"

namespace vgeo {

// A huge-page block is ordinary writable memory of the asked size, aligned like malloc's,
// and independent of any other block (zstd's workspace relies on all three).
TEST(ProcessMemory, HugePageBlocksHoldTheirBytesAndAreAligned) {
  const size_t sizes[] = {1, (size_t(1) << 20) + 7, (size_t(2) << 20) - 16, size_t(3) << 20};
  uint8_t* blocks[std::size(sizes)];
  for (size_t i = 0; i < std::size(sizes); ++i) {
    blocks[i] = static_cast<uint8_t*>(allocate_huge_pages(sizes[i]));
    ASSERT_NE(blocks[i], nullptr);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(blocks[i]) % alignof(std::max_align_t), 0u);
    std::memset(blocks[i], int(0x40 + i), sizes[i]);
  }
  for (size_t i = 0; i < std::size(sizes); ++i) {
    EXPECT_EQ(blocks[i][0], uint8_t(0x40 + i));
    EXPECT_EQ(blocks[i][sizes[i] - 1], uint8_t(0x40 + i));
    EXPECT_EQ(blocks[i][sizes[i] / 2], uint8_t(0x40 + i));
  }
  for (uint8_t* b : blocks) free_huge_pages(b);
  free_huge_pages(nullptr);  // like free(nullptr)
}

// Whether the mapping of /proc/self/smaps that holds `address` is advised for transparent huge
// pages (MADV_HUGEPAGE: "hg" among its VmFlags).
bool mapping_advised_for_huge_pages(uintptr_t address) {
  std::ifstream smaps("/proc/self/smaps");
  std::string line;
  bool inside = false;
  while (std::getline(smaps, line)) {
    unsigned long long begin = 0, end = 0;
    char dash = 0;
    std::istringstream head(line);
    if (line.find(':') == std::string::npos || line.find(':') > line.find(' ')) {
      if (head >> std::hex >> begin >> dash >> end && dash == '-') inside = address >= begin && address < end;
      continue;
    }
    if (inside && line.rfind("VmFlags:", 0) == 0) return line.find(" hg") != std::string::npos;
  }
  return false;
}

// After advise_thread_heap(n), the calling thread's next allocation (of less than n) lies in
// memory advised for huge pages: on the main heap and on a further thread's own heap (glibc's
// arena of that thread), the two a leaf pass of several chunks fills (dag/build.cpp). In a
// child process, whose heap settings are the build's (prepare_build_heap).
bool next_allocation_is_advised() {
  constexpr size_t kAdvised = size_t(8) << 20, kAllocated = size_t(6) << 20;
  advise_thread_heap(kAdvised);
  void* block = std::malloc(kAllocated);
  std::memset(block, 1, kAllocated);
  // The middle of the block: inside the whole huge pages of the advised range.
  const bool advised = mapping_advised_for_huge_pages(reinterpret_cast<uintptr_t>(block) + kAllocated / 2);
  std::free(block);
  return advised;
}

TEST(ProcessMemoryDeathTest, AThreadsNextAllocationsAreAdvisedForHugePages) {
  // madvise(MADV_HUGEPAGE) marks the mapping (smaps VmFlags "hg") whenever the kernel has transparent
  // huge pages, whatever mode /sys/kernel/mm/transparent_hugepage/enabled names; a kernel without them
  // has no such file, refuses the advice, and nothing may be marked.
  // The reuse of the advised range is glibc's heap under prepare_build_heap's settings; ASan's
  // allocator places blocks its own way (a quarantine delays reuse), so there the advice is lost —
  // harmless, it only saves page faults — and the calls are checked for memory safety alone.
  const bool kernel_has_thp = std::ifstream("/sys/kernel/mm/transparent_hugepage/enabled").good();
  const bool glibc_heap = !test::kSanitizerBuild;
  EXPECT_EXIT(
      {
        prepare_build_heap(0);
        const bool main_heap = next_allocation_is_advised();
        bool thread_heap = false;
        std::thread([&] { thread_heap = next_allocation_is_advised(); }).join();
        std::_Exit(!glibc_heap || (main_heap == kernel_has_thp && thread_heap == kernel_has_thp) ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

}  // namespace vgeo
