#pragma once
// The process's peak memory, as the builder's report and `vgeo bench build` state it.
#include <cstdint>

namespace vgeo {

// Peak resident set of this process image, in bytes: VmHWM of /proc/self/status (Linux), the
// high-water mark of the address space since exec. getrusage's ru_maxrss is the fallback: it
// also counts the address space the process had before exec, so a process started by vfork or
// posix_spawn from a larger one reports its parent's peak (`vgeo bench build`'s children did:
// 39 MiB for bunny00 against 20 MiB measured by /usr/bin/time).
uint64_t peak_rss_bytes();

}  // namespace vgeo
