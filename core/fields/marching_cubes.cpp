// The marching-cubes surface of a mask (ITK's itk::BinaryMask3DMeshSource, module ITKMesh, run on
// z-slabs in parallel) and the Kuhn split of voxels into tets.
#include "fields/marching_cubes.h"

#include <itkBinaryMask3DMeshSource.h>
#include <itkImage.h>
#include <itkMesh.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>

namespace cvt {
namespace {

using MaskImage = itk::Image<unsigned char, 3>;
using ItkMesh = itk::Mesh<double, 3>;

// Cube layers per ITK run: enough runs to keep two cores busy on a liver-size object, few enough
// that the per-run set-up does not show. A constant, so the output does not depend on threads.
constexpr int kSlabLayers = 16;

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

// The box of the mask as 0/1 with one voxel of zeros all around (the filter leaves an object
// that touches the image border open). Unit spacing and zero origin, so the filter's points are
// indices of this image: half-integers, exact.
MaskImage::Pointer padded_box_image(const Mask& mask, const Box& box) {
  auto image = MaskImage::New();
  MaskImage::RegionType region;
  for (unsigned a = 0; a < 3; ++a) region.SetSize(a, itk::SizeValueType(box.hi[a] - box.lo[a] + 2));
  image->SetRegions(region);
  image->Allocate();
  image->FillBuffer(0);
  unsigned char* out = image->GetBufferPointer();
  const std::size_t nx = region.GetSize(0), ny = region.GetSize(1);
  tbb::parallel_for(box.lo[2], box.hi[2], [&](int k) {
    for (int j = box.lo[1]; j < box.hi[1]; ++j) {
      unsigned char* row =
          out + (std::size_t(k - box.lo[2] + 1) * ny + std::size_t(j - box.lo[1] + 1)) * nx + 1;
      const unsigned char* in = &mask.data[mask.grid.linear(box.lo[0], j, k)];
      for (int i = 0; i < box.hi[0] - box.lo[0]; ++i) row[i] = in[i] != 0;
    }
  });
  return image;
}

// A vertex by its doubled padded-image index (every vertex is a voxel centre or an edge
// midpoint, so these are integers), packed so that keys sort by (z, y, x).
constexpr int kKeyBits = 21;
std::uint64_t vertex_key(double x, double y, double z) {
  auto twice = [](double v) { return std::uint64_t(std::llround(2 * v)); };
  return (twice(z) << (2 * kKeyBits)) | (twice(y) << kKeyBits) | twice(x);
}
Vec3 key_index(std::uint64_t key) {
  const std::uint64_t mask = (std::uint64_t(1) << kKeyBits) - 1;
  return {double(key & mask) / 2, double((key >> kKeyBits) & mask) / 2,
          double(key >> (2 * kKeyBits)) / 2};
}

// One ITK run over the cubes whose lowest corner has z in [z0, z1): its vertices as sorted keys,
// its triangles indexing them. The filter makes a few copies of some vertices when its region
// does not start at the image's first slice; welding them by key undoes that.
struct Slab {
  std::vector<std::uint64_t> keys;
  std::vector<Triangle> triangles;
};

Slab slab_surface(const MaskImage* image, int z0, int z1) {
  auto filter = itk::BinaryMask3DMeshSource<MaskImage, ItkMesh>::New();
  filter->SetInput(image);
  filter->SetObjectValue(1);
  MaskImage::RegionType roi = image->GetBufferedRegion();
  roi.SetIndex(2, z0);
  roi.SetSize(2, itk::SizeValueType(z1 - z0 + 1));  // the slices of the cubes' corners
  filter->SetRegionOfInterest(roi);
  filter->Update();
  const ItkMesh* mesh = filter->GetOutput();
  // (key, filter's id) sorted: equal keys are one vertex.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> key(mesh->GetNumberOfPoints());
  const auto* points = mesh->GetPoints();
  for (auto it = points->Begin(); it != points->End(); ++it)
    key.at(it.Index()) = {vertex_key(it.Value()[0], it.Value()[1], it.Value()[2]),
                          std::uint32_t(it.Index())};
  std::sort(key.begin(), key.end());
  Slab slab;
  std::vector<std::int32_t> welded(key.size());  // per filter's id: index into slab.keys
  for (const auto& [k, v] : key) {
    if (slab.keys.empty() || slab.keys.back() != k) slab.keys.push_back(k);
    welded[v] = std::int32_t(slab.keys.size() - 1);
  }
  auto id = [&](itk::IdentifierType v) { return welded.at(v); };
  slab.triangles.reserve(mesh->GetNumberOfCells());
  const auto* cells = mesh->GetCells();
  for (auto it = cells->Begin(); it != cells->End(); ++it) {
    const auto* cell = it.Value();
    if (cell->GetNumberOfPoints() != 3) continue;
    const auto* v = cell->PointIdsBegin();
    slab.triangles.push_back({id(v[0]), id(v[1]), id(v[2])});
  }
  return slab;
}

// The slabs joined into one surface, vertices in key order. A vertex on the plane two slabs
// share is in both; the upper slab's copy becomes the lower one's.
TriangleSurface join_slabs(std::vector<Slab>& slabs, const Box& box, const Grid& grid) {
  std::vector<std::vector<std::int32_t>> global(slabs.size());  // per slab vertex: its index
  // The index of key k in the slab below slab s, or −1. Keys sort by z first, so only keys up to
  // the last one below can be on the shared plane.
  auto shared = [&](std::size_t s, std::uint64_t k) {
    if (s == 0 || slabs[s - 1].keys.empty() || k > slabs[s - 1].keys.back()) return -1;
    const std::vector<std::uint64_t>& below = slabs[s - 1].keys;
    const auto it = std::lower_bound(below.begin(), below.end(), k);
    return *it == k ? global[s - 1][std::size_t(it - below.begin())] : -1;
  };
  std::vector<std::uint64_t> keys;
  for (std::size_t s = 0; s < slabs.size(); ++s) {
    global[s].resize(slabs[s].keys.size());
    for (std::size_t v = 0; v < slabs[s].keys.size(); ++v) {
      const std::uint64_t k = slabs[s].keys[v];
      global[s][v] = shared(s, k);
      if (global[s][v] < 0) global[s][v] = std::int32_t(keys.size()), keys.push_back(k);
    }
  }
  TriangleSurface out;
  std::size_t triangles = 0;
  for (const Slab& slab : slabs) triangles += slab.triangles.size();
  out.triangles.reserve(triangles);
  for (std::size_t s = 0; s < slabs.size(); ++s)
    for (const Triangle& t : slabs[s].triangles)
      out.triangles.push_back({global[s][t[0]], global[s][t[1]], global[s][t[2]]});
  // Padded-image indices to world (mm).
  const Vec3 shift{box.lo[0] - 1.0, box.lo[1] - 1.0, box.lo[2] - 1.0};
  out.vertices.resize(keys.size());
  tbb::parallel_for(std::size_t(0), keys.size(), [&](std::size_t v) {
    out.vertices[v] = grid.index_to_world(key_index(keys[v]) + shift);
  });
  return out;
}

}  // namespace

TriangleSurface marching_cubes(const Mask& mask) {
  if (mask.grid.voxel_count() == 0) return {};
  const Box box = object_box(mask);
  if (box.empty()) return {};
  const MaskImage::Pointer image = padded_box_image(mask, box);
  const int layers = int(image->GetBufferedRegion().GetSize(2)) - 1;  // cubes along z
  std::vector<int> z0;
  for (int z = 0; z < layers; z += kSlabLayers) z0.push_back(z);
  z0.push_back(layers);
  std::vector<Slab> slabs(z0.size() - 1);
  tbb::parallel_for(std::size_t(0), slabs.size(), [&](std::size_t s) {
    slabs[s] = slab_surface(image.GetPointer(), z0[s], z0[s + 1]);
  });
  TriangleSurface surface = join_slabs(slabs, box, mask.grid);
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
