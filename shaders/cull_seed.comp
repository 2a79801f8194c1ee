#version 460
// Seeds the traversal queue from a compacted list: instances (their BVH roots) or CullItems
// (pass 1's occluded items, retested in pass 2). Appends after the queue's write head.
#include "cull_common.glsl"

layout(local_size_x = VGEO_CULL_GROUP_SIZE) in;

void main() {
  uint n = list_in[0];
  uint k = gl_GlobalInvocationID.x;
  if (k >= n) return;
  uint64_t item;
  if (push.mode == kSeedInstances) {
    item = pack_cull_item(list_in[kListHeaderWords + k], 0u, kItemNode);
  } else {
    uint r = kListHeaderWords + 3u * k;
    item = pack_cull_item(list_in[r], list_in[r + 1u], list_in[r + 2u]);
  }
  uint slot = atomicAdd(queue.write_head, 1u);
  atomicAdd(queue.pending, 1u);
  atomicExchange(slots[slot], item);
}
