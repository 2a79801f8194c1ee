// Infrastructure smoke test: headless lavapipe context with validation, a compute pipeline
// from embedded SPIR-V, and 64-bit atomicMax into a storage buffer equal to the CPU max.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "gpu/gpu_testing.h"
#include "vgeo/gpu/shader_bindings.h"
#include "vgeo/gpu/shaders.h"

namespace vgeo {
namespace {

struct SmokePush {
  uint32_t value_count, slot_count;
};

TEST(GpuSmoke, DefaultDeviceIsLavapipeWithValidation) {
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  EXPECT_NE(gpu->device_name.find("llvmpipe"), std::string::npos) << gpu->device_name;
  EXPECT_TRUE(gpu->validation);
  testing::expect_no_validation_messages(*gpu);
}

TEST(GpuSmoke, AtomicMax64MatchesCpu) {
  auto gpu = testing::make_test_gpu();
  ASSERT_TRUE(gpu);
  // Contended (many values per slot) and random 64-bit values, including ones that
  // differ only in the low (id) or only in the high (depth) word.
  const uint32_t value_count = 200000, slot_count = 997;
  std::mt19937_64 rng(12);
  std::vector<uint64_t> values(value_count);
  for (uint32_t i = 0; i < value_count; ++i) {
    uint64_t v = rng();
    if (i % 3 == 1) v &= 0xffffffffull;
    if (i % 3 == 2) v |= 0xffffffffull;
    values[i] = v;
  }
  std::vector<uint64_t> expected(slot_count, 0);
  for (uint32_t i = 0; i < value_count; ++i) expected[i % slot_count] = std::max(expected[i % slot_count], values[i]);

  GpuBuffer in = create_gpu_buffer(*gpu, values.size() * 8);
  GpuBuffer out = create_gpu_buffer(*gpu, slot_count * 8);
  std::copy(values.begin(), values.end(), in.data<uint64_t>());
  ComputePipeline pipeline = create_compute_pipeline(*gpu, kShaderSmokeAtomicMax, kSmokeBindingCount, sizeof(SmokePush));
  auto rec = create_gpu_recorder(*gpu);
  begin_commands(*rec);
  cmd_fill(*rec, out, 0);
  SmokePush push{value_count, slot_count};
  uint32_t t0 = cmd_timestamp(*rec);
  cmd_dispatch(*rec, pipeline, gpu_bindings(kSmokeBindingCount, {{kSmokeBindValues, &in}, {kSmokeBindSlots, &out}}), &push, (value_count + 63) / 64);
  uint32_t t1 = cmd_timestamp(*rec);
  submit_and_wait(*rec);
  EXPECT_GE(timestamp_ms(*rec, t0, t1), 0.0);
  const uint64_t* got = out.data<uint64_t>();
  uint32_t mismatches = 0;
  for (uint32_t s = 0; s < slot_count; ++s) mismatches += got[s] != expected[s];
  EXPECT_EQ(mismatches, 0u);
  testing::expect_no_validation_messages(*gpu);
}

TEST(GpuSmoke, UnknownDeviceIsACodedError) {
  GpuOptions options;
  options.device = "no-such-gpu-device";
  try {
    create_gpu_context(options);
    FAIL() << "expected GPU_DEVICE_NOT_FOUND";
  } catch (const VgeoError& e) {
    EXPECT_EQ(e.error().code, "GPU_DEVICE_NOT_FOUND");
  }
}

}  // namespace
}  // namespace vgeo
