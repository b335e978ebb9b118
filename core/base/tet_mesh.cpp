#include "base/tet_mesh.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <stdexcept>
#include <string>

#include "base/memory.h"

namespace cvt {

std::vector<std::int64_t> face_neighbours(std::size_t num_vertices, const std::vector<Tet>& tets) {
  const std::size_t num_faces = 4 * tets.size();
  for (const Tet& t : tets)
    for (std::int32_t v : t)
      if (v < 0 || std::size_t(v) >= num_vertices)
        throw std::invalid_argument("tet vertex " + std::to_string(v) + " out of range");
  // Faces are bucketed by their smallest vertex (a counting sort, linear time); a bucket
  // holds only the few faces around one vertex, so sorting inside buckets is cheap. This is
  // several times faster than sorting all 4·#tets keyed faces for meshes of ~1M tets. Each
  // thread owns a range of vertices and scans every tet for the faces of its buckets: scans
  // are cheap, an atomic count per face was not (a third of the time on two cores).
  const std::size_t parts = std::size_t(std::max(1, tbb::this_task_arena::max_concurrency()));
  const auto part_begin = [&](std::size_t p) {
    return std::int64_t(num_vertices * p / parts);
  };
  std::vector<std::int64_t> bucket_start(num_vertices + 1, 0);
  tbb::parallel_for(std::size_t(0), parts, [&](std::size_t p) {
    const std::int64_t lo = part_begin(p), hi = part_begin(p + 1);
    for (const Tet& t : tets)
      for (const Triangle& f : outward_faces(t)) {
        const std::int64_t smallest = std::min({f[0], f[1], f[2]});
        if (smallest >= lo && smallest < hi) ++bucket_start[std::size_t(smallest) + 1];
      }
  });
  for (std::size_t v = 0; v < num_vertices; ++v) bucket_start[v + 1] += bucket_start[v];

  // Each entry: the other two vertices of the face (sorted, packed in 64 bits) and its id.
  struct Entry {
    std::uint64_t key;
    std::int64_t face;
  };
  std::vector<Entry> entries;
  resize_large(entries, num_faces);  // large buffers are faulted in on all threads
  tbb::parallel_for(std::size_t(0), parts, [&](std::size_t p) {
    const std::int64_t lo = part_begin(p), hi = part_begin(p + 1);
    std::vector<std::int64_t> fill(bucket_start.begin() + lo, bucket_start.begin() + hi);
    for (std::size_t t = 0; t < tets.size(); ++t) {
      const auto faces = outward_faces(tets[t]);
      for (int i = 0; i < 4; ++i) {
        std::array<std::int32_t, 3> f = faces[i];
        std::sort(f.begin(), f.end());
        if (f[0] < lo || f[0] >= hi) continue;
        const std::uint64_t key = (std::uint64_t(std::uint32_t(f[1])) << 32) | std::uint32_t(f[2]);
        entries[std::size_t(fill[std::size_t(f[0] - lo)]++)] = {key, std::int64_t(4 * t + i)};
      }
    }
  });

  // Faces with the same key in a bucket are the same triangle. Buckets are independent, so
  // they are sorted in parallel.
  std::vector<std::int64_t> neighbour;
  resize_large(neighbour, num_faces);
  tbb::parallel_for(std::size_t(0), num_faces, [&](std::size_t f) { neighbour[f] = -1; });
  tbb::parallel_for(std::size_t(0), num_vertices, [&](std::size_t v) {
    const auto first = entries.begin() + bucket_start[v],
               last = entries.begin() + bucket_start[v + 1];
    std::sort(first, last, [](const Entry& a, const Entry& b) {
      return a.key != b.key ? a.key < b.key : a.face < b.face;
    });
    for (auto run = first; run != last;) {
      auto end = run + 1;
      while (end != last && end->key == run->key) ++end;
      if (end - run > 1)
        for (auto f = run; f != end; ++f) neighbour[f->face] = (f + 1 == end ? run : f + 1)->face;
      run = end;
    }
  });
  return neighbour;
}

std::vector<std::int64_t> boundary_faces(const TetMesh& mesh) {
  const std::vector<std::int64_t> neighbour = face_neighbours(mesh.vertices.size(), mesh.tets);

  // Reported in (tet, face) order, which does not depend on the sort: deterministic.
  std::vector<std::int64_t> result;
  for (std::size_t f = 0; f < neighbour.size(); ++f) {
    if (neighbour[f] < 0) result.push_back(std::int64_t(f));
  }
  return result;
}

std::vector<Triangle> boundary_triangles(const TetMesh& mesh) {
  const std::vector<std::int64_t> faces = boundary_faces(mesh);
  std::vector<Triangle> triangles;
  triangles.reserve(faces.size());
  for (std::int64_t f : faces) triangles.push_back(outward_faces(mesh.tets[f / 4])[f % 4]);
  return triangles;
}

}  // namespace cvt
