// Stage 3 (paper III-D, Algorithm 2): interior samples I by Lloyd's algorithm on the voxel grid.
// Each object voxel belongs to its exactly nearest site (a discrete Voronoi tessellation); every
// site moves to the ρ-weighted centroid of its voxels, until Σ displacement < ε.
//
// Frames: sites live in the grid's local frame (mm, spacing ⊙ index, no origin or rotation),
// where distances equal world distances because the direction matrix is orthonormal; world
// positions (grid.index_to_world) are what callers draw and mesh.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <random>
#include <vector>

#include "base/progress.h"
#include "base/volume.h"
#include "preprocess/preprocess.h"
#include "sampling/nearest_site.h"

namespace cvt {

struct CvtOptions {
  double sigma_density_mm = 0;       // σ_d of eq. 4 (mm); 0 = auto: the interior spacing
  double interior_spacing_mm = 0;    // wanted distance between neighbouring sites (mm)
  std::int64_t interior_points = 0;  // number of sites; > 0 wins over interior_spacing_mm
  double epsilon_mm = 0;             // stop when Σ displacement < ε (mm); 0 = auto (below)
  int max_iterations = 100;          // run_to_convergence stops here anyway
  std::uint64_t seed = 1;            // initial points (std::mt19937_64)
  bool lattice_start = true;         // initial points on a BCC lattice (below), or drawn from ρ
};

// Density weights are ρ quantised to multiples of 2^-kWeightBits, so centroid sums are exact
// int64 sums (independent of summation order, hence of the thread count).
inline constexpr int kWeightBits = 20;

// Volume per site (mm³) of a BCC lattice whose nearest-neighbour distance is 1 mm: the cubic
// cell (edge 2/√3) holds 2 sites, so 4/(3√3). BCC is the lattice a uniform CVT converges to.
inline constexpr double kBccVolumePerSite = 0.769800358919501;

// Eq. 4: ρ = 1 − exp(−lfs² / (2σ²)) inside, 0 outside.
double density_from_lfs(double lfs_mm, double sigma_mm);
Volume<float> compute_density(const Mask& object, const Volume<float>& lfs_mm, double sigma_mm);

// Parameters after resolving the "auto" and "either/or" choices.
struct CvtResolved {
  std::int64_t sites = 0;       // N = volume / (0.7698 · spacing³), or interior_points
  double spacing_mm = 0;        // the spacing N corresponds to (given or derived from N)
  double sigma_density_mm = 0;  // auto = spacing_mm: ρ = 0.99 at lfs = 3 spacings, 0.86 at 2,
                                // 0.39 at 1: parts thinner than ~2 spacings, which the surface
                                // samples already fill, get fewer interior sites
  double epsilon_mm = 0;        // auto = 0.01 · spacing · N: mean displacement < 1 % spacing
  double object_volume_mm3 = 0;
};
// Throws InputError naming --interior-spacing/--interior-points when neither is set.
CvtResolved resolve_cvt_options(const CvtOptions& options, const Mask& object);

struct IterationStats {
  int iteration = 0;  // 0-based
  double energy = 0;  // Σ over object voxels p of ρ(p)·|p − z_owner(p)|² (mm², ρ quantised as
                      // above), for the sites BEFORE this iteration's move and their exact
                      // nearest-site owners; never increases from one iteration to the next
  double displacement_sum_mm = 0;  // Σ |z* − z| over the sites (paper's delta)
  double displacement_mean_mm = 0;
  double displacement_max_mm = 0;
  std::int64_t empty_regions = 0;  // sites that own no weight (they stay where they are)
  double wall_s = 0;
};

// Stateful Lloyd solver the CLI and the viewer share (the viewer runs it on a worker thread; it
// is not itself thread-safe). Deterministic: same input + seed → identical sites, whatever the
// thread count.
class LloydStepper {
 public:
  // ρ from eq. 4 on pre.lfs_mm; keeps copies of what it needs, not references.
  LloydStepper(const PreprocessResult& pre, const CvtOptions& options);
  // ρ given directly (≥ 0 inside, ignored outside), e.g. ρ ≡ 1 for tests.
  LloydStepper(const Mask& object, const Volume<float>& density, const CvtOptions& options);
  ~LloydStepper();
  LloydStepper(LloydStepper&&) noexcept;
  LloydStepper& operator=(LloydStepper&&) noexcept;

  // Places the N initial sites; clears history. step()/run() call it when needed.
  //   - lattice_start: on a BCC lattice (the lattice a uniform CVT tends to), each point kept
  //     with probability (ρ/ρmax)^(3/5) (a CVT's point density is ∝ ρ^(3/5) in 3D), its
  //     spacing chosen so that N points are expected; the count is then made exactly N by
  //     dropping random ones or drawing the rest as below. Far from the boundary the sites
  //     start where Lloyd would take them, so it converges in fewer iterations to a lower
  //     energy (the liver: 5 instead of 14).
  //   - otherwise (the paper): each drawn from ρ (voxel ∝ ρ, uniform jitter inside it).
  void initialize();
  // One Lloyd iteration: assign voxels, move sites to centroids.
  IterationStats step(const Progress& progress = {});
  // Up to k iterations, stopping after one that converges; checks cancellation before each
  // (and step() inside). Returns the number done. A cancelled iteration leaves no trace.
  int run(int k, const Progress& progress = {});
  // Until Σ displacement < ε or max_iterations iterations in total.
  int run_to_convergence(const Progress& progress = {});
  bool converged() const { return converged_; }

  const CvtResolved& resolved() const { return resolved_; }
  const Grid& grid() const { return grid_; }
  const std::vector<Vec3>& sites_local() const { return sites_local_; }  // mm, spacing ⊙ index
  const std::vector<Vec3>& sites_world() const { return sites_world_; }  // mm
  const std::vector<IterationStats>& history() const { return history_; }
  // Frees the voxels (the density bricks, most of the stepper's memory) once no more steps or
  // voxel owners are wanted; sites and history stay. Stepping or labelling after it throws.
  void release_voxels();

  // Owner (nearest site, current sites) of every voxel; −1 outside the object.
  void compute_labels(Volume<std::int32_t>& out) const;
  // Owners of the voxels of slice `index` along `axis` (0 = i, 1 = j, 2 = k), −1 outside; the
  // lower remaining axis varies fastest.
  std::vector<std::int32_t> slice_labels(int axis, int index) const;
  // Owners of arbitrary voxels (linear indices), e.g. the boundary voxels F.
  std::vector<std::int32_t> owners_of(const std::vector<std::int32_t>& voxels) const;

 private:
  // density(v): ρ of object voxel v (linear index).
  void pack_bricks(const Mask& object, const std::function<float(std::size_t)>& density);
  void set_sites(std::vector<Vec3> local);
  bool inside(int i, int j, int k) const;
  std::int32_t weight_at(int i, int j, int k) const;  // fine point's weight, −1 outside
  std::vector<Vec3> lattice_sites(std::mt19937_64& rng) const;
  void require_voxels() const;

  // Sets the integration grid: sub_³ points per voxel (sub_ odd, so one point is the voxel
  // centre) where sites are denser than one per 2³ voxels (coarse CT, thin structures), else 1.
  void subdivide(std::size_t object_voxels);

  Grid grid_;
  CvtResolved resolved_;
  // Integration points: voxels split into sub_³ (sub_ odd). With fewer points than sites, most
  // sites own none and never move, and the rest sit on voxel centres. Bricks, weights and the
  // kernel work on fine_ (its own local frame: spacing / sub_ ⊙ fine index); sites, labels and
  // owners stay on grid_. offset_ = fine-local − image-local of one point.
  int sub_ = 1;
  Grid fine_;
  Vec3 offset_{0, 0, 0};
  std::uint64_t seed_ = 1;
  bool lattice_start_ = true;
  int max_iterations_ = 100;
  std::array<int, 3> brick_{8, 8, 4};       // voxels per brick along i, j, k
  std::array<int, 3> brick_grid_{0, 0, 0};  // bricks along i, j, k
  std::vector<VoxelBrick> bricks_;          // bricks holding object voxels
  std::vector<std::int32_t> brick_at_;      // brick grid → index into bricks_, −1 if empty
  std::vector<std::int32_t> weight_;        // per brick slot: ρ·2^20, −1 outside the object
  std::vector<Vec3> sites_local_, sites_world_;
  std::vector<IterationStats> history_;
  bool initialized_ = false, converged_ = false, released_ = false;
};

}  // namespace cvt
