#pragma once
// COLLIDE_AVX2_CLONES before a function builds it twice, for AVX2 and for
// the baseline instruction set, and the loader picks the one the processor
// runs (GCC/Clang target_clones). For the hot per-pixel and per-sample loops
// of the detectors; each clone does the same operations in the same order, so
// both give the same numbers. On other processors the function is built once.
// (The ray-cast renderer has its own, GCC-only, switch: COLLIDE_SIMD_CLONES in
// vision/render_trace.hpp.)
//
// COLLIDE_INLINE_KERNEL before a small loop kernel called from a cloned
// function puts it inside each clone (built for that clone's instruction
// set), rather than behind a clone of its own: a call through the loader's
// choice costs an indirect call per use and keeps the kernel from being
// optimised with its caller (2 % of the sphere detector's time). Always
// inlined, such a kernel may take and return vector values (it has no
// calling convention of its own to differ between the builds); a clone
// should call nothing else in its hot loop that is built for the baseline
// (one such call per profile made the detector twice as slow).
//
// COLLIDE_NO_CLONES (defined for collide_vision_baseline, vision/CMakeLists.txt)
// builds everything for the baseline only: the test vision/clones_agree runs
// a simulated shot through both builds and requires the same numbers.

#if defined(__x86_64__) && defined(__GNUC__) && !defined(COLLIDE_NO_CLONES)
#define COLLIDE_AVX2_CLONES __attribute__((target_clones("avx2", "default")))
#define COLLIDE_INLINE_KERNEL inline __attribute__((always_inline))
#else
#define COLLIDE_AVX2_CLONES
#define COLLIDE_INLINE_KERNEL inline
#endif
