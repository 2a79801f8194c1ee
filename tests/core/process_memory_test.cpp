#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <cstring>

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

}  // namespace vgeo
