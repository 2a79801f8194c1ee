#version 460
// Persistent-threads traversal (Nanite): a fixed number of workgroups loop over one MPMC
// queue, with bounded work per invocation (llvmpipe ends every loop of an invocation after
// kGpuLoopBudget back edges in total: spec/raster.md §12). Each dispatch runs at most
// push.iterations loop iterations per invocation; gpu_cull.cpp re-dispatches until the
// queue's `pending` (items pushed, not finished) is 0.
//
// A workgroup is one subgroup (8 invocations). Per iteration invocation 0 reads the queue's
// read head; invocation l looks at slot head + l; the leading run of slots that are already
// written is claimed with one compare-and-swap of the read head. So an invocation never
// holds a slot it has not processed when the dispatch ends (nothing waits across
// dispatches), and no invocation waits for another within one (a failed claim is retried).
#include "cull_traverse.glsl"

layout(local_size_x = VGEO_PERSISTENT_GROUP_SIZE) in;

shared uint s_head, s_write, s_claimed, s_done;
shared uint s_ready[VGEO_PERSISTENT_GROUP_SIZE];

void main() {
  clear_counters();
  uint lane = gl_LocalInvocationIndex;
  for (uint it = 0u; it < push.iterations; ++it) {
    if (lane == 0u) {
      s_head = atomicAdd(queue.read_head, 0u);
      s_write = atomicAdd(queue.write_head, 0u);
    }
    barrier();
    uint slot = s_head + lane;
    uint64_t packed = uint64_t(0);
    if (slot < s_write && slot < params.queue_capacity) packed = atomicAdd(slots[slot], uint64_t(0));
    s_ready[lane] = packed != uint64_t(0) ? 1u : 0u;
    barrier();
    if (lane == 0u) {
      uint n = 0u;
      while (n < VGEO_PERSISTENT_GROUP_SIZE && s_ready[n] != 0u) ++n;
      s_claimed = (n > 0u && atomicCompSwap(queue.read_head, s_head, s_head + n) == s_head) ? n : 0u;
      s_done = (s_claimed == 0u && atomicAdd(queue.pending, 0u) == 0u) ? 1u : 0u;  // stays 0 once reached
    }
    barrier();
    if (lane < s_claimed) {
      uint pushed = process_item(packed);
      memoryBarrierBuffer();
      atomicAdd(queue.pending, pushed - 1u);  // children in, this item out: one atomic
    }
    if (s_done != 0u) break;  // uniform: read from shared memory by the whole workgroup
    barrier();
  }
  flush_counters();
}
