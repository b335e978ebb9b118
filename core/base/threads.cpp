#include "base/threads.h"

#include <tbb/info.h>

namespace cvt {

int resolve_threads(int requested) {
  return requested > 0 ? requested : tbb::info::default_concurrency();
}

}  // namespace cvt
