#include "runtime/allocator.hpp"

#include <malloc.h>

namespace harvest::rt {

bool keep_freed_memory() {
  constexpr int kMmapThreshold = 32 << 20;  // glibc's largest on 64-bit (DEFAULT_MMAP_THRESHOLD_MAX)
  constexpr int kTrimThreshold = 64 << 20;
  const bool mmap_ok = mallopt(M_MMAP_THRESHOLD, kMmapThreshold) == 1;
  const bool trim_ok = mallopt(M_TRIM_THRESHOLD, kTrimThreshold) == 1;
  return mmap_ok && trim_ok;
}

}  // namespace harvest::rt
