// Portable SIMD for the feature hot paths (Shi-Tomasi, Lucas-Kanade,
// pyramids). Kernels are written once with GCC/Clang vector extensions
// (8 floats / 8 int32 / 4 doubles per vector) as always-inline templates and
// compiled twice: for baseline x86-64 (SSE2: each vector is two halves) and
// for AVX2. The AVX2 build is chosen at run time when the CPU has it, so one
// binary runs everywhere. The AVX2 build does not enable FMA: both builds
// perform the same IEEE operations in the same order and give bit-identical
// results (tests/unit/features check it), so a replay is identical on any
// x86-64 machine.
#pragma once

#include <cstdint>
#include <cstring>

// The always-inline helpers below pass 32-byte vectors by value; they never
// exist as out-of-line calls, so the AVX calling-convention note is moot.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"

namespace harvest::features::simd {

using v8f = float __attribute__((vector_size(32)));
using v8i = int32_t __attribute__((vector_size(32)));
using v4d = double __attribute__((vector_size(32)));

#define HARVEST_SIMD_INLINE __attribute__((always_inline)) inline

HARVEST_SIMD_INLINE v8f load8(const float* p) {
  v8f v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
HARVEST_SIMD_INLINE void store8(float* p, v8f v) { std::memcpy(p, &v, sizeof v); }
HARVEST_SIMD_INLINE v8i load8(const int32_t* p) {
  v8i v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
HARVEST_SIMD_INLINE void store8(int32_t* p, v8i v) { std::memcpy(p, &v, sizeof v); }
HARVEST_SIMD_INLINE v8f splat(float x) { return v8f{} + x; }
HARVEST_SIMD_INLINE float sum(v8f v) {
  // Fixed order: both builds add the lanes identically.
  return ((v[0] + v[4]) + (v[1] + v[5])) + ((v[2] + v[6]) + (v[3] + v[7]));
}

// True when the running CPU has AVX2 (checked once).
bool have_avx2();

}  // namespace harvest::features::simd

#pragma GCC diagnostic pop

// HARVEST_SIMD_DISPATCH(name, impl, ret, params, args): defines
// `ret name(bool simd, params)` that runs `impl` (an always-inline template
// or function) compiled for AVX2 when `simd` and the CPU allow, else for the
// baseline. Parenthesise params and args: (const float* a, int n), (a, n).
#define HARVEST_SIMD_STRIP(...) __VA_ARGS__
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define HARVEST_SIMD_DISPATCH(name, impl, ret, params, args)                                       \
  __attribute__((target("avx2"))) ret name##_avx2(HARVEST_SIMD_STRIP params) { return impl args; } \
  ret name##_base(HARVEST_SIMD_STRIP params) { return impl args; }                                 \
  ret name(bool simd, HARVEST_SIMD_STRIP params) {                                                 \
    return simd && ::harvest::features::simd::have_avx2() ? name##_avx2 args : name##_base args;   \
  }
#else
#define HARVEST_SIMD_DISPATCH(name, impl, ret, params, args) \
  ret name(bool, HARVEST_SIMD_STRIP params) { return impl args; }
#endif
