// CGAL 5.5 Mesh_3 on a labelled image, as the reference the benchmarks compare cvtmesh against.
// The object is every non-zero label (or --labels L1,L2; or, in a grey image, the voxels of value
// ≥ --iso, as cvtmesh thresholds it), meshed as one subdomain; the criteria
// and the optimisation come from the command line; each phase (refine, lloyd, perturb, exude) is
// timed with the process peak RSS after it, and the mesh is written as Medit .mesh in world
// coordinates (INR: voxel (i,j,k) at (i·vx, j·vy, k·vz) + origin), the frame cvtmesh uses, so
// `cvtmesh quality MESH --image IMAGE` scores it against the same segmentation.
//
//   bench_cgal_mesh3 IMAGE -o OUT.mesh [--facet-angle 30] [--facet-size 6] [--facet-distance 0.5]
//       [--cell-radius-edge-ratio 3] [--cell-size 8] [--optimize none|default|lloyd]
//       [--threads 1|N] [--manifold] [--labels all|L1,L2 | --iso V] [--json TIMES.json] [--seed S]
//
// --optimize default is make_mesh_3's default: perturb then exude, each with a time limit equal
// to the refinement time and sliver bound 0 (as far as possible); lloyd runs lloyd_optimize_mesh_3
// (time limit = refinement time) before them. --threads > 1 uses the TBB-parallel mesher.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Image_3.h>
#include <CGAL/Labeled_mesh_domain_3.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Random.h>
#include <CGAL/make_mesh_3.h>
#include <tbb/global_control.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "base/memory.h"

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Domain = CGAL::Labeled_mesh_domain_3<K>;

struct Options {
  std::string image, output, json, labels = "all", optimize = "default";
  double facet_angle = 30, facet_size = 6, facet_distance = 0.5;
  double cell_radius_edge_ratio = 3, cell_size = 8;
  double iso = std::numeric_limits<double>::quiet_NaN();  // set: grey image, value >= iso
  int threads = 1;
  unsigned seed = 0;
  bool manifold = false;
};

struct Phase {
  std::string name;
  double wall_s = 0;
  double peak_rss_mb = 0;
};

double peak_mb() {
  return double(cvt::peak_rss_bytes()) / (1024.0 * 1024.0);
}

// A uchar image with 1 where the label is selected, 0 elsewhere; same dims, spacing and origin.
// Binarising first (rather than mapping labels after CGAL's label interpolation) makes the
// object exactly "voxels with a selected label", the object cvtmesh meshes.
CGAL::Image_3 binary_object(const CGAL::Image_3& image, const std::function<bool(double)>& in_object) {
  _image* im = _createImage(image.xdim(), image.ydim(), image.zdim(), 1, image.vx(), image.vy(),
                            image.vz(), 1, WK_FIXED, SGN_UNSIGNED);
  im->tx = image.tx();
  im->ty = image.ty();
  im->tz = image.tz();
  auto* out = static_cast<unsigned char*>(im->data);
  std::size_t n = 0, inside = 0;
  for (std::size_t k = 0; k < image.zdim(); ++k)
    for (std::size_t j = 0; j < image.ydim(); ++j)
      for (std::size_t i = 0; i < image.xdim(); ++i, ++n) {
        const bool in = in_object(double(image.value(i, j, k)));
        out[n] = in ? 1 : 0;
        inside += in;
      }
  if (inside == 0) throw std::runtime_error("no voxel has a selected label");
  return CGAL::Image_3(im);
}

std::set<long> parse_labels(const std::string& s) {
  std::set<long> out;
  if (s == "all") return out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');) out.insert(std::stol(item));
  return out;
}

// Writes the cells in the complex as Medit .mesh: only the vertices they use (renumbered from
// 1), the boundary facets of the complex as Triangles (oriented out of the object), every tet
// positively oriented, refs 1.
template <class C3t3>
void write_medit(const C3t3& c3t3, const std::string& path) {
  using Tr = typename C3t3::Triangulation;
  using Vh = typename Tr::Vertex_handle;
  const Tr& tr = c3t3.triangulation();
  std::map<Vh, std::size_t> index;
  std::vector<Vh> order;
  for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c)
    for (int i = 0; i < 4; ++i)
      if (index.emplace(c->vertex(i), order.size() + 1).second) order.push_back(c->vertex(i));
  std::ofstream os(path);
  if (!os) throw std::runtime_error("cannot write " + path);
  os.precision(17);
  os << "MeshVersionFormatted 2\nDimension 3\nVertices\n" << order.size() << "\n";
  for (const Vh& v : order) {
    const auto& p = tr.point(v).point();
    os << p.x() << ' ' << p.y() << ' ' << p.z() << " 1\n";
  }
  std::vector<std::array<std::size_t, 3>> triangles;
  for (auto f = c3t3.facets_in_complex_begin(); f != c3t3.facets_in_complex_end(); ++f) {
    auto cell = f->first;
    int i = f->second;
    if (!c3t3.is_in_complex(cell)) {  // look from the inside cell, so the normal points out
      const auto m = tr.mirror_facet(*f);
      cell = m.first;
      i = m.second;
    }
    if (!c3t3.is_in_complex(cell)) continue;
    // Vertices of facet i seen from outside, counter-clockwise: CGAL's vertex_triple_index.
    std::array<std::size_t, 3> t{};
    for (int a = 0; a < 3; ++a) t[a] = index.at(cell->vertex(Tr::vertex_triple_index(i, a)));
    triangles.push_back({t[0], t[2], t[1]});
  }
  os << "Triangles\n" << triangles.size() << "\n";
  for (const auto& t : triangles) os << t[0] << ' ' << t[1] << ' ' << t[2] << " 1\n";
  os << "Tetrahedra\n" << c3t3.number_of_cells_in_complex() << "\n";
  for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c)
    os << index.at(c->vertex(0)) << ' ' << index.at(c->vertex(1)) << ' ' << index.at(c->vertex(2))
       << ' ' << index.at(c->vertex(3)) << " 1\n";
  os << "End\n";
  if (!os) throw std::runtime_error("failed writing " + path);
}

template <class Concurrency>
nlohmann::json run(const Options& o) {
  using Tr = typename CGAL::Mesh_triangulation_3<Domain, CGAL::Default, Concurrency>::type;
  using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr>;
  using Criteria = CGAL::Mesh_criteria_3<Tr>;
  namespace p = CGAL::parameters;
  std::vector<Phase> phases;
  auto timed = [&phases](const std::string& name, auto&& f) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    phases.push_back({name, s, peak_mb()});
    std::fprintf(stderr, "%-8s %8.2f s  peak RSS %7.1f MB\n", name.c_str(), s, peak_mb());
    return s;
  };

  CGAL::Image_3 image, object;
  timed("read", [&] {
    if (!image.read(o.image.c_str())) throw std::runtime_error("cannot read image " + o.image);
    const std::set<long> labels = parse_labels(o.labels);
    const double iso = o.iso;
    object = std::isnan(iso) ? binary_object(image, [&](double v) {
      return labels.empty() ? long(v) != 0 : labels.count(long(v)) > 0;
    })
                             : binary_object(image, [iso](double v) { return v >= iso; });
  });
  CGAL::Random rng(o.seed);
  const Domain domain = Domain::create_labeled_image_mesh_domain(object, p::p_rng = &rng);
  const Criteria criteria(p::facet_angle = o.facet_angle, p::facet_size = o.facet_size,
                          p::facet_distance = o.facet_distance,
                          p::cell_radius_edge_ratio = o.cell_radius_edge_ratio,
                          p::cell_size = o.cell_size);
  C3t3 c3t3;
  const double refine_s = timed("refine", [&] {
    if (o.manifold)
      c3t3 = CGAL::make_mesh_3<C3t3>(domain, criteria, p::manifold(), p::no_perturb(),
                                     p::no_exude(), p::no_lloyd(), p::no_odt());
    else
      c3t3 = CGAL::make_mesh_3<C3t3>(domain, criteria, p::no_perturb(), p::no_exude(),
                                     p::no_lloyd(), p::no_odt());
  });
  const std::size_t refined_vertices = c3t3.triangulation().number_of_vertices();
  if (o.optimize == "lloyd")
    timed("lloyd", [&] { CGAL::lloyd_optimize_mesh_3(c3t3, domain, p::time_limit = refine_s); });
  if (o.optimize == "default" || o.optimize == "lloyd") {
    timed("perturb", [&] {
      CGAL::perturb_mesh_3(c3t3, domain, p::time_limit = refine_s, p::sliver_bound = 0);
    });
    timed("exude",
          [&] { CGAL::exude_mesh_3(c3t3, p::time_limit = refine_s, p::sliver_bound = 0); });
  }
  timed("write", [&] { write_medit(c3t3, o.output); });

  // Bounding box of the mesh vertices in the complex (world, mm), to check the frame.
  CGAL::Bbox_3 box;
  for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c)
    for (int i = 0; i < 4; ++i) box += c3t3.triangulation().point(c->vertex(i)).point().bbox();

  nlohmann::json j;
  j["image"] = o.image;
  j["criteria"] = {{"facet_angle", o.facet_angle},
                   {"facet_size", o.facet_size},
                   {"facet_distance", o.facet_distance},
                   {"cell_radius_edge_ratio", o.cell_radius_edge_ratio},
                   {"cell_size", o.cell_size}};
  j["optimize"] = o.optimize;
  j["manifold"] = o.manifold;
  j["threads"] = o.threads;
  j["seed"] = o.seed;
  j["phases"] = nlohmann::json::array();
  for (const Phase& ph : phases)
    j["phases"].push_back(
        {{"name", ph.name}, {"wall_s", ph.wall_s}, {"peak_rss_mb", ph.peak_rss_mb}});
  j["peak_rss_mb"] = peak_mb();
  j["triangulation_vertices_after_refine"] = refined_vertices;
  j["cells_in_complex"] = c3t3.number_of_cells_in_complex();
  j["facets_in_complex"] = c3t3.number_of_facets_in_complex();
  j["bbox_mm"] = {box.xmin(), box.ymin(), box.zmin(), box.xmax(), box.ymax(), box.zmax()};
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"CGAL Mesh_3 on a labelled image (benchmark reference)"};
  app.add_option("IMAGE", o.image, "Labelled image CGAL's ImageIO reads (.inr, .inr.gz, ...)")
      ->required();
  app.add_option("-o,--output", o.output, "Output Medit .mesh")->required();
  app.add_option("--facet-angle", o.facet_angle, "Lower bound on surface facet angles (deg)");
  app.add_option("--facet-size", o.facet_size, "Upper bound on surface Delaunay ball radius (mm)");
  app.add_option("--facet-distance", o.facet_distance,
                 "Upper bound on facet circumcentre to surface distance (mm)");
  app.add_option("--cell-radius-edge-ratio", o.cell_radius_edge_ratio, "Tet radius-edge bound");
  app.add_option("--cell-size", o.cell_size, "Upper bound on tet circumradius (mm)");
  app.add_option("--optimize", o.optimize, "none | default (perturb + exude) | lloyd (+ both)")
      ->check(CLI::IsMember({"none", "default", "lloyd"}));
  app.add_option("--threads", o.threads, "1: sequential mesher; > 1: TBB-parallel with N threads");
  app.add_option("--labels", o.labels, "Object labels: all (non-zero) | L1,L2,...");
  app.add_option("--iso", o.iso, "Grey images: the object is value >= ISO (replaces --labels)");
  app.add_flag("--manifold", o.manifold,
               "Refine until the boundary is a 2-manifold (CGAL's manifold() option)");
  app.add_option("--seed", o.seed, "Seed of the domain's random generator");
  app.add_option("--json", o.json, "Write phase times, memory and counts here");
  CLI11_PARSE(app, argc, argv);
  try {
    nlohmann::json j;
    if (o.threads > 1) {
#ifdef CGAL_LINKED_WITH_TBB
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, o.threads);
      j = run<CGAL::Parallel_tag>(o);
#else
      throw std::runtime_error("built without TBB: --threads must be 1");
#endif
    } else {
      j = run<CGAL::Sequential_tag>(o);
    }
    if (!o.json.empty()) std::ofstream(o.json) << j.dump(2) << "\n";
    std::fprintf(stderr, "%zu tets, peak RSS %.1f MB\n", std::size_t(j["cells_in_complex"]),
                 double(j["peak_rss_mb"]));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_cgal_mesh3: %s\n", e.what());
    return 1;
  }
  return 0;
}
