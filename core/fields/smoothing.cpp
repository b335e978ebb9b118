#include "fields/smoothing.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <tbb/parallel_for.h>

namespace cvt {
namespace {

std::vector<float> gaussian_kernel(double sigma_voxels) {
  const int radius = std::max(1, int(std::ceil(3.0 * sigma_voxels)));
  std::vector<float> k(2 * radius + 1);
  double sum = 0;
  for (int t = -radius; t <= radius; ++t) sum += k[t + radius] = float(std::exp(-0.5 * t * t / (sigma_voxels * sigma_voxels)));
  for (float& w : k) w = float(w / sum);
  return k;
}

// Convolves every line along `axis` with `kernel`, clamping at the borders (the crop margin is
// background, so clamping equals zero padding there).
void convolve_axis(Volume<float>& f, int axis, const std::vector<float>& kernel,
                   const Progress& progress) {
  const Grid& g = f.grid;
  const int n = g.dims[axis];
  const int radius = int(kernel.size() / 2);
  const std::ptrdiff_t stride = axis == 0 ? 1 : (axis == 1 ? g.dims[0] : std::ptrdiff_t(g.dims[0]) * g.dims[1]);
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  tbb::parallel_for(0, g.dims[a2], [&](int c2) {
    progress.check_cancelled();
    std::vector<float> line(n);
    for (int c1 = 0; c1 < g.dims[a1]; ++c1) {
      std::array<int, 3> start{0, 0, 0};
      start[a1] = c1;
      start[a2] = c2;
      float* base = &f.data[g.linear(start[0], start[1], start[2])];
      for (int t = 0; t < n; ++t) line[t] = base[t * stride];
      // Most lines of a crop lie wholly inside or outside: convolution leaves them unchanged.
      if (std::all_of(line.begin(), line.end(), [&](float v) { return v == line[0]; })) continue;
      for (int t = 0; t < n; ++t) {
        float acc = 0;
        for (int s = -radius; s <= radius; ++s)
          acc += kernel[s + radius] * line[std::clamp(t + s, 0, n - 1)];
        base[t * stride] = acc;
      }
    }
  });
}

// The same along axis 1 or 2, a plane at a time: the plane of the lines through one index of
// the remaining axis, held as rows along i, so the kernel runs over whole contiguous rows (not
// strided gathers). Each voxel's sum has the same terms in the same order as convolve_axis, and
// constant lines stay unchanged as there: the result is bitwise the same.
void convolve_across_rows(Volume<float>& f, int axis, const std::vector<float>& kernel,
                          const Progress& progress) {
  const Grid& g = f.grid;
  const int nx = g.dims[0], n = g.dims[axis];
  const int other = axis == 1 ? 2 : 1;
  const std::ptrdiff_t line_stride = axis == 1 ? nx : std::ptrdiff_t(nx) * g.dims[1];
  const std::ptrdiff_t plane_stride = other == 1 ? nx : std::ptrdiff_t(nx) * g.dims[1];
  const int radius = int(kernel.size() / 2);
  tbb::parallel_for(0, g.dims[other], [&](int c) {
    progress.check_cancelled();
    float* base = f.data.data() + std::ptrdiff_t(c) * plane_stride;
    std::vector<float> plane(std::size_t(n) * nx), acc(nx);
    for (int t = 0; t < n; ++t)
      std::copy_n(base + t * line_stride, nx, plane.data() + std::size_t(t) * nx);
    std::vector<char> varies(nx, 0);
    bool any = false;
    for (int t = 1; t < n; ++t) {
      const float* row = plane.data() + std::size_t(t) * nx;
      for (int i = 0; i < nx; ++i) varies[i] |= row[i] != plane[i];
    }
    for (int i = 0; i < nx && !any; ++i) any = varies[i];
    if (!any) return;
    for (int t = 0; t < n; ++t) {
      std::fill(acc.begin(), acc.end(), 0.0f);
      for (int s = -radius; s <= radius; ++s) {
        const float w = kernel[s + radius];
        const float* row = plane.data() + std::size_t(std::clamp(t + s, 0, n - 1)) * nx;
        for (int i = 0; i < nx; ++i) acc[i] += w * row[i];
      }
      float* out = base + t * line_stride;
      for (int i = 0; i < nx; ++i)
        if (varies[i]) out[i] = acc[i];
    }
  });
}

}  // namespace

Volume<float> smooth_indicator(const Mask& mask, double sigma_mm, const Progress& progress) {
  Volume<float> f(mask.grid, 0.0f);
  tbb::parallel_for(std::size_t(0), mask.size(),
                    [&](std::size_t v) { f.data[v] = mask.data[v] ? 1.0f : 0.0f; });
  if (sigma_mm <= 0) return f;
  for (int axis = 0; axis < 3; ++axis) {
    const double sigma_voxels = sigma_mm / mask.grid.spacing[axis];
    if (sigma_voxels < 0.2) continue;  // the kernel would be ≈ a delta
    if (axis == 0)
      convolve_axis(f, axis, gaussian_kernel(sigma_voxels), progress);
    else
      convolve_across_rows(f, axis, gaussian_kernel(sigma_voxels), progress);
  }
  return f;
}

namespace {

// value(i, j, k) is the field's value at a voxel, as a double.
template <class T, class Value>
double trilinear(const Volume<T>& field, const Vec3& index, Value value) {
  const Grid& g = field.grid;
  int base[3];
  double frac[3];
  for (int a = 0; a < 3; ++a) {
    const double x = std::clamp(index[a], 0.0, double(g.dims[a] - 1));
    base[a] = std::min(int(x), std::max(0, g.dims[a] - 2));
    frac[a] = x - base[a];
  }
  const int i1 = std::min(base[0] + 1, g.dims[0] - 1), j1 = std::min(base[1] + 1, g.dims[1] - 1),
            k1 = std::min(base[2] + 1, g.dims[2] - 1);
  const auto& v = value;
  const double c00 = v(base[0], base[1], base[2]) * (1 - frac[0]) + v(i1, base[1], base[2]) * frac[0];
  const double c10 = v(base[0], j1, base[2]) * (1 - frac[0]) + v(i1, j1, base[2]) * frac[0];
  const double c01 = v(base[0], base[1], k1) * (1 - frac[0]) + v(i1, base[1], k1) * frac[0];
  const double c11 = v(base[0], j1, k1) * (1 - frac[0]) + v(i1, j1, k1) * frac[0];
  const double c0 = c00 * (1 - frac[1]) + c10 * frac[1];
  const double c1 = c01 * (1 - frac[1]) + c11 * frac[1];
  return c0 * (1 - frac[2]) + c1 * frac[2];
}

template <class T>
Vec3 central_gradient(const Volume<T>& field, const Vec3& index) {
  Vec3 grad;
  const double h = 0.5;  // half a voxel: smooth enough on the trilinear field
  for (int a = 0; a < 3; ++a) {
    Vec3 lo = index, hi = index;
    lo[a] -= h;
    hi[a] += h;
    grad[a] = (double(sample_trilinear(field, hi)) - double(sample_trilinear(field, lo))) /
              (2 * h * field.grid.spacing[a]);
  }
  return grad;
}

}  // namespace

float sample_trilinear(const Volume<float>& field, const Vec3& index) {
  return float(trilinear(field, index, [&](int i, int j, int k) { return double(field.at(i, j, k)); }));
}

float sample_trilinear(const Mask& mask, const Vec3& index) {
  return float(
      trilinear(mask, index, [&](int i, int j, int k) { return mask.at(i, j, k) ? 1.0 : 0.0; }));
}

Vec3 gradient_local(const Volume<float>& field, const Vec3& index) {
  return central_gradient(field, index);
}

Vec3 gradient_local(const Mask& mask, const Vec3& index) { return central_gradient(mask, index); }

}  // namespace cvt
