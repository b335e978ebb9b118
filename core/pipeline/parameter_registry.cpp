#include "pipeline/parameter_registry.h"

#include <cmath>
#include <sstream>
#include <type_traits>

#include "base/errors.h"

namespace cvt {
namespace {

template <auto Member>
ParameterRef top(Parameters& p) {
  return &(p.*Member);
}
template <auto Member>
ParameterRef opt(Parameters& p) {
  return &(p.optimization.*Member);
}
bool optimizing(const Parameters& p) { return p.optimize == OptimizeMode::standard; }

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::string_view kOpt = "optimization";
using S = Stage;
using P = Parameters;
using O = OptimizationOptions;

std::vector<ParameterSpec> make_registry() {
  return {
      // Reading the image. The sform by default, as nibabel and FSL read NIfTI files: ITK
      // prefers the qform, and an atlas whose two transforms disagree then lands far from
      // where those tools (and the user) see it.
      {.key = "nifti_frame", .cli = "nifti-frame", .label = "NIfTI frame", .stage = S::preprocess,
       .tooltip = "NIfTI images: the header transform that places the image, sform (as nibabel "
                  "and FSL read it) or qform. Either gives way to the other when its code is 0, "
                  "and to the voxel spacing alone when both codes are.",
       .words = {"qform", "sform"}, .defines_object = true, .ref = top<&P::nifti_frame>},
      // Stage 1: the object.
      {.key = "labels", .cli = "labels", .label = "labels", .stage = S::preprocess,
       .tooltip = "Labels that make the object: all (every non-zero label) or a list L1,L2,...",
       .defines_object = true, .ref = top<&P::labels>},
      {.key = "iso", .cli = "iso", .label = "iso value", .stage = S::preprocess,
       .tooltip = "Grey images: threshold of the object (image units); replaces the labels.",
       .defines_object = true, .ref = top<&P::iso>},
      {.key = "inside_above", .cli = "inside", .label = "inside ≥ iso", .stage = S::preprocess,
       .tooltip = "With an iso value: inside is value ≥ iso (above) or ≤ iso (below).",
       .words = {"below", "above"}, .defines_object = true, .ref = top<&P::inside_above>},
      {.key = "margin_voxels", .cli = "margin", .label = "margin", .unit = "voxels",
       .stage = S::preprocess,
       .tooltip = "Background voxels kept around the object's bounding box when cropping.",
       .lo = 1, .hi = 64, .defines_object = true, .ref = top<&P::margin_voxels>},
      {.key = "remove_small_components", .cli = "remove-small-components",
       .label = "remove specks", .stage = S::preprocess,
       .tooltip = "Drop connected components smaller than the fraction below.",
       .defines_object = true, .ref = top<&P::remove_small_components>},
      {.key = "min_component_fraction", .cli = "min-component-fraction", .label = "min component",
       .stage = S::preprocess,
       .tooltip = "Smallest component kept, as a fraction of the largest (0–1).", .lo = 0, .hi = 1,
       .defines_object = true, .ref = top<&P::min_component_fraction>},
      {.key = "fill_cavities", .cli = "fill-cavities", .label = "fill cavities",
       .stage = S::preprocess,
       .tooltip = "Enclosed background (a cavity) becomes object when it is small: see the "
                  "fraction below.",
       .defines_object = true, .ref = top<&P::fill_cavities>},
      {.key = "max_cavity_fraction", .cli = "max-cavity-fraction", .label = "max cavity",
       .stage = S::preprocess,
       .tooltip = "Largest cavity filled, as a fraction of the object's volume (≥ 0); larger "
                  "ones stay holes, as a skull's cranial cavity must. A large value fills all.",
       .lo = 0, .defines_object = true, .ref = top<&P::max_cavity_fraction>},
      // Stage 1: fields.
      {.key = "smoothing_sigma_mm", .cli = "smoothing-sigma", .label = "smoothing σ", .unit = "mm",
       .stage = S::preprocess,
       .tooltip = "Gaussian σ of the smoothed indicator whose 0.5 level is the sub-voxel boundary "
                  "(mm); auto: half the largest spacing.",
       .lo = 0, .zero_means = "auto", .ref = top<&P::smoothing_sigma_mm>},
      {.key = "medial_min_separation_mm", .cli = "medial-separation", .label = "medial λ",
       .unit = "mm", .stage = S::preprocess,
       .tooltip = "Medial axis: least distance between the two nearest boundary points (mm); "
                  "auto: 3 sizing units (the larger of the largest spacing and the object's volume "
                  "over 9 × its surface area, so a finer scan of the same anatomy keeps it).",
       .lo = 0, .zero_means = "auto", .ref = top<&P::medial_min_separation_mm>},
      {.key = "medial_min_angle_deg", .cli = "medial-angle", .label = "medial θ", .unit = "°",
       .stage = S::preprocess,
       .tooltip = "Medial axis: least angle between the two nearest boundary points, seen from "
                  "the voxel (degrees).",
       .lo = 0, .hi = 180, .ref = top<&P::medial_min_angle_deg>},
      {.key = "lfs_min_mm", .cli = "lfs-min", .label = "lfs min", .unit = "mm",
       .stage = S::preprocess,
       .tooltip = "Lower clamp of the local feature size (mm); auto: the largest spacing.", .lo = 0,
       .zero_means = "auto", .ref = top<&P::lfs_min_mm>},
      {.key = "lfs_max_mm", .cli = "lfs-max", .label = "lfs max", .unit = "mm",
       .stage = S::preprocess,
       .tooltip = "Upper clamp of the local feature size (mm); auto: 10 sizing units (see "
                  "medial λ).",
       .lo = 0, .zero_means = "auto", .ref = top<&P::lfs_max_mm>},
      // Stage 2.
      {.key = "r", .cli = "r", .label = "r", .stage = S::surface,
       .tooltip = "Surface sampling ratio in (0, 1): every boundary voxel lies within r·lfs of a "
                  "sample. Smaller = denser surface.",
       .lo = 0, .hi = 1, .lo_open = true, .hi_open = true, .slider = {0.05, 0.95},
       .ref = top<&P::r>},
      {.key = "chord_tolerance_mm", .cli = "chord-tolerance", .label = "chord tolerance",
       .unit = "mm", .stage = S::surface,
       .tooltip = "Where lfs is large, samples lie within √(8·δ·lfs) instead of r·lfs, so a "
                  "boundary triangle stays within δ of a surface curved with radius lfs (mm); 0: "
                  "r·lfs alone.",
       .lo = 0, .ref = top<&P::chord_tolerance_mm>},
      {.key = "surface_lfs_max_mm", .cli = "surface-lfs-max", .label = "surface lfs max",
       .unit = "mm", .stage = S::surface,
       .tooltip = "The surface is sampled as if lfs were at most this (mm), so its flat parts "
                  "still follow the segmentation's voxel-scale detail; the interior spacing "
                  "stays as without it. Auto: the median lfs over the object's boundary; a "
                  "value above every lfs (1000) turns it off.",
       .lo = 0, .zero_means = "auto", .ref = top<&P::surface_lfs_max_mm>},
      {.key = "target_vertices", .cli = "vertices", .label = "vertices", .stage = S::surface,
       .tooltip = "Approximate vertex count of the mesh: r and the interior points are scaled "
                  "together to reach it, keeping their balance (0: off, r and the interior "
                  "spacing as set); stage 6's boundary refinement adds up to a tenth more.",
       .lo = 0, .hi = 1e9, .zero_means = "off", .ref = top<&P::target_vertices>},
      // σ only scales the energies of eq. (3); Algorithm 1's order depends on h² − r²·lfs²
      // alone, so it changes no result.
      {.key = "sigma_surface_mm", .cli = "sigma-surface", .label = "σ surface", .unit = "mm",
       .stage = S::surface, .changes_no_result = true,
       .tooltip = "σ of the surface sampling energy (eq. 3, mm); it scales the energies only, "
                  "so the samples do not depend on it.",
       .lo = 0, .lo_open = true, .ref = top<&P::sigma_surface_mm>},
      {.key = "project_samples", .cli = "project-samples", .label = "project samples",
       .stage = S::surface,
       .tooltip = "Move surface samples onto the smoothed indicator's 0.5 level (sub-voxel "
                  "surface).",
       .ref = top<&P::project_samples>},
      // Stage 3.
      {.key = "sigma_density_mm", .cli = "sigma-density", .label = "σ density", .unit = "mm",
       .stage = S::cvt,
       .tooltip = "σ of the interior density ρ = 1 − exp(−lfs²/2σ²) (eq. 4, mm); auto: the "
                  "interior spacing.",
       .lo = 0, .zero_means = "auto", .ref = top<&P::sigma_density_mm>},
      {.key = "interior_spacing_mm", .cli = "interior-spacing", .label = "interior spacing",
       .unit = "mm", .stage = S::cvt,
       .tooltip = "Target distance between neighbouring interior points (mm); auto: the surface "
                  "samples' area-weighted mean spacing.",
       .lo = 0, .zero_means = "auto", .excludes = "interior-points",
       .ref = top<&P::interior_spacing_mm>},
      {.key = "interior_points", .cli = "interior-points", .label = "interior points",
       .stage = S::cvt, .tooltip = "Exact number of interior points; wins over the spacing.",
       .lo = 0, .zero_means = "from the spacing", .ref = top<&P::interior_points>},
      {.key = "epsilon_mm", .cli = "epsilon", .label = "ε", .unit = "mm", .stage = S::cvt,
       .tooltip = "Lloyd stops when Σ displacement of the sites < ε (mm); auto: 1 % of the "
                  "spacing × the number of sites.",
       .lo = 0, .zero_means = "auto", .ref = top<&P::epsilon_mm>},
      {.key = "max_iterations", .cli = "max-iterations", .label = "max iterations",
       .stage = S::cvt, .tooltip = "Cap on Lloyd iterations.", .lo = 0, .hi = 100000,
       .ref = top<&P::max_iterations>},
      {.key = "initial_points", .cli = "initial-points", .label = "initial points",
       .stage = S::cvt,
       .tooltip = "Where Lloyd starts: on a lattice thinned to the density (converges in fewer "
                  "iterations, to a lower energy) or drawn at random from the density (the "
                  "paper).",
       .words = {"random", "lattice"}, .ref = top<&P::lattice_start>},
      {.key = "seed", .cli = "seed", .label = "seed", .stage = S::cvt,
       .tooltip = "Seed of every random choice (initial interior points, stage 5's jitter).",
       .ref = top<&P::seed>},
      // Stage 5.
      {.key = "fidelity_rounds", .cli = "fidelity-rounds", .label = "fidelity rounds",
       .stage = S::mesh,
       .tooltip = "Where the mesh and the segmentation disagree by more than the tolerance (a "
                  "thin channel bridged, a thin sheet missed, a narrow pit down to an interior "
                  "sample), add surface samples and triangulate again, at most this many times.",
       .lo = 0, .hi = 10, .zero_means = "off", .ref = top<&P::fidelity_rounds>},
      {.key = "fidelity_tolerance_mm", .cli = "fidelity-tolerance", .label = "fidelity tolerance",
       .unit = "mm", .stage = S::mesh,
       .tooltip = "Disagreement between mesh and segmentation that triggers a refinement round "
                  "(mm); auto: 1.5 × the largest voxel spacing.",
       .lo = 0, .zero_means = "auto", .ref = top<&P::fidelity_tolerance_mm>},
      // Stage 6.
      {.key = "optimize", .cli = "optimize", .label = "optimisation", .stage = S::optimize,
       .tooltip = "Stage 6, flips, vertex moves and insertions that remove slivers: default (on) "
                  "or none (the paper's stage-5 mesh, slivers and all).",
       .words = {"none", "default"}, .ref = top<&P::optimize>},
      {.key = "target_dihedral_deg", .section = kOpt, .cli = "opt-target-dihedral-deg",
       .label = "target dihedral", .unit = "°", .stage = S::optimize,
       .tooltip = "Tets with a dihedral angle below this, or above 180° minus this, are bad and "
                  "worked on (degrees).",
       .lo = 1, .hi = 35, .ref = opt<&O::target_dihedral_deg>, .active = optimizing},
      {.key = "max_passes", .section = kOpt, .cli = "opt-max-passes", .label = "max passes",
       .stage = S::optimize,
       .tooltip = "Most passes of stage 6; a pass that changes nothing ends it early (count).",
       .lo = 0, .hi = 100, .ref = opt<&O::max_passes>, .active = optimizing},
      {.key = "flips", .section = kOpt, .cli = "opt-flips", .label = "flips", .stage = S::optimize,
       .tooltip = "Edge removal (3-2, 4-4, ...) and 2-3 face flips on bad tets.",
       .ref = opt<&O::flips>, .active = optimizing},
      {.key = "boundary_flips", .section = kOpt, .cli = "opt-boundary-flips",
       .label = "boundary flips", .stage = S::optimize,
       .tooltip = "Swap the diagonal of two boundary triangles where the boundary is convex, and "
                  "remove corner tets, when the new triangles follow the segmentation surface.",
       .ref = opt<&O::boundary_flips>, .active = optimizing},
      {.key = "max_face_distance_voxels", .section = kOpt, .cli = "opt-max-face-distance-voxels",
       .label = "max face distance", .unit = "voxels", .stage = S::optimize,
       .tooltip = "Boundary flips: largest distance of a new boundary triangle from the surface "
                  "(0.5 level), in smallest voxel spacings.",
       .lo = 0, .hi = 5, .ref = opt<&O::max_face_distance_voxels>, .active = optimizing},
      {.key = "max_boundary_shift_mm", .section = kOpt, .cli = "opt-max-boundary-shift-mm",
       .label = "max boundary shift", .unit = "mm", .stage = S::optimize,
       .tooltip = "Boundary flips without the smoothed indicator: largest boundary move allowed "
                  "(mm; 0 = none).",
       .lo = 0, .hi = 10, .ref = opt<&O::max_boundary_shift_mm>, .active = optimizing},
      {.key = "insert_vertices", .section = kOpt, .cli = "opt-insert-vertices",
       .label = "insert vertices", .stage = S::optimize,
       .tooltip = "Insert interior vertices where flips and moves cannot help (appended after the "
                  "mesh's vertices).",
       .ref = opt<&O::insert_vertices>, .active = optimizing},
      {.key = "smooth_interior", .section = kOpt, .cli = "opt-smooth-interior",
       .label = "move interior vertices", .stage = S::optimize,
       .tooltip = "Move interior vertices to raise the worst tet of their star.",
       .ref = opt<&O::smooth_interior>, .active = optimizing},
      {.key = "smooth_surface", .section = kOpt, .cli = "opt-smooth-surface",
       .label = "slide surface vertices", .stage = S::optimize,
       .tooltip = "Slide boundary vertices along the sub-voxel surface (0.5 level of the smoothed "
                  "indicator).",
       .ref = opt<&O::smooth_surface>, .active = optimizing},
      {.key = "smoothing_iterations", .section = kOpt, .cli = "opt-smoothing-iterations",
       .label = "smoothing iterations", .stage = S::optimize,
       .tooltip = "Ascent steps per vertex and pass (count).", .lo = 0, .hi = 50,
       .ref = opt<&O::smoothing_iterations>, .active = optimizing},
      {.key = "odt_passes", .section = kOpt, .cli = "opt-odt-passes", .label = "ODT passes",
       .stage = S::optimize,
       .tooltip = "In this many first passes, a global ODT sweep moves the interior vertices "
                  "towards the volume-weighted mean of their tets' circumcentres (count).",
       .lo = 0, .hi = 100, .ref = opt<&O::odt_passes>, .active = optimizing},
      {.key = "odt_iterations", .section = kOpt, .cli = "opt-odt-iterations",
       .label = "ODT iterations", .stage = S::optimize,
       .tooltip = "ODT sweeps per such pass (count).", .lo = 0, .hi = 20,
       .ref = opt<&O::odt_iterations>, .active = optimizing},
      // Off by default: on the liver it gave +1.5 % good tets for +60 % stage-6 time.
      {.key = "odt_flips", .section = kOpt, .cli = "opt-odt-flips", .label = "flips after ODT",
       .stage = S::optimize,
       .tooltip = "Delaunay flips after each ODT sweep (a little better, much slower).",
       .ref = opt<&O::odt_flips>, .active = optimizing},
      // The global flip passes lift Table I's good bins (on the liver +2.5 % in each measure for
      // ~0.2 s), not only the bad tets. Three rather than one: on the liver, skull and brain
      // phantom +1.3 to +1.7 points in every good bin and 42–60 % fewer tets below 20°, for
      // +0.04–0.14 s of stage 6 (single runs; bench/results/compare*.md for whole processes).
      {.key = "global_flip_passes", .section = kOpt, .cli = "opt-global-flip-passes",
       .label = "global flip passes", .stage = S::optimize,
       .tooltip = "In this many first passes, flips also work on mediocre tets (quality below the "
                  "next value), not only bad ones (count).",
       .lo = 0, .hi = 100, .ref = opt<&O::global_flip_passes>, .active = optimizing},
      {.key = "global_flip_below", .section = kOpt, .cli = "opt-global-flip-below",
       .label = "global flip below", .stage = S::optimize,
       .tooltip = "Quality below which those passes flip a tet (1 = bad; the quality is the "
                  "smallest of each measure over its bad-bin edge, unitless).",
       .lo = 1, .hi = 10, .ref = opt<&O::global_flip_below>, .active = optimizing},
      // Interior samples that stage 5's peeling exposed are on the boundary but off the surface:
      // sliding them onto it would move the boundary, so they stay.
      {.key = "surface_tolerance_voxels", .section = kOpt, .cli = "opt-surface-tolerance-voxels",
       .label = "surface tolerance", .unit = "voxels", .stage = S::optimize,
       .tooltip = "Boundary vertices farther than this from the surface are not surface samples "
                  "and stay fixed (smallest voxel spacings).",
       .lo = 0, .hi = 2, .ref = opt<&O::surface_tolerance_voxels>, .active = optimizing},
      // A facet-distance bound, as CGAL Mesh_3's facet_distance: r·lfs alone cuts across the
      // segmentation's voxel-scale detail (where a thick slice ends). In millimetres, from the
      // anatomy's own scale, so a finer scan of the same organ gets about as many vertices.
      {.key = "refine_boundary", .section = kOpt, .cli = "opt-refine-boundary",
       .label = "refine boundary", .stage = S::optimize,
       .tooltip = "In stage 6's second and third passes, insert boundary vertices where the "
                  "segmentation's boundary lies farther than the tolerance below from the mesh "
                  "boundary, farthest first, at most a tenth more vertices.",
       .ref = opt<&O::refine_boundary>, .active = optimizing},
      {.key = "boundary_tolerance_mm", .section = kOpt, .cli = "opt-boundary-tolerance",
       .label = "boundary tolerance", .unit = "mm", .stage = S::optimize,
       .tooltip = "Boundary refinement: farthest the segmentation's boundary may lie from the "
                  "mesh boundary (mm); auto: half the sizing unit (see medial λ).",
       .lo = 0, .zero_means = "auto", .ref = opt<&O::boundary_tolerance_mm>,
       .active = optimizing},
      {.key = "fit_surface", .section = kOpt, .cli = "opt-fit-surface",
       .label = "fit boundary to surface", .stage = S::optimize,
       .tooltip = "Last: move boundary vertices along the normal so the boundary triangles fit "
                  "the sub-voxel surface in the least-squares sense (they no longer cut its "
                  "chords), as far as no tet turns bad.",
       .ref = opt<&O::fit_surface>, .active = optimizing},
      // No stage: how the run is carried out.
      {.key = "threads", .cli = "threads", .label = "threads",
       .tooltip = "Worker threads. Results do not depend on it.", .lo = 0, .hi = 1024,
       .zero_means = "all cores", .ref = top<&P::threads>},
      {.key = "max_points", .cli = "max-points", .label = "max points",
       .tooltip = "Guard: refuse runs that would need more interior points than this (a tiny "
                  "spacing or r → 0).",
       .lo = 0, .lo_open = true, .ref = top<&P::max_points>},
      {.key = "max_memory_mb", .cli = "max-memory", .label = "max memory", .unit = "MB",
       .tooltip = "Guard: refuse runs whose estimated memory exceeds this (MB).", .lo = 0,
       .zero_means = "available memory", .ref = top<&P::max_memory_mb>},
  };
}

std::string number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

template <class T>
constexpr bool is_integer_v = std::is_integral_v<T> && !std::is_same_v<T, bool>;

void require(bool ok, const ParameterSpec& spec, const std::string& what) {
  if (!ok) throw InputError(spec.name() + ": " + what);
}

void check(const ParameterSpec& spec, const Parameters& p) {
  visit_parameter(spec, p, [&](const auto& v) {
    using T = std::decay_t<decltype(v)>;
    auto in_range = [&](double x) {
      return (spec.lo_open ? x > spec.lo : x >= spec.lo) &&
             (spec.hi_open ? x < spec.hi : x <= spec.hi);
    };
    if constexpr (std::is_same_v<T, double>) {
      if (!(std::isfinite(v) && in_range(v))) {
        const std::string range = range_text(spec);
        require(false, spec, range.empty() ? "must be a finite number" : range);
      }
    } else if constexpr (is_integer_v<T>) {
      if (!in_range(double(v))) require(false, spec, range_text(spec));
    } else if constexpr (std::is_same_v<T, std::optional<double>>) {
      require(!v || std::isfinite(*v), spec, "must be a finite number");
    } else if constexpr (is_word_switch_v<T>) {
      require(int(v) == 0 || int(v) == 1, spec,
              "must be \"" + std::string(spec.words[0]) + "\" or \"" +
                  std::string(spec.words[1]) + "\"");
    }
  });
}

}  // namespace

std::string_view optimize_word(OptimizeMode mode) {
  return find_parameter("", "optimize")->words[int(mode)];
}

std::string ParameterSpec::name() const {
  return section.empty() ? std::string(key) : std::string(section) + "." + std::string(key);
}

std::string ParameterSpec::label_with_unit() const {
  return unit.empty() ? std::string(label) : std::string(label) + " (" + std::string(unit) + ")";
}

const std::vector<ParameterSpec>& parameter_registry() {
  static const std::vector<ParameterSpec> registry = make_registry();
  return registry;
}

const ParameterSpec* find_parameter(std::string_view section, std::string_view key) {
  for (const ParameterSpec& s : parameter_registry())
    if (s.section == section && s.key == key) return &s;
  return nullptr;
}

bool same_value(const ParameterSpec& spec, const Parameters& a, const Parameters& b) {
  bool same = false;
  visit_parameter(spec, a, [&](const auto& x) {
    visit_parameter(spec, b, [&](const auto& y) {
      if constexpr (std::is_same_v<decltype(x), decltype(y)>) same = x == y;
    });
  });
  return same;
}

void copy_value(const ParameterSpec& spec, const Parameters& from, Parameters& to) {
  visit_parameter(spec, to, [&](auto& out) {
    visit_parameter(spec, from, [&](const auto& in) {
      if constexpr (std::is_same_v<std::decay_t<decltype(out)>, std::decay_t<decltype(in)>>)
        out = in;
    });
  });
}

std::string range_text(const ParameterSpec& spec) {
  std::string text;
  const bool has_lo = spec.lo > -kInf, has_hi = spec.hi < kInf;
  bool integer = false;
  visit_parameter(spec, Parameters{}, [&](const auto& v) {
    integer = is_integer_v<std::decay_t<decltype(v)>>;
  });
  if (has_lo && has_hi)
    text = integer ? "must be in " + number(spec.lo) + ".." + number(spec.hi)
                   : "must be in " + std::string(spec.lo_open ? "(" : "[") + number(spec.lo) +
                         ", " + number(spec.hi) + (spec.hi_open ? ")" : "]");
  else if (has_lo)
    text = std::string(spec.lo_open ? "must be > " : "must be >= ") + number(spec.lo);
  else if (has_hi)
    text = std::string(spec.hi_open ? "must be < " : "must be <= ") + number(spec.hi);
  if (!text.empty() && !spec.zero_means.empty())
    text += " (0 = " + std::string(spec.zero_means) + ")";
  return text;
}

void validate(const Parameters& p) {
  for (const ParameterSpec& spec : parameter_registry()) check(spec, p);
  const ParameterSpec& lfs_max = *find_parameter("", "lfs_max_mm");
  require(p.lfs_max_mm == 0 || p.lfs_max_mm >= p.lfs_min_mm, lfs_max,
          "must not be below lfs_min_mm");
}

void clamp_to_ranges(Parameters& p) {
  for (const ParameterSpec& spec : parameter_registry())
    visit_parameter(spec, p, [&](auto& v) {
      using T = std::decay_t<decltype(v)>;
      if constexpr (std::is_same_v<T, double> || is_integer_v<T>) {
        const double before = double(v);
        double x = std::isfinite(before) ? before : spec.lo;
        if (!spec.lo_open && x < spec.lo) x = spec.lo;
        if (!spec.hi_open && x > spec.hi) x = spec.hi;
        if (x != before && std::isfinite(x)) v = T(x);  // (unchanged values keep every bit)
      }
    });
}

void validate(const OptimizationOptions& options) {
  Parameters p;
  p.optimization = options;
  for (const ParameterSpec& spec : parameter_registry())
    if (spec.section == kOpt) check(spec, p);
}

Stage first_changed_stage(const Parameters& a, const Parameters& b) {
  Stage first = Stage::count;
  for (const ParameterSpec& spec : parameter_registry())
    if (stales_from(spec) < first && (is_active(spec, a) || is_active(spec, b)) &&
        !same_value(spec, a, b))
      first = stales_from(spec);
  return first;
}

}  // namespace cvt
