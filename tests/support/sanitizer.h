// Whether this test binary is built with AddressSanitizer (the sanitized CI build): some tests
// size their work to it, and properties of glibc's heap do not hold under ASan's own allocator.
#pragma once

// GCC defines __SANITIZE_ADDRESS__, clang has __has_feature.
#if defined(__SANITIZE_ADDRESS__)
#define VGEO_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define VGEO_TEST_SANITIZED 1
#endif
#endif
#ifndef VGEO_TEST_SANITIZED
#define VGEO_TEST_SANITIZED 0
#endif

namespace vgeo::test {
inline constexpr bool kSanitizerBuild = VGEO_TEST_SANITIZED;
}  // namespace vgeo::test
