// Force-included (-include) into the clang fuzz build. Debian's ITK headers were generated for
// GCC only: itk_compiler_detection.h stops with "Unsupported compiler" under clang. Clang is
// GCC-compatible for everything those headers use, so they are shown GCC 12 while they decide.
#pragma once
#if defined(__clang__) && defined(__has_include)
#if __has_include(<itk_compiler_detection.h>)
#pragma push_macro("__clang__")
#pragma push_macro("__GNUC__")
#pragma push_macro("__GNUC_MINOR__")
#undef __clang__
#undef __GNUC__
#undef __GNUC_MINOR__
#define __GNUC__ 12
#define __GNUC_MINOR__ 2
#include <itk_compiler_detection.h>
#pragma pop_macro("__GNUC_MINOR__")
#pragma pop_macro("__GNUC__")
#pragma pop_macro("__clang__")
#endif
#endif
