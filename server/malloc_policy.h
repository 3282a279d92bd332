// glibc malloc settings for a process that moves megabyte-sized gRPC messages (issue 12). Set
// once at start, as early as possible: glintd's main and the benchmarks' in-process loopback
// service (bench/lib/loopback_service.h), so that the end_to_end rows measure glintd's setting.
//
// Why. gRPC reads a message into receive buffers about as large as the message, and the stream
// allocates chunk messages and replies of several MiB. Served by mmap (glintd used a 1 MiB
// M_MMAP_THRESHOLD), every such buffer was faulted in and zeroed page by page and unmapped when
// freed: ~11k page faults and ~170 ms CPU per 1M-probe stream on loopback, against ~60 ms with
// the blocks kept in the heap (bench_transport --end-to-end-only under `perf stat -e page-faults`,
// GLIBC_TUNABLES). The 1 MiB threshold bounded RSS by returning freed blocks to the system; here
// the heap keeps them for the next message instead, and the bound comes from
// - M_ARENA_MAX 2: gRPC's many threads share two heaps, so freed blocks are reused rather than
//   left idle in one heap per thread (glibc's default is 8 per core);
// - M_TRIM_THRESHOLD 64 MiB: at most that much free memory at the top of a heap stays mapped;
// - M_MMAP_THRESHOLD 32 MiB (glibc's maximum): only blocks beyond it, larger than glintd's
//   messages by default, are mapped and unmapped per use.
#pragma once

namespace glint {

// Applies the settings above; returns false if glibc refused one (the process still runs).
bool ConfigureMallocForMessages();

}  // namespace glint
