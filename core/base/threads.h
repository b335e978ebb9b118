// How many threads a run uses, for the CLI and the viewer alike.
#pragma once

namespace cvt {

// The thread count asked for (Parameters::threads, --threads), or all cores when it is 0 or
// less.
int resolve_threads(int requested);

}  // namespace cvt
