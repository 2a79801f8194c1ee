#version 460
// Between two levels of cull_traverse_level.comp: the items appended by the last level
// become the current level, and the indirect dispatch covers them.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types : require
#include "vgeo/core/cull_shared.h"
#include "vgeo/gpu/shader_bindings.h"

layout(local_size_x = 1) in;
layout(std430, binding = kAdvanceBindQueue) coherent buffer QueueBuf { GpuQueueHeader queue; };

void main() {
  queue.level_begin = queue.level_end;
  queue.level_end = queue.write_head;
  queue.dispatch_x = (queue.level_end - queue.level_begin + kCullGroupSize - 1u) / kCullGroupSize;
  queue.dispatch_y = 1u;
  queue.dispatch_z = 1u;
}
