// The marching-cubes surface of a mask (ITK's itk::BinaryMask3DMeshSource, module ITKMesh) and
// the Kuhn split of voxels into tets.
#include "fields/marching_cubes.h"

#include <itkBinaryMask3DMeshSource.h>
#include <itkImage.h>
#include <itkMesh.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

namespace cvt {
namespace {

using MaskImage = itk::Image<unsigned char, 3>;
using ItkMesh = itk::Mesh<double, 3>;

// The mask as 0/1 with one voxel of zeros all around (the filter leaves an object that touches
// the image border open), same world geometry.
MaskImage::Pointer padded_itk_image(const Mask& mask) {
  const Grid& g = mask.grid;
  const Grid p = g.sub_grid({-1, -1, -1}, {g.dims[0] + 2, g.dims[1] + 2, g.dims[2] + 2});
  auto image = MaskImage::New();
  MaskImage::RegionType region;
  MaskImage::SpacingType spacing;
  MaskImage::PointType origin;
  MaskImage::DirectionType direction;
  for (unsigned a = 0; a < 3; ++a) {
    region.SetSize(a, itk::SizeValueType(p.dims[a]));
    spacing[a] = p.spacing[int(a)];
    origin[a] = p.origin[int(a)];
    for (unsigned b = 0; b < 3; ++b) direction(a, b) = p.direction[3 * a + b];
  }
  image->SetRegions(region);
  image->SetSpacing(spacing);
  image->SetOrigin(origin);
  image->SetDirection(direction);
  image->Allocate();
  image->FillBuffer(0);
  unsigned char* out = image->GetBufferPointer();
  tbb::parallel_for(0, g.dims[2], [&](int k) {
    for (int j = 0; j < g.dims[1]; ++j)
      for (int i = 0; i < g.dims[0]; ++i)
        out[p.linear(i + 1, j + 1, k + 1)] = mask.at(i, j, k) != 0;
  });
  return image;
}

}  // namespace

TriangleSurface marching_cubes(const Mask& mask) {
  TriangleSurface surface;
  if (mask.grid.voxel_count() == 0) return surface;
  auto filter = itk::BinaryMask3DMeshSource<MaskImage, ItkMesh>::New();
  filter->SetInput(padded_itk_image(mask));
  filter->SetObjectValue(1);
  filter->Update();
  const ItkMesh* mesh = filter->GetOutput();

  // The filter places vertices with single-precision error (~1e-7 relative); every vertex is an
  // edge midpoint, so snap its continuous index to the nearest half voxel: exact in double.
  surface.vertices.resize(mesh->GetNumberOfPoints());
  const auto* points = mesh->GetPoints();
  const Grid& g = mask.grid;
  for (auto it = points->Begin(); it != points->End(); ++it) {
    const auto& q = it.Value();
    Vec3 index = g.world_to_index({q[0], q[1], q[2]});
    for (int a = 0; a < 3; ++a) index[a] = std::round(2 * index[a]) / 2;
    surface.vertices.at(it.Index()) = g.index_to_world(index);
  }
  surface.triangles.reserve(mesh->GetNumberOfCells());
  const auto* cells = mesh->GetCells();
  for (auto it = cells->Begin(); it != cells->End(); ++it) {
    const auto* cell = it.Value();
    if (cell->GetNumberOfPoints() != 3) continue;
    const auto* id = cell->PointIdsBegin();
    surface.triangles.push_back({std::int32_t(id[0]), std::int32_t(id[1]), std::int32_t(id[2])});
  }
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
