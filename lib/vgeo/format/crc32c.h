#pragma once
// CRC-32C (Castagnoli): the page and header checksum of spec/format.md §Checksums.
// Reflected polynomial 0x82F63B78, initial value 0xFFFFFFFF, final XOR 0xFFFFFFFF
// (the iSCSI / SSE4.2 `crc32` variant). Test vector: crc32c("123456789") == 0xE3069283.
#include <cstddef>
#include <cstdint>

namespace vgeo {

// `crc` chains calls: crc32c(b, n2, crc32c(a, n1)) == crc32c(a ++ b).
uint32_t crc32c(const void* data, size_t size, uint32_t crc = 0);

}  // namespace vgeo
