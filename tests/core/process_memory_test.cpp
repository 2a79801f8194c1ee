#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <thread>
#if defined(__GLIBC__)
#include <unistd.h>
#endif

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

#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
// After prepare_build_heap a second thread allocates from the main heap (the brk area below
// sbrk(0)), so it reuses what the main thread freed instead of faulting in an mmapped arena of
// its own (glibc's default for a new thread). Run in a fresh process (a death-test child):
// glibc fixes its arena limit when the first thread arena is made, which an earlier test of
// this binary may have done. (AddressSanitizer replaces malloc: nothing to check there.)
TEST(ProcessMemory, BuildHeapIsSharedWithOtherThreads) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        prepare_build_heap(0);
        void* first = std::malloc(size_t(1) << 20);
        const uintptr_t freed = reinterpret_cast<uintptr_t>(first);
        std::free(first);
        void* block = nullptr;
        std::thread([&] { block = std::malloc(size_t(1) << 20); }).join();
        const uintptr_t at = reinterpret_cast<uintptr_t>(block);
        const bool in_main_heap = block && at >= freed && at < reinterpret_cast<uintptr_t>(sbrk(0));
        std::free(block);
        std::exit(in_main_heap ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}
#endif

}  // namespace vgeo
