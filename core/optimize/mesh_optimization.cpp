#include "optimize/mesh_optimization.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <nlohmann/json.hpp>

#include "base/errors.h"
#include "base/parallel_find.h"
#include "optimize/mesh_optimization_work.h"
#include "preprocess/object_scale.h"
#include "evaluate/quality.h"

namespace cvt {
namespace {

constexpr double kMaxBoundaryRefinementShare = 0.1;

constexpr double kPi = 3.14159265358979323846;

// CPU time of the process (all threads), for timings on a loaded machine.
double process_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Largest distance to the surface over the vertices where `select` is set.
double max_surface_distance(const opt::WorkMesh& m, const opt::LevelSetSurface& surface,
                            const std::vector<char>& select) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, m.vertex_count(), 1024), 0.0,
      [&](const tbb::blocked_range<std::size_t>& r, double d) {
        for (std::size_t v = r.begin(); v != r.end(); ++v)
          if (select[v] && !m.vertex_tets[v].empty())  // not removed (corners, collapses)
            d = std::max(d, surface.distance(m.pos[v]));
        return d;
      },
      [](double a, double b) { return std::max(a, b); });
}

void validate(const TetMesh& mesh, const OptimizationOptions& o) {
  auto require = [](bool ok, const std::string& what) {
    if (!ok) throw InputError("mesh optimisation: " + what);
  };
  cvt::validate(o);  // the parameter registry's ranges, as presets and the CLI check them
  require(mesh.labels.empty() || mesh.labels.size() == mesh.tets.size(),
          "one label per tet expected");
  const std::int64_t n = std::int64_t(mesh.vertices.size());
  // The first bad tet, found in parallel; messages are built only for it.
  const std::size_t bad = parallel_find_first(mesh.tets.size(), [&](std::size_t t) {
    const Tet& tet = mesh.tets[t];
    const bool in_range =
        std::all_of(tet.begin(), tet.end(), [&](std::int32_t v) { return v >= 0 && v < n; });
    return !in_range || !(signed_volume(mesh, tet) > 0);
  });
  if (bad < mesh.tets.size()) {
    const Tet& tet = mesh.tets[bad];
    for (std::int32_t v : tet)
      require(v >= 0 && v < n, "tet " + std::to_string(bad) + " references a missing vertex");
    require(false, "tet " + std::to_string(bad) + " is not positively oriented");
  }
}

}  // namespace

MeshOptimizer::MeshOptimizer(const TetMesh& mesh, const Volume<float>* indicator,
                             const OptimizationOptions& options, bool pass_statistics,
                             const Mask* object)
    : options_(options), pass_statistics_(pass_statistics) {
  if (object) {
    target_ = std::make_unique<opt::MaskSurface>(*object);
    boundary_tolerance_mm_ =
        options_.boundary_tolerance_mm > 0
            ? options_.boundary_tolerance_mm
            : auto_boundary_tolerance_mm(sizing_unit_mm(*object, volume_to_area_mm(*object)));
    if (indicator && options_.refine_boundary)
      result_.boundary_tolerance_mm = boundary_tolerance_mm_;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = process_cpu_s();
  validate(mesh, options_);
  input_vertices_ = std::int32_t(mesh.vertices.size());
  opt::QualityScale scale;
  scale.sine = std::sin(options_.target_dihedral_deg * kPi / 180.0);
  work_ = std::make_unique<opt::WorkMesh>(mesh, scale);
  opt::WorkMesh& m = *work_;
  m.on_surface.assign(m.vertex_count(), 0);
  if (indicator) {
    surface_ = std::make_unique<opt::LevelSetSurface>(*indicator, 0.5f);
    const double tolerance = options_.surface_tolerance_voxels * surface_->min_spacing_mm();
    std::vector<double> d(m.vertex_count(), 0);
    tbb::parallel_for(std::size_t(0), m.vertex_count(), [&](std::size_t v) {
      if (m.on_boundary[v]) d[v] = surface_->distance(m.pos[v]);
    });
    for (std::size_t v = 0; v < m.vertex_count(); ++v) {
      if (!m.on_boundary[v]) continue;
      if (d[v] <= tolerance) {
        m.on_surface[v] = 1;
        ++result_.sliding_vertices;
        result_.surface_distance_before_mm = std::max(result_.surface_distance_before_mm, d[v]);
      } else {
        ++result_.fixed_boundary_vertices;
        result_.fixed_boundary_distance_mm = std::max(result_.fixed_boundary_distance_mm, d[v]);
      }
    }
  }
  result_.setup_s = seconds_since(t0);
  result_.wall_s = result_.setup_s;
  result_.cpu_s = process_cpu_s() - c0;
  result_.history.push_back(statistics(0, true));
  finished_ = options_.max_passes == 0;
}

MeshOptimizer::~MeshOptimizer() = default;

TetMesh MeshOptimizer::mesh(std::vector<std::int32_t>* origin) const {
  TetMesh m = work_->to_mesh(origin);
  if (origin)
    for (std::int32_t& o : *origin)
      if (o >= input_vertices_) o = -1;
  return m;
}

bool MeshOptimizer::step(const Progress& progress) {
  if (finished_) return false;
  const int pass = passes() + 1;
  progress("optimisation pass " + std::to_string(pass), double(pass - 1) / options_.max_passes);
  opt::WorkMesh& m = *work_;
  m.progress = &progress;
  struct Forget {  // the Progress lives only as long as this call
    opt::WorkMesh& m;
    ~Forget() { m.progress = nullptr; }
  } forget{m};
  const double bad_below = 1;  // qualities are scaled so that bad means below 1
  double cpu = 0;
  auto timed = [&cpu](auto&& work) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = process_cpu_s();
    work();
    cpu += process_cpu_s() - c0;
    return seconds_since(t0);
  };
  opt::PassCounts snapped, flips, odt, smooth, inserted;
  double flips_s = 0, odt_s = 0, smoothing_s = 0, insertion_s = 0;
  opt::BoundaryRefinement refined;
  // The first pass clears most slivers: the edges split after it have fewer bad tets around.
  // The farthest points first, and at most a tenth more vertices: a segmentation drawn on thick
  // slices, or resampled from one, departs from any smooth boundary by half a slice all over.
  if (surface_ && target_ && options_.refine_boundary && (pass == 2 || pass == 3)) {
    insertion_s += timed([&] {
      opt::BoundaryRefinementOptions b;
      b.tolerance_mm = boundary_tolerance_mm_;
      b.spacing_mm = 2 * b.tolerance_mm;
      b.bad_below = bad_below;
      const auto cap = std::size_t(kMaxBoundaryRefinementShare * input_vertices_);
      b.max_inserted = cap - std::min(cap, result_.inserted_boundary_vertices);
      if (!refiner_) refiner_ = std::make_unique<opt::BoundaryRefiner>(target_->mask(), *surface_);
      refined = refiner_->run(m, b);
    });
  }
  if (surface_ && options_.smooth_surface) {
    smoothing_s = timed([&] {
      const double tolerance = options_.surface_tolerance_voxels * surface_->min_spacing_mm();
      snapped = opt::snap_to_surface(m, *surface_, tolerance, bad_below);
    });
  }
  if (options_.flips || options_.boundary_flips) {
    flips_s = timed([&] {
      opt::TopologyOptions t;
      t.bad_below = pass <= options_.global_flip_passes
                        ? std::max(bad_below, options_.global_flip_below)
                        : bad_below;
      t.interior_flips = options_.flips;
      t.boundary_flips = options_.boundary_flips;
      t.surface = surface_.get();
      t.max_face_distance_mm =
          surface_ ? options_.max_face_distance_voxels * surface_->min_spacing_mm() : 0.0;
      t.max_boundary_shift_mm = options_.max_boundary_shift_mm;
      flips = opt::improve_topology(m, t);
      opt::CollapseOptions c;
      c.bad_below = bad_below;
      c.surface = surface_.get();
      c.max_face_distance_mm = t.max_face_distance_mm;
      flips.collapsed_edges = opt::collapse_short_edges(m, c).collapsed_edges;
    });
  }
  progress.check_cancelled();
  if (options_.odt_iterations > 0 && pass <= options_.odt_passes) {
    odt_s = timed([&] { odt = opt::odt_smooth(m, options_.odt_iterations, options_.odt_flips); });
  }
  progress.check_cancelled();
  if (options_.smooth_interior || options_.smooth_surface) {
    smoothing_s += timed([&] {
      opt::SmoothingOptions s;
      s.bad_below = bad_below;
      s.iterations = options_.smoothing_iterations;
      s.move_interior = options_.smooth_interior;
      s.move_surface = options_.smooth_surface;
      smooth = opt::smooth_vertices(m, surface_.get(), s);
    });
  }
  progress.check_cancelled();
  if (options_.insert_vertices) {
    insertion_s += timed([&] {
      opt::InsertionOptions in;
      in.bad_below = bad_below;
      inserted = opt::insert_vertices(m, in);
      if (surface_) inserted.split_caps = opt::split_bad_caps(m, *surface_, bad_below).split_caps;
    });
  }
  const std::size_t changes = flips.edge_removals + flips.face_flips + flips.boundary_flips +
                              flips.corner_removals + flips.collapsed_edges + odt.edge_removals +
                              odt.face_flips + odt.moved_interior + smooth.moved_interior +
                              smooth.moved_surface + snapped.moved_surface +
                              snapped.snapped_surface + inserted.inserted + inserted.split_caps +
                              refined.inserted;
  if (changes == 0 || pass >= options_.max_passes) finished_ = true;
  if (finished_ && surface_ && options_.fit_surface) {
    result_.surface_distance_after_mm = max_surface_distance(m, *surface_, m.on_surface);
    fitted_ = true;
    opt::SurfaceFit fit;
    result_.fit_s = timed([&] {
      opt::SurfaceFitOptions f;
      f.max_step_mm = 0.5 * surface_->min_spacing_mm();
      f.min_step_mm = 0.01 * surface_->min_spacing_mm();
      // The fit trades a little quality for fidelity, but not near the bad edge: no tet is
      // brought below a 20° dihedral angle's worth, nor below its star's worst.
      f.bad_below = std::max(bad_below, std::sin(20.0 * kPi / 180.0) / m.scale.sine);
      fit = opt::fit_to_surface(m, *surface_, target_.get(), f);
    });
    smoothing_s += result_.fit_s;
    result_.fit_vertices = fit.vertices;
    result_.fit_mean_offset_mm = fit.mean_offset_mm;
    result_.fit_max_offset_mm = fit.max_offset_mm;
    result_.fit_error_before_mm = fit.mean_error_before_mm;
    result_.fit_error_after_mm = fit.mean_error_after_mm;
  }
  // Full figures after every pass, or only for the last one.
  PassStats stats = statistics(pass, pass_statistics_ || finished_);
  stats.flips_s = flips_s;
  stats.odt_s = odt_s;
  stats.smoothing_s = smoothing_s;
  stats.insertion_s = insertion_s;
  stats.wall_s = flips_s + odt_s + smoothing_s + insertion_s;
  stats.cpu_s = cpu;
  stats.edge_removals = flips.edge_removals + odt.edge_removals;
  stats.face_flips = flips.face_flips + odt.face_flips;
  stats.boundary_flips = flips.boundary_flips;
  stats.corner_removals = flips.corner_removals;
  stats.collapsed_edges = flips.collapsed_edges;
  stats.odt_moved = odt.moved_interior;
  stats.moved_interior = smooth.moved_interior;
  stats.moved_surface = smooth.moved_surface + snapped.moved_surface;
  stats.snapped_surface = snapped.snapped_surface;
  stats.inserted = inserted.inserted;
  stats.split_caps = inserted.split_caps;
  stats.far_boundary_points = refined.far_points;
  stats.inserted_boundary = refined.inserted;
  result_.wall_s += stats.wall_s;
  result_.cpu_s += cpu;
  result_.boundary_flips += flips.boundary_flips;
  result_.corner_removals += flips.corner_removals;
  result_.collapsed_edges += flips.collapsed_edges;
  result_.inserted_vertices += inserted.inserted;
  result_.inserted_boundary_vertices += refined.inserted;
  result_.split_caps += inserted.split_caps;
  result_.snapped_vertices += snapped.snapped_surface;
  result_.max_boundary_shift_mm =
      std::max(result_.max_boundary_shift_mm, flips.max_boundary_shift_mm);
  result_.max_flip_face_distance_mm =
      std::max(result_.max_flip_face_distance_mm, flips.max_face_distance_mm);
  result_.max_flip_replaced_distance_mm =
      std::max(result_.max_flip_replaced_distance_mm, flips.max_replaced_distance_mm);
  result_.history.push_back(stats);
  return true;
}

int MeshOptimizer::run(const Progress& progress) {
  int n = 0;
  while (step(progress)) ++n;
  return n;
}

PassStats MeshOptimizer::statistics(int pass, bool full) {
  const opt::WorkMesh& m = *work_;
  PassStats s;
  s.pass = pass;
  s.tets = m.live_tets();
  s.vertices = m.vertex_count();
  // The worst tet is cheap to find from the cached qualities.
  double qmin = 1;
  for (std::size_t t = 0; t < m.tets.size(); ++t)
    if (!opt::is_dead(m.tets[t])) qmin = std::min(qmin, m.quality[t]);
  s.min_quality = qmin;
  if (!full) return s;
  std::array<std::array<double, 2>, 3> edges;
  for (int k = 0; k < 3; ++k) edges[k] = table1_bin_edges(kShewchukMeasures[k]);
  auto summary_of = [&](const Tet& tet) {
    const TetFigures f =
        tet_figures(m.pos[tet[0]], m.pos[tet[1]], m.pos[tet[2]], m.pos[tet[3]], false);
    TetFigureSummary out;
    out.min_dihedral = f.min_dihedral;
    out.max_dihedral = f.max_dihedral;
    for (int k = 0; k < 3; ++k) {
      const double q = measure_of(f, kShewchukMeasures[k]);
      out.bin[k] = q < edges[k][0] ? 0 : (q > edges[k][1] ? 2 : 1);
    }
    return out;
  };
  // With statistics after every pass, a slot's figures are kept and recomputed only when it is
  // new or anything around it changed (a tet added or removed, a vertex moved) since the last
  // statistics. Without (two statistics in all), nothing is kept: it would only cost memory.
  if (pass_statistics_) {
    const std::size_t known = figures_clock_ ? figures_.size() : 0;
    figures_.resize(m.tets.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m.tets.size(), 4096), [&](const auto& r) {
      for (std::size_t t = r.begin(); t != r.end(); ++t)
        if (!opt::is_dead(m.tets[t]) &&
            (t >= known || m.changed_since(std::int32_t(t), figures_clock_)))
          figures_[t] = summary_of(m.tets[t]);
    });
    figures_clock_ = m.clock;
  }
  struct Acc {
    double min_d = 180, max_d = 0;
    std::array<std::size_t, 4> below{};
    std::array<std::array<std::size_t, 3>, 3> bins{};
  };
  const Acc acc = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, m.tets.size(), 4096), Acc{},
      [&](const tbb::blocked_range<std::size_t>& r, Acc a) {
        for (std::size_t t = r.begin(); t != r.end(); ++t) {
          if (opt::is_dead(m.tets[t])) continue;
          const TetFigureSummary f = pass_statistics_ ? figures_[t] : summary_of(m.tets[t]);
          a.min_d = std::min(a.min_d, f.min_dihedral);
          a.max_d = std::max(a.max_d, f.max_dihedral);
          const double limits[4] = {5, 10, 15, 20};
          for (int i = 0; i < 4; ++i) a.below[i] += f.min_dihedral < limits[i];
          for (int k = 0; k < 3; ++k) ++a.bins[k][f.bin[k]];
        }
        return a;
      },
      [](Acc a, const Acc& b) {
        a.min_d = std::min(a.min_d, b.min_d);
        a.max_d = std::max(a.max_d, b.max_d);
        for (int i = 0; i < 4; ++i) a.below[i] += b.below[i];
        for (int k = 0; k < 3; ++k)
          for (int i = 0; i < 3; ++i) a.bins[k][i] += b.bins[k][i];
        return a;
      });
  s.min_dihedral_deg = acc.min_d;
  s.max_dihedral_deg = acc.max_d;
  s.below_5 = acc.below[0];
  s.below_10 = acc.below[1];
  s.below_15 = acc.below[2];
  s.below_20 = acc.below[3];
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 3; ++i)
      s.bins_percent[k][i] = s.tets ? 100.0 * double(acc.bins[k][i]) / double(s.tets) : 0.0;
  s.has_statistics = true;
  return s;
}

OptimizationResult MeshOptimizer::result() const {
  OptimizationResult r = result_;
  if (surface_ && !fitted_) {
    r.surface_distance_after_mm = max_surface_distance(*work_, *surface_, work_->on_surface);
  }
  return r;
}

OptimizationResult optimize_mesh(TetMesh& mesh, const Volume<float>* indicator,
                                 const OptimizationOptions& options, const Progress& progress,
                                 const Mask* object) {
  MeshOptimizer optimizer(mesh, indicator, options, false, object);
  optimizer.run(progress);
  OptimizationResult r = optimizer.result();
  mesh = optimizer.mesh(&r.vertex_origin);
  return r;
}

nlohmann::json to_json(const OptimizationResult& r) {
  nlohmann::json passes = nlohmann::json::array();
  for (const PassStats& s : r.history) {
    nlohmann::json p = {{"pass", s.pass},
                        {"wall_s", s.wall_s},
                        {"cpu_s", s.cpu_s},
                        {"flips_s", s.flips_s},
                        {"odt_s", s.odt_s},
                        {"smoothing_s", s.smoothing_s},
                        {"insertion_s", s.insertion_s},
                        {"tets", s.tets},
                        {"min_quality", s.min_quality},
                        {"edge_removals", s.edge_removals},
                        {"face_flips", s.face_flips},
                        {"boundary_flips", s.boundary_flips},
                        {"corner_removals", s.corner_removals},
                        {"collapsed_edges", s.collapsed_edges},
                        {"odt_moved", s.odt_moved},
                        {"moved_interior", s.moved_interior},
                        {"moved_surface", s.moved_surface},
                        {"snapped_surface", s.snapped_surface},
                        {"inserted", s.inserted},
                        {"split_caps", s.split_caps},
                        {"far_boundary_points", s.far_boundary_points},
                        {"inserted_boundary", s.inserted_boundary},
                        {"vertices", s.vertices}};
    if (s.has_statistics) {
      p["min_dihedral_deg"] = s.min_dihedral_deg;
      p["max_dihedral_deg"] = s.max_dihedral_deg;
      p["below_deg"] = {
          {"5", s.below_5}, {"10", s.below_10}, {"15", s.below_15}, {"20", s.below_20}};
      nlohmann::json bins;
      for (int k = 0; k < 3; ++k)
        bins[std::string(measure_key(kShewchukMeasures[k]))] = s.bins_percent[k];
      p["bins_percent"] = bins;
    }
    passes.push_back(p);
  }
  return {{"wall_s", r.wall_s},
          {"setup_s", r.setup_s},
          {"cpu_s", r.cpu_s},
          {"surface_distance_before_mm", r.surface_distance_before_mm},
          {"surface_distance_after_mm", r.surface_distance_after_mm},
          {"sliding_vertices", r.sliding_vertices},
          {"fixed_boundary_vertices", r.fixed_boundary_vertices},
          {"fixed_boundary_distance_mm", r.fixed_boundary_distance_mm},
          {"snapped_vertices", r.snapped_vertices},
          {"max_boundary_shift_mm", r.max_boundary_shift_mm},
          {"max_flip_face_distance_mm", r.max_flip_face_distance_mm},
          {"max_flip_replaced_distance_mm", r.max_flip_replaced_distance_mm},
          {"boundary_flips", r.boundary_flips},
          {"corner_removals", r.corner_removals},
          {"collapsed_edges", r.collapsed_edges},
          {"inserted_vertices", r.inserted_vertices},
          {"inserted_boundary_vertices", r.inserted_boundary_vertices},
          {"boundary_tolerance_mm", r.boundary_tolerance_mm},
          {"split_caps", r.split_caps},
          {"fit_vertices", r.fit_vertices},
          {"fit_mean_offset_mm", r.fit_mean_offset_mm},
          {"fit_max_offset_mm", r.fit_max_offset_mm},
          {"fit_error_before_mm", r.fit_error_before_mm},
          {"fit_error_after_mm", r.fit_error_after_mm},
          {"fit_s", r.fit_s},
          {"passes", passes}};
}

}  // namespace cvt
