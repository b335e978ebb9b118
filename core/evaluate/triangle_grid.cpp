#include "evaluate/triangle_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "base/memory.h"

namespace cvt {

double point_triangle_squared_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  // The region of the triangle's plane that p projects into, from the signs of the projections
  // of p − vertex on the two edges out of a (Ericson, Real-Time Collision Detection, 5.1.5).
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return squared_norm(ap);  // vertex a
  const Vec3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return squared_norm(bp);  // vertex b
  const Vec3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return squared_norm(cp);  // vertex c
  const double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return squared_norm(ap - ab * (d1 / (d1 - d3)));  // edge ab
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return squared_norm(ap - ac * (d2 / (d2 - d6)));  // edge ac
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)                                         // edge bc
    return squared_norm(bp - (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
  // Inside the face: the distance to its plane, unless the triangle is (nearly) degenerate, the
  // sine of its angle at a below 1e-6: a needle no wider than 1e-6 of its length, whose edges are
  // as near as its face and whose plane is meaningless.
  const Vec3 n = cross(ab, ac);
  const double nn = squared_norm(n);
  if (!(nn > 1e-12 * squared_norm(ab) * squared_norm(ac))) {
    auto segment = [&](const Vec3& s, const Vec3& t) {
      const Vec3 st = t - s;
      const double l = squared_norm(st);
      const double u = l > 0 ? std::clamp(dot(p - s, st) / l, 0.0, 1.0) : 0.0;
      return squared_norm(p - s - st * u);
    };
    return std::min({segment(a, b), segment(b, c), segment(c, a)});
  }
  const double height = dot(n, ap);
  return height * height / nn;
}

namespace {

// Each dimension's cell count, with cells of `cell` over [lo, hi].
std::array<int, 3> cell_counts(const Vec3& lo, const Vec3& hi, double cell) {
  std::array<int, 3> n;
  for (int a = 0; a < 3; ++a) n[a] = std::max(1, int(std::ceil((hi[a] - lo[a]) / cell)));
  return n;
}

}  // namespace

TriangleGrid::TriangleGrid(const TriangleSurface& surface, double cell_mm) : surface_(&surface) {
  const auto& v = surface.vertices;
  const auto& tris = surface.triangles;
  if (tris.empty()) return;
  Vec3 lo = v[tris[0][0]], hi = lo;
  double edges = 0;
  for (const Triangle& t : tris) {
    for (int i = 0; i < 3; ++i)
      for (int a = 0; a < 3; ++a)
        lo[a] = std::min(lo[a], v[t[i]][a]), hi[a] = std::max(hi[a], v[t[i]][a]);
    edges += std::sqrt(
        std::max({cvt::squared_distance(v[t[0]], v[t[1]]), cvt::squared_distance(v[t[1]], v[t[2]]),
                  cvt::squared_distance(v[t[2]], v[t[0]])}));
  }
  lo_ = lo;
  // A cell twice the size of a triangle holds a few of them and is searched with its neighbours;
  // at most about four cells per triangle (most cells are empty: they hold no surface).
  cell_ = cell_mm > 0 ? cell_mm : 2 * edges / double(tris.size());
  cell_ = std::max(cell_, 1e-9 * (1 + norm(hi - lo)));
  const double max_cells = 4.0 * double(tris.size()) + 64;
  n_ = cell_counts(lo, hi, cell_);
  while (double(n_[0]) * n_[1] * n_[2] > max_cells) cell_ *= 1.25, n_ = cell_counts(lo, hi, cell_);

  // Counting sort of (cell, triangle) pairs, triangles ascending within a cell.
  const std::size_t cells = std::size_t(n_[0]) * std::size_t(n_[1]) * std::size_t(n_[2]);
  resize_large(start_, cells + 1);  // zeros; large buffers are faulted in on all threads
  auto for_each_cell = [&](const Triangle& t, auto&& f) {
    std::array<int, 3> c0, c1;
    for (int a = 0; a < 3; ++a) {
      const double tlo = std::min({v[t[0]][a], v[t[1]][a], v[t[2]][a]});
      const double thi = std::max({v[t[0]][a], v[t[1]][a], v[t[2]][a]});
      c0[a] = cell_of(tlo, a), c1[a] = cell_of(thi, a);
    }
    for (int k = c0[2]; k <= c1[2]; ++k)
      for (int j = c0[1]; j <= c1[1]; ++j)
        for (int i = c0[0]; i <= c1[0]; ++i)
          f((std::size_t(k) * std::size_t(n_[1]) + std::size_t(j)) * std::size_t(n_[0]) +
            std::size_t(i));
  };
  for (const Triangle& t : tris) for_each_cell(t, [&](std::size_t c) { ++start_[c + 1]; });
  for (std::size_t c = 0; c < cells; ++c) start_[c + 1] += start_[c];
  resize_large(entries_, start_[cells]);
  std::vector<std::uint32_t> fill;
  resize_large(fill, cells);
  std::copy(start_.begin(), start_.end() - 1, fill.begin());
  for (std::size_t t = 0; t < tris.size(); ++t) {
    const Triangle& tri = tris[t];
    const Vec3 m = (v[tri[0]] + v[tri[1]] + v[tri[2]]) * (1.0 / 3);
    const double r = std::sqrt(
        std::max({cvt::squared_distance(m, v[tri[0]]), cvt::squared_distance(m, v[tri[1]]),
                  cvt::squared_distance(m, v[tri[2]])}));
    // In single precision, the radius grown by more than the rounding of the centre.
    Entry e{float(m.x), float(m.y), float(m.z),
            std::nextafter(float(r + 1e-6 * (1 + norm(m))), std::numeric_limits<float>::max()),
            std::int32_t(t)};
    for_each_cell(tri, [&](std::size_t c) { entries_[fill[c]++] = e; });
  }
}

int TriangleGrid::cell_of(double v, int a) const {
  // Truncation is the floor once clamped at 0; NaN goes to 0.
  return int(std::max(0.0, std::min((v - lo_[a]) / cell_, double(n_[a] - 1))));
}

double TriangleGrid::gap(int c, int a, double v) const {
  const double c_lo = lo_[a] + c * cell_;
  return std::max({0.0, c_lo - v, v - (c_lo + cell_)});
}

double TriangleGrid::squared_distance(const Vec3& p, std::int32_t* nearest) const {
  double best = std::numeric_limits<double>::infinity();
  if (empty()) return best;
  const auto& v = surface_->vertices;
  const auto& tris = surface_->triangles;
  const std::array<int, 3> c{cell_of(p.x, 0), cell_of(p.y, 1), cell_of(p.z, 2)};
  double best_root = best;  // √best
  std::int32_t found = -1;
  auto search_cell = [&](std::size_t cell) {
    for (std::uint32_t i = start_[cell]; i < start_[cell + 1]; ++i) {
      const Entry& e = entries_[i];
      const double dx = p.x - e.x, dy = p.y - e.y, dz = p.z - e.z, reach = best_root + e.radius;
      if (dx * dx + dy * dy + dz * dz >= reach * reach) continue;  // the sphere is too far
      const Triangle& t = tris[std::size_t(e.triangle)];
      const double d = point_triangle_squared_distance(p, v[t[0]], v[t[1]], v[t[2]]);
      if (d < best) best = d, best_root = std::sqrt(d), found = e.triangle;
    }
  };
  // A first guess, so that the spheres skip most triangles: the one given, else the triangle of
  // p's cell with the nearest centroid.
  std::int32_t guess = nearest ? *nearest : -1;
  if (guess < 0 || std::size_t(guess) >= tris.size()) {
    guess = -1;
    const std::size_t cell =
        (std::size_t(c[2]) * std::size_t(n_[1]) + std::size_t(c[1])) * std::size_t(n_[0]) +
        std::size_t(c[0]);
    double closest = std::numeric_limits<double>::infinity();
    for (std::uint32_t i = start_[cell]; i < start_[cell + 1]; ++i) {
      const Entry& e = entries_[i];
      const double dx = p.x - e.x, dy = p.y - e.y, dz = p.z - e.z, d = dx * dx + dy * dy + dz * dz;
      if (d < closest) closest = d, guess = e.triangle;
    }
  }
  if (guess >= 0) {
    const Triangle& t = tris[std::size_t(guess)];
    best = point_triangle_squared_distance(p, v[t[0]], v[t[1]], v[t[2]]);
    best_root = std::sqrt(best), found = guess;
  }
  for (int r = 0;; ++r) {
    // A cell of ring r (Chebyshev distance r from p's cell) is r cells away along some axis, so
    // it is at least that axis's gap away.
    if (r > 0) {
      double bound = std::numeric_limits<double>::infinity();
      for (int a = 0; a < 3; ++a) {
        if (c[a] - r >= 0) bound = std::min(bound, gap(c[a] - r, a, p[a]));
        if (c[a] + r < n_[a]) bound = std::min(bound, gap(c[a] + r, a, p[a]));
      }
      if (bound * bound >= best) break;  // also when no ring-r cell exists (bound = +inf)
    }
    const int k0 = std::max(0, c[2] - r), k1 = std::min(n_[2] - 1, c[2] + r);
    const int j0 = std::max(0, c[1] - r), j1 = std::min(n_[1] - 1, c[1] + r);
    const int i0 = std::max(0, c[0] - r), i1 = std::min(n_[0] - 1, c[0] + r);
    for (int k = k0; k <= k1; ++k) {
      const double gz = gap(k, 2, p.z);
      if (gz * gz >= best) continue;
      for (int j = j0; j <= j1; ++j) {
        const double gy = gap(j, 1, p.y), gyz = gz * gz + gy * gy;
        if (gyz >= best) continue;
        const std::size_t row =
            (std::size_t(k) * std::size_t(n_[1]) + std::size_t(j)) * std::size_t(n_[0]);
        auto visit = [&](int i) {
          const double gx = gap(i, 0, p.x);
          if (gyz + gx * gx < best) search_cell(row + std::size_t(i));
        };
        if (std::abs(k - c[2]) == r || std::abs(j - c[1]) == r) {
          for (int i = i0; i <= i1; ++i) visit(i);
        } else {  // inside the ring's box: only its two ends along x are on the ring
          if (c[0] - r >= 0) visit(c[0] - r);
          if (c[0] + r < n_[0]) visit(c[0] + r);
        }
      }
    }
  }
  if (nearest) *nearest = found;
  return best;
}

}  // namespace cvt
