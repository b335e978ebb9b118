// Where the distance from a surface to another is sampled (surface_distance, fidelity.h): about
// one sample per h × h of surface, however small or large its triangles are. Every triangle is
// cut into k² pieces with edges ≤ h (k = 1 for a triangle no longer than h), and the pieces are
// grouped by the cube of side h, from the surface's lowest corner, that holds their centroid. A
// group is one sample, standing for the group's area: at the centroid of one of its pieces, drawn
// with probability ∝ area by a hash of the cube (deterministic; stratified, so the area-weighted
// mean of the samples is an unbiased estimate of the surface's mean).
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "fields/marching_cubes.h"

namespace cvt {

struct TrianglePiece {
  Vec3 a, b, c;
};

class DistanceSamples {
 public:
  // Keeps a reference to `surface`, which must outlive the samples.
  DistanceSamples(const TriangleSurface& surface, double h);

  std::size_t size() const { return at_.size(); }
  const Vec3& at(std::size_t g) const { return at_[g]; }
  double area(std::size_t g) const { return area_[g]; }  // mm²
  // The farthest any point of group g is from at(g) (mm): with a 1-Lipschitz distance, no point
  // of the group is farther than the sample's distance + reach.
  double reach(std::size_t g) const { return reach_[g]; }
  // The pieces of group g, in a fixed order.
  std::vector<TrianglePiece> pieces(std::size_t g) const;

 private:
  TrianglePiece piece(std::uint32_t triangle, std::uint32_t index) const;

  const TriangleSurface* surface_;
  std::vector<std::uint32_t> k_;  // per triangle: pieces per edge
  // (triangle, piece index) of every piece, group by group; piece index (i k + j) 2 + upper.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> members_;
  std::vector<std::uint32_t> start_;  // per group: first member; one past the end
  std::vector<Vec3> at_;
  std::vector<double> area_, reach_;
};

}  // namespace cvt
