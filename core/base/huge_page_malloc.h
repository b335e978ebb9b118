// Transparent huge pages for everything malloc hands out.
#pragma once

namespace cvt {

// Re-executes this process (same pid, same arguments) with glibc's malloc tunable
// glibc.malloc.hugetlb=1, so that malloc asks the kernel for transparent huge pages, and (unless
// the environment sets it) glibc.malloc.arena_max=1, so that every thread's memory comes from
// the one heap that gets them. Faulting in fresh 4 KiB pages was a tenth of a whole run's time
// (the liver 9 %, the brain-size phantom 15 %, same bytes out, same peak memory). Call it first
// in main(), before any thread starts. Returns (doing nothing) when the environment already sets
// glibc.malloc.hugetlb (so a user can say glibc.malloc.hugetlb=0), when the kernel has
// transparent huge pages off, under a sanitizer (it brings its own malloc), or when the exec
// fails.
void reexec_with_huge_page_malloc(char** argv);

}  // namespace cvt
