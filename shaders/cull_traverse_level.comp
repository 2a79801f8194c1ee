#version 460
// Level-by-level traversal: one indirect dispatch per BVH level over the queue's slots
// [level_begin, level_end); children are appended after level_end and become the next
// level (cull_advance.comp). No invocation waits for another, so it cannot deadlock however
// few workgroups are resident.
#include "cull_traverse.glsl"

layout(local_size_x = VGEO_CULL_GROUP_SIZE) in;

void main() {
  clear_counters();
  uint slot = queue.level_begin + gl_GlobalInvocationID.x;
  if (slot < queue.level_end) process_item(slots[slot]);
  flush_counters();
}
