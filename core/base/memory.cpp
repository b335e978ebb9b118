#include "base/memory.h"

#include <tbb/parallel_for.h>

#include <cstdint>
#include <fstream>
#include <sstream>

#ifdef __linux__
#include <sys/mman.h>
#endif

#include "base/errors.h"

namespace cvt {
namespace {

// Reads "<key>: <n> kB" from a /proc file; 0 when absent.
std::size_t read_kb_field(const char* file, const std::string& key) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.compare(0, key.size(), key) == 0 && line.size() > key.size() &&
        line[key.size()] == ':') {
      std::istringstream s(line.substr(key.size() + 1));
      std::size_t kb = 0;
      s >> kb;
      return kb * 1024;
    }
  }
  return 0;
}

}  // namespace

std::size_t peak_rss_bytes() { return read_kb_field("/proc/self/status", "VmHWM"); }
std::size_t current_rss_bytes() { return read_kb_field("/proc/self/status", "VmRSS"); }
std::size_t available_memory_bytes() { return read_kb_field("/proc/meminfo", "MemAvailable"); }

void require_memory(std::size_t bytes, std::size_t limit_bytes, const std::string& what) {
  const std::size_t limit = limit_bytes ? limit_bytes : available_memory_bytes();
  if (limit && bytes > limit) {
    std::ostringstream msg;
    msg << what << ": needs about " << bytes / (1024 * 1024) << " MB but only "
        << limit / (1024 * 1024) << " MB " << (limit_bytes ? "are allowed" : "are available");
    throw InputError(msg.str());
  }
}

void fault_in_pages(void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE) && defined(MADV_POPULATE_WRITE)
  constexpr std::uintptr_t kHuge = std::uintptr_t(2) << 20;
  // Whole 2 MiB pages inside the buffer (the partial ones at its ends fault in when written).
  const std::uintptr_t begin = (std::uintptr_t(data) + kHuge - 1) & ~(kHuge - 1);
  const std::uintptr_t end = (std::uintptr_t(data) + bytes) & ~(kHuge - 1);
  if (end <= begin) return;
  madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
  // Errors (an old kernel) leave the pages to fault in when first written, as without this.
  tbb::parallel_for(std::uintptr_t(0), (end - begin) / kHuge, [&](std::uintptr_t page) {
    madvise(reinterpret_cast<void*>(begin + page * kHuge), kHuge, MADV_POPULATE_WRITE);
  });
#else
  (void)data;
  (void)bytes;
#endif
}

}  // namespace cvt
