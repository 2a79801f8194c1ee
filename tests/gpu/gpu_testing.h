#pragma once
// Shared by the GPU tests: a context on the default device (lavapipe) with validation on.
// Tests that need Vulkan fail when it is missing, never skip: a skipped GPU test would let a
// machine without Vulkan report the GPU path green (DEVELOPERS.md). Every test ends
// with expect_no_validation_messages: any validation message fails the test.
#include <gtest/gtest.h>

#include <memory>

#include "vgeo/core/error.h"
#include "vgeo/gpu/context.h"

namespace vgeo::testing {

inline std::unique_ptr<GpuContext> make_test_gpu() {
  GpuOptions options;
  options.validate = true;
  try {
    return create_gpu_context(options);
  } catch (const VgeoError& e) {
    ADD_FAILURE() << e.what();
    return nullptr;
  }
}

inline void expect_no_validation_messages(GpuContext& gpu) {
  std::lock_guard<std::mutex> lock(gpu.messages_mutex);
  EXPECT_TRUE(gpu.validation_messages.empty()) << gpu.validation_messages.size() << " validation message(s), first: "
                                              << (gpu.validation_messages.empty() ? "" : gpu.validation_messages[0]);
}

}  // namespace vgeo::testing
