#pragma once
// 64-bit FNV-1a: content hashes for caches and test vectors (not a checksum for pages;
// the page format specifies its own).
// Based on: Fowler, Noll, Vo, "The FNV Non-Cryptographic Hash Algorithm" (IETF
// draft-eastlake-fnv), FNV-1a with the 64-bit offset basis and prime.
#include <cstddef>
#include <cstdint>
#include <string_view>

namespace vgeo {

inline constexpr uint64_t kFnvOffset = 0xcbf29ce484222325ull;
inline constexpr uint64_t kFnvPrime = 0x100000001b3ull;

inline uint64_t fnv1a64(const void* data, size_t size, uint64_t h = kFnvOffset) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) h = (h ^ p[i]) * kFnvPrime;
  return h;
}
inline uint64_t fnv1a64(std::string_view s, uint64_t h = kFnvOffset) {
  return fnv1a64(s.data(), s.size(), h);
}

}  // namespace vgeo
