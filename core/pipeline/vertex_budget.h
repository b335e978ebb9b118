// --vertices N: how r and the interior points are scaled together so that a mesh gets about N
// vertices. A mesh's vertices are its surface samples S (∝ 1/r²) and its interior sites n less
// the shallow ones; the shallow sites form a layer about one spacing thick under the surface,
// so their share of n falls as n^(−1/3) when n grows.
#pragma once

#include <cstdint>

namespace cvt {

// The r whose surface samples, with their matching interior sites, make about `target`
// vertices: r·√((S + n) / target) from the S samples and n default interior sites that r
// gives, clamped to (0, 1). The shallow sites are left out here; interior_points_for_budget
// then makes up for them.
double r_for_budget(double r, std::int64_t surface_samples, std::int64_t interior_sites,
                    std::int64_t target);

// The number of interior sites n that, with `surface_samples` kept and a shallow share of
// `shallow_share` measured at `probe_sites` sites (scaling as n^(−1/3)), leaves `target` − S
// interior vertices: n (1 − share(n)) = target − S. At least 1.
std::int64_t interior_points_for_budget(std::int64_t target, std::int64_t surface_samples,
                                        std::int64_t probe_sites, double shallow_share);

}  // namespace cvt
