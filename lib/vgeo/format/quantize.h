#pragma once
// Internal to lib/vgeo/format: the encoder's choice of each mesh's quantization grids and its
// report (spec/format.md §2), implemented in quantize.cpp with the public quantization
// functions of format.h (dequantize_position, octahedral_encode/decode, uv_quantized_limit,
// inflate_metadata_for_quantization).
#include <cmath>
#include <cstdint>
#include <string>

#include "vgeo/core/thread_pool.h"
#include "vgeo/dag/cluster_dag.h"
#include "vgeo/format/format.h"

namespace vgeo::format_detail {

// std::nearbyint in the default rounding mode (to nearest, ties to even) without its libm call
// (the baseline x86-64 ISA has no rounding instruction; the call was ~1.5% of the write stage
// on a 1M-triangle sphere): adding then subtracting 2^52 rounds a |x| < 2^52 to an integer
// exactly, as nearbyint does; a larger |x| (or inf, NaN) is its own result; the sign is
// restored as nearbyint keeps it (−0.3 → −0.0).
inline double round_to_nearest_even(double x) {
  constexpr double kTwoPow52 = 4503599627370496.0;
  const double a = std::fabs(x);
  if (!(a < kTwoPow52)) return x;
  return std::copysign((a + kTwoPow52) - kTwoPow52, x);
}

// The encoder's one failure: VgeoError(FORMAT_ENCODE) at "<encoder>" (container.cpp).
[[noreturn]] void encode_fail(const std::string& what);

// The position grid step (log2) of one mesh: FormatOptions::position_step_log2 if set, else
// the smallest power of two that fits the extent in position_bits bits, refined towards the
// DAG's median first-simplification error (FormatOptions). Throws on a non-finite position.
// `pool` (may be null): the scans of the positions in chunks on it (maxima: the same values).
int32_t choose_position_step(const ClusterDag& dag, const FormatOptions& o, ThreadPool* pool = nullptr);
// The UV step of one mesh: the option's step, coarsened (a power of two at a time) until
// every |uv| fits in uv_quantized_limit steps; every finite UV fits at kMaxUvStepLog2.
int32_t choose_uv_step(const ClusterDag& dag, const FormatOptions& o);
// Largest |decoded − source| over a mesh's positions and UVs (FormatReport::meshes).
// `pool` (may be null) as for choose_position_step.
FormatReport::MeshQuantizationReport measure_quantization(const ClusterDag& dag, const MeshQuantization& q,
                                                          ThreadPool* pool = nullptr);

}  // namespace vgeo::format_detail
