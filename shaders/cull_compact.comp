#version 460
// Compacts a bit set into a list in key order (canonical: independent of the order in which
// the bits were set). One workgroup: each invocation counts the set bits of a contiguous
// run of words, an exclusive scan over the workgroup gives each run its output offset, and
// the runs are written in order. Keys are decoded per push.mode (cull_shared.h).
#include "cull_common.glsl"

layout(local_size_x = VGEO_COMPACT_GROUP_SIZE) in;

shared uint s_offsets[kCompactGroupSize];

// The instance whose key range holds `key`: the last one with base ≤ key (bases ascend;
// an instance with nothing to key has the next one's base and is skipped by "last").
uint instance_of_key(uint key, bool items) {
  uint lo = 0u, hi = params.instance_count;  // answer in [lo, hi)
  while (hi - lo > 1u) {
    uint mid = (lo + hi) / 2u;
    uint base = items ? instances[mid].item_key_base : instances[mid].cluster_key_base;
    if (base <= key) lo = mid; else hi = mid;
  }
  return lo;
}

void emit(uint at, uint key) {
  if (push.mode == kCompactInstances) {
    list_out[kListHeaderWords + at] = key;
  } else if (push.mode == kCompactClusters) {
    uint i = instance_of_key(key, false);
    list_out[kListHeaderWords + 2u * at] = i;
    list_out[kListHeaderWords + 2u * at + 1u] = key - instances[i].cluster_key_base;
  } else {
    uint i = instance_of_key(key, true);
    uint local = key - instances[i].item_key_base;
    list_out[kListHeaderWords + 3u * at] = i;
    list_out[kListHeaderWords + 3u * at + 1u] = local / kItemKinds;
    list_out[kListHeaderWords + 3u * at + 2u] = local % kItemKinds;
  }
}

void main() {
  uint t = gl_LocalInvocationIndex;
  uint per = (push.word_count + kCompactGroupSize - 1u) / kCompactGroupSize;
  uint begin = min(t * per, push.word_count), end = min(begin + per, push.word_count);
  uint base = push.append != 0u ? list_out[0] : 0u;  // read by all before invocation 0 writes
  uint count = 0u;
  for (uint w = begin; w < end; ++w) count += bitCount(bits[push.word_begin + w]);
  s_offsets[t] = count;
  barrier();
  if (t == 0u) {  // exclusive scan (kCompactGroupSize entries: serial is cheap)
    uint sum = 0u;
    for (uint k = 0u; k < kCompactGroupSize; ++k) {
      uint c = s_offsets[k];
      s_offsets[k] = sum;
      sum += c;
    }
    list_out[0] = base + sum;
  }
  barrier();
  uint at = base + s_offsets[t];
  for (uint w = begin; w < end; ++w) {
    uint word = bits[push.word_begin + w];
    while (word != 0u) {
      uint b = findLSB(word);
      word &= word - 1u;
      emit(at++, (w << 5) + b);
    }
  }
}
