// The marching-cubes surface of a mask (ITK's itk::BinaryMask3DMeshSource, module ITKMesh, as a
// table of its 256 cube cases applied to every cube in parallel) and the Kuhn split of voxels
// into tets.
#include "fields/marching_cubes.h"

#include <itkBinaryMask3DMeshSource.h>
#include <itkImage.h>
#include <itkMesh.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <numeric>
#include <utility>

namespace cvt {
namespace {

using MaskImage = itk::Image<unsigned char, 3>;
using ItkMesh = itk::Mesh<double, 3>;

// The box of non-zero voxels, [lo, hi) per axis; empty (lo ≥ hi) when there are none.
struct Box {
  std::array<int, 3> lo{0, 0, 0}, hi{0, 0, 0};
  bool empty() const { return lo[0] >= hi[0]; }
};

Box object_box(const Mask& mask) {
  const Grid& g = mask.grid;
  const Box none{{g.dims[0], g.dims[1], g.dims[2]}, {0, 0, 0}};
  auto join = [](Box a, const Box& b) {
    for (int d = 0; d < 3; ++d)
      a.lo[d] = std::min(a.lo[d], b.lo[d]), a.hi[d] = std::max(a.hi[d], b.hi[d]);
    return a;
  };
  return tbb::parallel_reduce(
      tbb::blocked_range<int>(0, g.dims[2]), none,
      [&](const tbb::blocked_range<int>& r, Box box) {
        for (int k = r.begin(); k != r.end(); ++k)
          for (int j = 0; j < g.dims[1]; ++j) {
            const unsigned char* row = &mask.data[g.linear(0, j, k)];
            const unsigned char* end = row + g.dims[0];
            const unsigned char* first = std::find_if(row, end, [](unsigned char v) { return v; });
            if (first == end) continue;
            const unsigned char* last =
                std::find_if(std::make_reverse_iterator(end), std::make_reverse_iterator(first + 1),
                             [](unsigned char v) { return v; })
                    .base();
            box = join(box, Box{{int(first - row), j, k}, {int(last - row), j + 1, k + 1}});
          }
        return box;
      },
      join);
}

// A vertex by its doubled padded-image index (every vertex is a voxel centre, an edge or face
// midpoint or a cube centre, so these are integers), packed so that keys sort by (z, y, x).
constexpr int kKeyBits = 21;
std::uint64_t pack_key(std::uint64_t x, std::uint64_t y, std::uint64_t z) {
  return (z << (2 * kKeyBits)) | (y << kKeyBits) | x;
}
Vec3 key_index(std::uint64_t key) {
  const std::uint64_t mask = (std::uint64_t(1) << kKeyBits) - 1;
  return {double(key & mask) / 2, double((key >> kKeyBits) & mask) / 2,
          double(key >> (2 * kKeyBits)) / 2};
}

// ITK's triangles for each of the 256 cube configurations (corner b = (b & 1, b >> 1 & 1,
// b >> 2) is inside when bit b of the case is set), each vertex as its doubled offset from the
// cube's lowest corner (0, 1 or 2 per axis). ITK's filter looks at one cube at a time, so these
// make its surface of any mask; running it per case once, instead of over the mask, avoids its
// per-triangle cost (a heap cell and a global time stamp per point: on the liver 0.4 s of the
// evaluation's 0.6 s).
struct CaseTriangle {
  std::array<std::array<std::uint8_t, 3>, 3> corner;
};
using CaseTable = std::array<std::vector<CaseTriangle>, 256>;

CaseTable itk_case_table() {
  CaseTable table;
  for (int c = 1; c < 255; ++c) {
    // The cube's voxels at (1..2)³ of a 4³ image: the filter skips cubes at the image border.
    auto image = MaskImage::New();
    MaskImage::RegionType region;
    region.SetSize({4, 4, 4});
    image->SetRegions(region);
    image->Allocate();
    image->FillBuffer(0);
    for (int b = 0; b < 8; ++b)
      if (c >> b & 1) image->SetPixel({1 + (b & 1), 1 + ((b >> 1) & 1), 1 + (b >> 2)}, 1);
    auto filter = itk::BinaryMask3DMeshSource<MaskImage, ItkMesh>::New();
    filter->SetInput(image);
    filter->SetObjectValue(1);
    filter->Update();
    const ItkMesh* mesh = filter->GetOutput();
    if (!mesh->GetCells()) continue;
    for (auto it = mesh->GetCells()->Begin(); it != mesh->GetCells()->End(); ++it) {
      const auto* cell = it.Value();
      if (cell->GetNumberOfPoints() != 3) continue;
      CaseTriangle t;
      Vec3 centroid;
      for (int v = 0; v < 3; ++v) {
        const auto p = mesh->GetPoint(cell->PointIdsBegin()[v]);
        for (int a = 0; a < 3; ++a) {
          centroid[a] += p[unsigned(a)] / 3;
          t.corner[std::size_t(v)][std::size_t(a)] =
              std::uint8_t(std::lround(2 * (p[unsigned(a)] - 1)));
        }
      }
      // The neighbouring cubes' triangles (of the same voxels, seen from outside) lie outside.
      bool inside = true;
      for (int a = 0; a < 3; ++a) inside = inside && centroid[a] > 1 && centroid[a] < 2;
      if (inside) table[std::size_t(c)].push_back(t);
    }
  }
  return table;
}

const CaseTable& case_table() {
  static const CaseTable table = itk_case_table();
  return table;
}

// The box padded by one voxel of zeros all around; cube (i, j, k) has its lowest corner at
// padded voxel (i, j, k), so there are box size + 1 cubes per axis.
std::array<int, 3> cube_counts(const Box& box) {
  std::array<int, 3> cubes;
  for (int a = 0; a < 3; ++a) cubes[a] = box.hi[a] - box.lo[a] + 1;
  return cubes;
}

// Calls visit(i, c) for each cube (i, j, k) of a row whose case c (corner bit b = (b & 1,
// b >> 1 & 1, b >> 2) inside) is neither empty nor full. rows: scratch of 4 × (cubes[0] + 1).
template <class Visit>
void visit_cube_row(const Mask& mask, const Box& box, int j, int k,
                    std::array<std::vector<std::uint8_t>, 4>& rows, Visit&& visit) {
  const int nx = box.hi[0] - box.lo[0];
  for (int r = 0; r < 4; ++r) {  // padded rows (j, k), (j + 1, k), (j, k + 1), (j + 1, k + 1)
    std::vector<std::uint8_t>& row = rows[std::size_t(r)];
    row.assign(std::size_t(nx) + 2, 0);
    const int y = box.lo[1] + j + (r & 1) - 1, z = box.lo[2] + k + (r >> 1) - 1;
    if (y < box.lo[1] || y >= box.hi[1] || z < box.lo[2] || z >= box.hi[2]) continue;
    const unsigned char* in = &mask.data[mask.grid.linear(box.lo[0], y, z)];
    for (int i = 0; i < nx; ++i) row[std::size_t(i) + 1] = in[i] != 0;
  }
  // Corner bit b is row b >> 1 at x offset b & 1: stepping along x, the upper-x corners become
  // the lower-x ones.
  auto upper = [&](int x) {
    return rows[0][std::size_t(x)] << 1 | rows[1][std::size_t(x)] << 3 |
           rows[2][std::size_t(x)] << 5 | rows[3][std::size_t(x)] << 7;
  };
  int c = upper(0) >> 1;
  for (int i = 0; i <= nx; ++i) {
    c = (c >> 1 & 0x55) | upper(i + 1);
    if (c != 0 && c != 255) visit(i, c);
  }
}

}  // namespace

TriangleSurface marching_cubes(const Mask& mask) {
  if (mask.grid.voxel_count() == 0) return {};
  const Box box = object_box(mask);
  if (box.empty()) return {};
  const CaseTable& table = case_table();
  const std::array<int, 3> cubes = cube_counts(box);
  // Per cube layer, in parallel: its vertices' keys, sorted, and its triangles indexing them.
  // A vertex of cube row j in layer k has doubled coordinates x ≤ 2 cubes[0], y in {2j, 2j + 1,
  // 2j + 2} and z in {2k, 2k + 1, 2k + 2}, so a window of 3 × 3 rows numbers each vertex once;
  // row 2j + 2 becomes the next cube row's 2j.
  struct Layer {
    std::vector<std::uint64_t> keys;
    std::vector<Triangle> triangles;
  };
  std::vector<Layer> layers(static_cast<std::size_t>(cubes[2]));
  const std::size_t kx = 2 * std::size_t(cubes[0]) + 1;
  tbb::parallel_for(0, cubes[2], [&](int k) {
    Layer& out = layers[std::size_t(k)];
    std::vector<std::int32_t> window(9 * kx, -1);  // (z, y) row (3 z + y) of the window
    auto row_of = [&](std::size_t z, std::size_t y) {
      return window.begin() + std::ptrdiff_t((3 * z + y) * kx);
    };
    std::array<std::vector<std::uint8_t>, 4> rows;
    for (int j = 0; j < cubes[1]; ++j) {
      if (j > 0)
        for (std::size_t z = 0; z < 3; ++z) {
          std::copy(row_of(z, 2), row_of(z, 2) + std::ptrdiff_t(kx), row_of(z, 0));
          std::fill(row_of(z, 1), row_of(z, 1) + std::ptrdiff_t(2 * kx), -1);
        }
      visit_cube_row(mask, box, j, k, rows, [&](int i, int c) {
        for (const CaseTriangle& t : table[std::size_t(c)]) {
          Triangle tri;
          for (int v = 0; v < 3; ++v) {
            const auto& o = t.corner[std::size_t(v)];
            const std::size_t x = std::size_t(2 * i + o[0]);
            std::int32_t& id = row_of(o[2], o[1])[std::ptrdiff_t(x)];
            if (id < 0) {
              id = std::int32_t(out.keys.size());
              out.keys.push_back(
                  pack_key(x, std::uint64_t(2 * j + o[1]), std::uint64_t(2 * k + o[2])));
            }
            tri[std::size_t(v)] = id;
          }
          out.triangles.push_back(tri);
        }
      });
    }
    // Renumber the layer's vertices in key order.
    std::vector<std::int32_t> order(out.keys.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](std::int32_t a, std::int32_t b) {
      return out.keys[std::size_t(a)] < out.keys[std::size_t(b)];
    });
    std::vector<std::int32_t> rank(order.size());
    std::vector<std::uint64_t> sorted(order.size());
    for (std::size_t r = 0; r < order.size(); ++r)
      rank[std::size_t(order[r])] = std::int32_t(r), sorted[r] = out.keys[std::size_t(order[r])];
    out.keys.swap(sorted);
    for (Triangle& tri : out.triangles)
      for (std::int32_t& v : tri) v = rank[std::size_t(v)];
  });
  // Vertices in key order ((z, y, x) order); neighbouring layers share the plane between them.
  std::vector<std::uint64_t> keys;
  for (const Layer& layer : layers) keys.insert(keys.end(), layer.keys.begin(), layer.keys.end());
  tbb::parallel_sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  // Each layer's vertices to their global indices (both lists sorted), then its triangles.
  std::vector<std::size_t> first(layers.size() + 1, 0);
  for (std::size_t k = 0; k < layers.size(); ++k)
    first[k + 1] = first[k] + layers[k].triangles.size();
  TriangleSurface surface;
  surface.triangles.resize(first.back());
  tbb::parallel_for(std::size_t(0), layers.size(), [&](std::size_t k) {
    Layer& layer = layers[k];
    std::vector<std::int32_t> global(layer.keys.size());
    auto at = keys.begin();
    if (!layer.keys.empty()) at = std::lower_bound(keys.begin(), keys.end(), layer.keys[0]);
    for (std::size_t v = 0; v < layer.keys.size(); ++v) {
      while (*at < layer.keys[v]) ++at;
      global[v] = std::int32_t(at - keys.begin());
    }
    for (std::size_t t = 0; t < layer.triangles.size(); ++t)
      for (int v = 0; v < 3; ++v)
        surface.triangles[first[k] + t][std::size_t(v)] =
            global[std::size_t(layer.triangles[t][std::size_t(v)])];
    layer = {};
  });
  // Padded-image indices to world (mm).
  const Vec3 shift{box.lo[0] - 1.0, box.lo[1] - 1.0, box.lo[2] - 1.0};
  surface.vertices.resize(keys.size());
  tbb::parallel_for(std::size_t(0), keys.size(), [&](std::size_t v) {
    surface.vertices[v] = mask.grid.index_to_world(key_index(keys[v]) + shift);
  });
  // Normals out of the object whatever the filter's convention and the direction's handedness:
  // the enclosed volume must be positive.
  double volume = 0;
  const Vec3 o = surface.vertices.empty() ? Vec3{} : surface.vertices[0];
  for (const Triangle& t : surface.triangles)
    volume += dot(surface.vertices[t[0]] - o,
                  cross(surface.vertices[t[1]] - o, surface.vertices[t[2]] - o));
  if (volume < 0)
    for (Triangle& t : surface.triangles) std::swap(t[1], t[2]);
  return surface;
}

long long marching_cubes_euler(const Mask& mask) {
  if (mask.grid.voxel_count() == 0) return 0;
  const Box box = object_box(mask);
  if (box.empty()) return 0;
  // Per case, 8 × its share of V − F/2: a vertex at a voxel centre is shared by the 8 cubes
  // around it, one at an edge midpoint by 4, at a face centre by 2, at the cube centre by none,
  // and every cube around a vertex has it (the surface is closed).
  static const std::array<long long, 256> share = [] {
    std::array<long long, 256> out{};
    const CaseTable& table = case_table();
    for (std::size_t c = 0; c < 256; ++c) {
      std::vector<std::array<std::uint8_t, 3>> vertices;
      for (const CaseTriangle& t : table[c])
        for (const auto& v : t.corner) vertices.push_back(v);
      std::sort(vertices.begin(), vertices.end());
      vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
      for (const auto& v : vertices) out[c] += 1LL << ((v[0] & 1) + (v[1] & 1) + (v[2] & 1));
      out[c] -= 4 * (long long)table[c].size();
    }
    return out;
  }();
  const std::array<int, 3> cubes = cube_counts(box);
  const long long sum = tbb::parallel_reduce(
      tbb::blocked_range<int>(0, cubes[2]), 0LL,
      [&](const tbb::blocked_range<int>& r, long long total) {
        std::array<std::vector<std::uint8_t>, 4> rows;
        for (int k = r.begin(); k != r.end(); ++k)
          for (int j = 0; j < cubes[1]; ++j)
            visit_cube_row(mask, box, j, k, rows, [&](int, int c) { total += share[std::size_t(c)]; });
        return total;
      },
      std::plus<>());
  return sum / 8;
}

TetMesh voxel_tet_mesh(const Mask& mask) {
  const Grid& g = mask.grid;
  const int nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const std::size_t cx = std::size_t(nx) + 1, cy = std::size_t(ny) + 1;
  std::vector<std::int32_t> id(cx * cy * (std::size_t(nz) + 1), -1);
  TetMesh mesh;
  auto corner = [&](int i, int j, int k) {
    std::int32_t& v = id[(std::size_t(k) * cy + std::size_t(j)) * cx + std::size_t(i)];
    if (v < 0) {
      v = std::int32_t(mesh.vertices.size());
      mesh.vertices.push_back(g.index_to_world({i - 0.5, j - 0.5, k - 0.5}));
    }
    return v;
  };
  constexpr int kPerm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (!mask.at(i, j, k)) continue;
        std::int32_t c[8];
        for (int b = 0; b < 8; ++b) c[b] = corner(i + (b & 1), j + ((b >> 1) & 1), k + (b >> 2));
        for (const auto& p : kPerm) {
          const int b1 = 1 << p[0], b2 = b1 | (1 << p[1]);
          Tet t{c[0], c[b1], c[b2], c[7]};
          if (signed_volume(mesh, t) < 0) std::swap(t[2], t[3]);
          mesh.tets.push_back(t);
        }
      }
  return mesh;
}

}  // namespace cvt
