// The marching-cubes surface of an image's object, written as OFF for the TetGen and NETGEN
// baselines of bench/compare: the same surface `cvtmesh quality --image` measures fidelity
// against (the object after cvtmesh's default clean-up, so every method meshes one object;
// world, mm, outward-oriented, closed 2-manifold).
//
//   bench_mc_surface IMAGE OUT.off [--labels all|L1,L2]
// Prints one JSON line on stdout: {"vertices","triangles","wall_s","peak_rss_mb"}.
#include <chrono>
#include <cstdio>
#include <exception>
#include <string>

#include "evaluate/fidelity.h"
#include "io/image_io.h"
#include "fields/marching_cubes.h"
#include "base/memory.h"
#include "preprocess/object_selection.h"

int main(int argc, char** argv) {
  if (argc != 3 && !(argc == 5 && std::string(argv[3]) == "--labels")) {
    std::fprintf(stderr, "usage: bench_mc_surface IMAGE OUT.off [--labels all|L1,L2]\n");
    return 2;
  }
  try {
    const auto t0 = std::chrono::steady_clock::now();
    cvt::ObjectSelection selection;
    if (argc == 5) selection.labels = cvt::parse_label_list(argv[4]);
    const cvt::TriangleSurface s =
        cvt::marching_cubes(cvt::fidelity_object(cvt::read_image(argv[1]), selection, {}));
    std::FILE* f = std::fopen(argv[2], "w");
    if (!f) throw std::runtime_error(std::string("cannot write ") + argv[2]);
    std::fprintf(f, "OFF\n%zu %zu 0\n", s.vertices.size(), s.triangles.size());
    for (const cvt::Vec3& v : s.vertices) std::fprintf(f, "%.17g %.17g %.17g\n", v[0], v[1], v[2]);
    for (const cvt::Triangle& t : s.triangles) std::fprintf(f, "3 %d %d %d\n", t[0], t[1], t[2]);
    if (std::fclose(f) != 0) throw std::runtime_error(std::string("failed writing ") + argv[2]);
    const double wall_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf(
        "{\"vertices\": %zu, \"triangles\": %zu, \"wall_s\": %.4f, \"peak_rss_mb\": %.1f}\n",
        s.vertices.size(), s.triangles.size(), wall_s,
        double(cvt::peak_rss_bytes()) / (1024.0 * 1024.0));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_mc_surface: %s\n", e.what());
    return 1;
  }
  return 0;
}
