#include "pipeline/vertex_budget.h"

#include <algorithm>
#include <cmath>

namespace cvt {

double r_for_budget(double r, std::int64_t surface_samples, std::int64_t interior_sites,
                    std::int64_t target) {
  const double total = double(surface_samples + interior_sites);
  if (target <= 0 || total <= 0) return r;
  return std::clamp(r * std::sqrt(total / double(target)), 0.02, 0.95);
}

std::int64_t interior_points_for_budget(std::int64_t target, std::int64_t surface_samples,
                                        std::int64_t probe_sites, double shallow_share) {
  const double want = double(target - surface_samples);
  if (want <= 1) return 1;
  const double share = std::clamp(shallow_share, 0.0, 0.95);
  // Fixed point of n = want / (1 − share · (probe / n)^(1/3)); the share only falls as n grows,
  // so from n = want it rises monotonically to the root.
  double n = want;
  for (int i = 0; i < 50; ++i) {
    const double s = std::min(0.95, share * std::cbrt(double(probe_sites) / n));
    const double next = want / (1.0 - s);
    if (std::abs(next - n) < 0.5) {
      n = next;
      break;
    }
    n = next;
  }
  return std::max<std::int64_t>(1, std::llround(n));
}

}  // namespace cvt
