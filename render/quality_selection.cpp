#include "quality_selection.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace cvt::render {

int table1_bin(double v, const std::array<double, 2>& edges) {
  if (!std::isfinite(v)) return v > 0 ? 2 : 0;
  return v < edges[0] ? 0 : (v > edges[1] ? 2 : 1);
}

int histogram_bar(double v, double lo, double hi, int bars) {
  bars = std::max(bars, 1);
  if (!std::isfinite(v)) return bars - 1;
  const double width = (hi - lo) / double(bars);
  const double t = std::floor((v - lo) / width);
  return int(std::clamp(t, 0.0, double(bars - 1)));
}

std::vector<std::uint8_t> select_tets(const std::vector<double>& values, const TetSelection& s) {
  std::vector<std::uint8_t> out(values.size(), 0);
  if (s.kind == TetSelection::Kind::none) return out;
  const auto edges = table1_bin_edges(s.measure);
  for (std::size_t t = 0; t < values.size(); ++t) {
    const int bin = s.kind == TetSelection::Kind::table1_bin
                        ? table1_bin(values[t], edges)
                        : histogram_bar(values[t], s.range[0], s.range[1], s.bars);
    out[t] = bin == s.index;
  }
  return out;
}

std::string describe(const TetSelection& s) {
  if (s.kind == TetSelection::Kind::none) return "nothing";
  const std::string name(measure_key(s.measure));
  char text[160];
  if (s.kind == TetSelection::Kind::table1_bin) {
    static const char* bins[] = {"low", "middle", "high"};
    std::snprintf(text, sizeof text, "%s Table I %s bin", name.c_str(),
                  bins[std::clamp(s.index, 0, 2)]);
  } else {
    const double w = (s.range[1] - s.range[0]) / std::max(s.bars, 1);
    std::snprintf(text, sizeof text, "%s in [%.4g, %.4g)", name.c_str(), s.range[0] + s.index * w,
                  s.range[0] + (s.index + 1) * w);
  }
  return text;
}

MeasureScale measure_scale(Measure m) {
  switch (m) {
    case Measure::VOverRmc3:
    case Measure::GradientError:
    case Measure::ConditionNumber:
      return {0.0, regular_tet_value(m), true};
    case Measure::MinDihedralDeg:
      return {0.0, regular_tet_value(m), true};
    case Measure::MaxDihedralDeg:
      return {regular_tet_value(m), 180.0, false};
    case Measure::RadiusEdge:
      return {regular_tet_value(m), 3.0, false};
  }
  return {};
}

bool measure_from_key(const std::string& key, Measure& out) {
  for (int k = 0; k < 6; ++k)
    if (measure_key(Measure(k)) == key) {
      out = Measure(k);
      return true;
    }
  return false;
}

std::vector<std::size_t> measure_histogram(const std::vector<double>& values, Measure m, int bars) {
  const MeasureScale s = measure_scale(m);
  std::vector<std::size_t> h(std::size_t(std::max(bars, 1)), 0);
  for (double v : values) ++h[histogram_bar(v, s.lo, s.hi, bars)];
  return h;
}

MeshFigures mesh_figures(const std::array<std::vector<double>, 6>& measures) {
  MeshFigures f;
  const auto& min_d = measures[int(Measure::MinDihedralDeg)];
  const auto& max_d = measures[int(Measure::MaxDihedralDeg)];
  f.tets = min_d.size();
  if (f.tets == 0) return f;
  for (int k = 0; k < 3; ++k) {
    const Measure m = kShewchukMeasures[k];
    const auto edges = table1_bin_edges(m);
    std::array<std::size_t, 3> counts{};
    for (double v : measures[int(m)]) ++counts[table1_bin(v, edges)];
    for (int b = 0; b < 3; ++b) f.bins_percent[k][b] = 100.0 * double(counts[b]) / double(f.tets);
  }
  f.min_dihedral_deg = *std::min_element(min_d.begin(), min_d.end());
  f.max_dihedral_deg = *std::max_element(max_d.begin(), max_d.end());
  for (double v : min_d) f.below_10 += v < 10, f.below_20 += v < 20;
  return f;
}

}  // namespace cvt::render
