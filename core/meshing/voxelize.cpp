#include "meshing/voxelize.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <iterator>
#include <tuple>

#include "fields/byte_runs.h"

namespace cvt {
namespace {

constexpr double kSlack = 1e-9;  // index units: a centre on a face counts as inside

using Corners = std::array<Vec3, 4>;  // a tet's corners in index space

// The voxels a tet's bounding box spans, clamped to the grid (a side may come out empty).
struct VoxelBox {
  std::array<int, 3> from, to;
};

VoxelBox voxel_box(const Corners& c, const Grid& grid) {
  VoxelBox box;
  for (int a = 0; a < 3; ++a) {
    double lo = c[0][a], hi = c[0][a];
    for (int k = 1; k < 4; ++k) {
      lo = std::min(lo, c[k][a]);
      hi = std::max(hi, c[k][a]);
    }
    // Clamped to just beyond the grid first, so that far-off corners stay in int range.
    const double beyond = grid.dims[a];
    box.from[a] = std::max(0, int(std::ceil(std::clamp(lo, -1.0, beyond) - kSlack)));
    box.to[a] = std::min(grid.dims[a] - 1, int(std::floor(std::clamp(hi, -1.0, beyond) + kSlack)));
  }
  return box;
}

Corners corners_of(const TetMesh& mesh, const Tet& t, const Grid& grid) {
  Corners c;
  for (int k = 0; k < 4; ++k) c[k] = grid.world_to_index(mesh.vertices[t[k]]);
  return c;
}

// Sets the voxels of `inside` whose centres lie in the tet (closed, with a little slack). The
// corners are put in a fixed order first, so the result depends on the tet's shape only, not on
// how a mesh happens to number it.
void voxelize_tet(Corners c, Mask& inside) {
  const Grid& grid = inside.grid;
  std::sort(c.begin(), c.end(), [](const Vec3& a, const Vec3& b) {
    return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
  });
  // Barycentric coordinates through the inverse of [c1−c0, c2−c0, c3−c0] (index space).
  const Vec3 e1 = c[1] - c[0], e2 = c[2] - c[0], e3 = c[3] - c[0];
  const double det = dot(e1, cross(e2, e3));
  if (std::abs(det) < 1e-12) return;
  const Vec3 r1 = cross(e2, e3) / det, r2 = cross(e3, e1) / det, r3 = cross(e1, e2) / det;
  const VoxelBox box = voxel_box(c, grid);
  // Along a row the barycentric coordinates are linear in i, so each of the four conditions
  // bounds i on one side: the row's voxels are tested only within those bounds widened by one
  // (far beyond rounding), with the same test as every other voxel. A coefficient too small to
  // bound i safely leaves that side to the test.
  const double slope[4] = {r1.x, r2.x, r3.x, r1.x + r2.x + r3.x};
  for (int k = box.from[2]; k <= box.to[2]; ++k)
    for (int j = box.from[1]; j <= box.to[1]; ++j) {
      const Vec3 q = Vec3{0.0, double(j), double(k)} - c[0];
      const double at0[4] = {dot(r1, q), dot(r2, q), dot(r3, q), 0};
      double lo_i = box.from[0], hi_i = box.to[0];
      for (int m = 0; m < 4; ++m) {
        const double b0 = m < 3 ? at0[m] : at0[0] + at0[1] + at0[2];
        const double limit = m < 3 ? -kSlack : 1 + kSlack;  // b ≥ limit (m < 3), b ≤ limit (m = 3)
        const double a = slope[m];
        if (std::abs(a) < 1e-6) continue;
        const double x = (limit - b0) / a;  // where b crosses its limit
        const bool lower = (m < 3) == (a > 0);
        if (lower) lo_i = std::max(lo_i, std::ceil(x) - 1);
        else hi_i = std::min(hi_i, std::floor(x) + 1);
      }
      if (lo_i > hi_i) continue;  // both now lie in [from, to]: safe to convert
      for (int i = int(lo_i); i <= int(hi_i); ++i) {
        const Vec3 p = Vec3{double(i), double(j), double(k)} - c[0];
        const double b1 = dot(r1, p), b2 = dot(r2, p), b3 = dot(r3, p);
        if (b1 >= -kSlack && b2 >= -kSlack && b3 >= -kSlack && b1 + b2 + b3 <= 1 + kSlack)
          std::atomic_ref<unsigned char>(inside.at(i, j, k)).store(1, std::memory_order_relaxed);
      }
    }
}

// Tets in parallel: neighbours share voxels, which they can only set to 1 (atomically), so the
// result does not depend on the order. `wanted` picks the tets (by index) to voxelize.
template <class Wanted>
void voxelize_tets(const TetMesh& mesh, Mask& inside, const Progress& progress, Wanted wanted) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.tets.size(), 2048),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      progress.check_cancelled();
                      for (std::size_t n = range.begin(); n != range.end(); ++n) {
                        const Corners c = corners_of(mesh, mesh.tets[n], inside.grid);
                        if (wanted(c)) voxelize_tet(c, inside);
                      }
                    });
}

// Blocks of kBlock³ voxels, flagged when a changed tet's box reaches them.
constexpr int kBlock = 8;

class BlockFlags {
 public:
  explicit BlockFlags(const Grid& grid) {
    for (int a = 0; a < 3; ++a) dims_[a] = (grid.dims[a] + kBlock - 1) / kBlock;
    flags_.assign(std::size_t(dims_[0]) * dims_[1] * dims_[2], 0);
  }
  template <class Visit>
  void for_each_in(const VoxelBox& box, Visit visit) const {
    for (int k = box.from[2] / kBlock; k <= box.to[2] / kBlock; ++k)
      for (int j = box.from[1] / kBlock; j <= box.to[1] / kBlock; ++j)
        for (int i = box.from[0] / kBlock; i <= box.to[0] / kBlock; ++i)
          if (visit(at(i, j, k))) return;
  }
  void flag(const VoxelBox& box) {
    for_each_in(box, [&](std::size_t b) {
      flags_[b] = 1;
      return false;
    });
  }
  bool any(const VoxelBox& box) const {
    bool found = false;
    for_each_in(box, [&](std::size_t b) { return found = flags_[b] != 0; });
    return found;
  }
  // The flagged blocks' voxels go back to 0.
  void clear_flagged(Mask& inside) const {
    const Grid& g = inside.grid;
    tbb::parallel_for(0, dims_[2], [&](int bk) {
      for (int bj = 0; bj < dims_[1]; ++bj)
        for (int bi = 0; bi < dims_[0]; ++bi) {
          if (!flags_[at(bi, bj, bk)]) continue;
          const int i0 = bi * kBlock, i1 = std::min(g.dims[0], i0 + kBlock);
          for (int k = bk * kBlock; k < std::min(g.dims[2], (bk + 1) * kBlock); ++k)
            for (int j = bj * kBlock; j < std::min(g.dims[1], (bj + 1) * kBlock); ++j)
              std::fill(&inside.at(i0, j, k), &inside.at(i0, j, k) + (i1 - i0), 0);
        }
    });
  }

 private:
  std::size_t at(int i, int j, int k) const {
    return (std::size_t(k) * dims_[1] + j) * dims_[0] + i;
  }
  std::array<int, 3> dims_;
  std::vector<char> flags_;
};

bool box_is_empty(const VoxelBox& box) {
  for (int a = 0; a < 3; ++a)
    if (box.from[a] > box.to[a]) return true;
  return false;
}

// The runs of set voxels along each row, in index order (rows by k-slice in parallel).
template <class Run>
std::vector<Run> runs_of(const Mask& mask) {
  const Grid& g = mask.grid;
  std::vector<std::vector<Run>> slices(std::size_t(g.dims[2]));
  tbb::parallel_for(0, g.dims[2], [&](int k) {
    for (int j = 0; j < g.dims[1]; ++j) {
      const std::size_t row = g.linear(0, j, k);
      const unsigned char* bytes = mask.data.data() + row;
      for (int i = detail::next_nonzero_byte(bytes, 0, g.dims[0]); i < g.dims[0];) {
        const int end = detail::next_zero_byte(bytes, i, g.dims[0]);
        slices[std::size_t(k)].push_back({row + std::size_t(i), std::int32_t(end - i)});
        i = detail::next_nonzero_byte(bytes, end, g.dims[0]);
      }
    }
  });
  std::vector<Run> runs;
  for (const auto& slice : slices) runs.insert(runs.end(), slice.begin(), slice.end());
  return runs;
}

}  // namespace

Mask voxelize(const TetMesh& mesh, const Grid& grid, const Progress& progress) {
  Mask inside(grid, 0);
  voxelize_tets(mesh, inside, progress, [](const Corners&) { return true; });
  return inside;
}

IncrementalVoxelizer::IncrementalVoxelizer(const Grid& grid) : grid_(grid) {}

Mask IncrementalVoxelizer::update(const TetMesh& mesh, const std::vector<std::int32_t>& vertex_id,
                                  const Progress& progress) {
  const Grid& grid = grid_;
  Mask inside(grid, 0);
  for (const Run& r : inside_) std::fill_n(inside.data.begin() + std::ptrdiff_t(r.start), r.length, 1);
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const std::size_t id = std::size_t(vertex_id[v]);
    if (id >= corner_.size()) corner_.resize(id + 1);
    corner_[id] = grid.world_to_index(mesh.vertices[v]);
  }
  std::vector<std::array<std::int32_t, 4>> tets(mesh.tets.size());
  tbb::parallel_for(std::size_t(0), tets.size(), [&](std::size_t n) {
    for (int k = 0; k < 4; ++k) tets[n][k] = vertex_id[std::size_t(mesh.tets[n][k])];
    std::sort(tets[n].begin(), tets[n].end());
  });
  tbb::parallel_sort(tets.begin(), tets.end());
  if (empty_) {
    voxelize_tets(mesh, inside, progress, [](const Corners&) { return true; });
  } else {
    // A voxel none of the changed tets' boxes reach is covered by the same tets as before.
    std::vector<std::array<std::int32_t, 4>> changed;
    std::set_symmetric_difference(tets_.begin(), tets_.end(), tets.begin(), tets.end(),
                                  std::back_inserter(changed));
    BlockFlags dirty(grid);
    for (const auto& t : changed) {
      const VoxelBox box =
          voxel_box({corner_[t[0]], corner_[t[1]], corner_[t[2]], corner_[t[3]]}, grid);
      if (!box_is_empty(box)) dirty.flag(box);
    }
    dirty.clear_flagged(inside);
    voxelize_tets(mesh, inside, progress, [&](const Corners& c) {
      const VoxelBox box = voxel_box(c, grid);
      return !box_is_empty(box) && dirty.any(box);
    });
  }
  empty_ = false;
  tets_ = std::move(tets);
  inside_ = runs_of<Run>(inside);
  return inside;
}

}  // namespace cvt
