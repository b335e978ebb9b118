// Which tets a click in the quality panel selects (a Table I bin or a histogram bar of one
// measure), binned exactly as core/quality.cpp bins them so the highlighted count equals the
// count shown. Also the colour scale of each measure for the 3D view and its legend. GL-free.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "evaluate/quality.h"

namespace cvt::render {

// Table I bin of a value: 0 (Q < lo), 1 (lo ≤ Q ≤ hi), 2 (Q > hi); non-finite: 2 if > 0 else 0.
int table1_bin(double value, const std::array<double, 2>& edges);
// Histogram bar of a value over [lo, hi] in `bars` bars (outside → end bars, non-finite → last).
int histogram_bar(double value, double lo, double hi, int bars);

struct TetSelection {
  enum class Kind { none, table1_bin, histogram_bar };
  Kind kind = Kind::none;
  Measure measure = Measure::VOverRmc3;
  int index = 0;                  // the bin or bar
  std::array<double, 2> range{};  // histogram range (bars only)
  int bars = 0;                   // bar count (bars only)
  bool operator==(const TetSelection&) const = default;
};

// 1 for the selected tets, given the per-tet values of selection.measure.
std::vector<std::uint8_t> select_tets(const std::vector<double>& values,
                                      const TetSelection& selection);
std::string describe(const TetSelection& selection);

// How a measure maps to colours: [lo, hi] and whether larger values are better (the colormap
// runs red → green in the better direction).
struct MeasureScale {
  double lo = 0, hi = 1;
  bool higher_is_better = true;
};
MeasureScale measure_scale(Measure m);
// The measure whose key (measure_key) is `key`, or false.
bool measure_from_key(const std::string& key, Measure& out);

// The histogram of any per-tet measure over its scale with `bars` bars (the Shewchuk ones match
// QualityReport's histograms when bars = QualityOptions::histogram_bins).
std::vector<std::size_t> measure_histogram(const std::vector<double>& values, Measure m, int bars);

// Table I bins and dihedral figures from per-tet values of every Measure (in enum order, as
// MeshLayers and MeshMeasures hold them), binned as core/quality.cpp bins them: the quality
// panel's before/after columns, also while stage 6 is stepped and no QualityReport is current.
struct MeshFigures {
  std::size_t tets = 0;
  std::array<std::array<double, 3>, 3> bins_percent{};  // kShewchukMeasures order
  double min_dihedral_deg = 0, max_dihedral_deg = 0;
  std::size_t below_10 = 0, below_20 = 0;  // tets whose min dihedral angle is below (°)
};
MeshFigures mesh_figures(const std::array<std::vector<double>, 6>& measures);

}  // namespace cvt::render
