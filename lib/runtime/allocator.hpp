// How a process's heap treats large blocks.
#pragma once

namespace harvest::rt {

// glibc gives blocks above its mmap threshold (128 kB at start) their own
// mapping and unmaps them when freed, and trims the heap's top above 128 kB:
// a detector that builds a 300 kB distance map and label image for every
// frame page-faults them in afresh each time (a third of a tree log's
// replay went to the kernel's page-fault handler). Blocks up to 32 MB now
// come from the heap, and up to 64 MB of freed memory is kept for the next
// frame. Called once at start by every node process and by the replay tool;
// true if glibc took both settings.
bool keep_freed_memory();

}  // namespace harvest::rt
