// The library's one way to use wider vector instructions: GCC function multiversioning. The
// code is written once (GCC vector extensions or plain loops), compiled for the x86-64 baseline
// (SSE2) and for AVX2, and the loader picks the version the CPU runs (ifunc); there is no
// hand-written dispatch. cvtcore builds with -ffp-contract=off, so every version rounds alike and
// results do not depend on the CPU (tests/test_isa_independence.py). Elsewhere (another
// compiler, CPU or OS) only the baseline is built.
#pragma once

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define CVT_MULTIVERSION 1
// On a function: one clone per instruction set of the same source.
#define CVT_CLONES __attribute__((target_clones("avx2", "default")))
// On a helper the clones call: inlined into each, so it is compiled for that clone's set.
#define CVT_INLINE_IN_CLONES __attribute__((always_inline)) inline
#else
#define CVT_MULTIVERSION 0
#define CVT_CLONES
#define CVT_INLINE_IN_CLONES inline
#endif
