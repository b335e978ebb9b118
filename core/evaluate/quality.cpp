// Element measures (Shewchuk 2002, raw), dihedral angles, radius–edge ratio, their statistics and
// the JSON report. Validity lives in mesh_validity.cpp.
#include "evaluate/quality.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>

#include "base/errors.h"
#include "base/memory.h"

namespace cvt {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kRadToDeg = 180.0 / std::numbers::pi;
// Edges in the order used everywhere here: 01, 02, 03, 12, 13, 23.
constexpr int kEdge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

// Smallest ball through the points (a segment's, a triangle's or a tet's circumball).
struct Ball {
  Vec3 center;
  double r2 = kInf;  // squared radius; inf when the points are degenerate
};

Ball segment_ball(const Vec3& a, const Vec3& b) {
  return {(a + b) * 0.5, squared_distance(a, b) / 4};
}

Ball triangle_ball(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 u = b - a, v = c - a, n = cross(u, v);
  const double n2 = squared_norm(n);
  if (!(n2 > 0)) return {};
  const Vec3 off = (squared_norm(u) * cross(v, n) + squared_norm(v) * cross(n, u)) / (2 * n2);
  return {a + off, squared_norm(off)};
}

Ball tet_ball(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const Vec3 u = b - a, v = c - a, w = d - a;
  const double det = dot(u, cross(v, w));
  if (det == 0) return {};
  const Vec3 off = (squared_norm(u) * cross(v, w) + squared_norm(v) * cross(w, u) +
                    squared_norm(w) * cross(u, v)) /
                   (2 * det);
  return {a + off, squared_norm(off)};
}

// x^{3/4} without pow.
double pow34(double x) {
  const double r = std::sqrt(x);
  return r * std::sqrt(r);
}

}  // namespace

TetFigures tet_figures(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                       bool all_dihedrals) {
  const Vec3 p[4] = {a, b, c, d};
  const double volume = dot(b - a, cross(c - a, d - a)) / 6.0;
  // N[i]: twice the area vector of the face opposite vertex i, all pointing the same way
  // (out of the tet when it is positively oriented); A[i] its area.
  const Vec3 N[4] = {cross(c - b, d - b), cross(d - a, c - a), cross(b - a, d - a),
                     cross(c - a, b - a)};
  double A[4], sum_a = 0, sum_a2 = 0, cross_sum = 0, min_l2 = kInf;
  for (int i = 0; i < 4; ++i) A[i] = 0.5 * norm(N[i]), sum_a += A[i], sum_a2 += A[i] * A[i];
  TetFigures f;
  // Dihedral at edge e = ij, between the faces opposite k and l: π − angle(N_k, N_l).
  auto dihedral = [&](int e) {
    const int k = kEdge[5 - e][0], l = kEdge[5 - e][1];
    return std::atan2(norm(cross(N[k], N[l])), -dot(N[k], N[l])) * kRadToDeg;
  };
  // Without all the angles: the edges of the extreme ones by a pseudo-angle, monotonic in the
  // angle and as precise near 0° and 180° (s / (|c| + s) from the unnormalised sine and cosine).
  int smallest = 0, largest = 0;
  double pseudo_min = kInf, pseudo_max = -kInf;
  bool degenerate = false;  // a face without area: then every angle, as with all_dihedrals
  for (int e = 0; e < 6; ++e) {
    const int i = kEdge[e][0], j = kEdge[e][1], k = kEdge[5 - e][0], l = kEdge[5 - e][1];
    const double l2 = squared_distance(p[i], p[j]);
    cross_sum += A[i] * A[j] * l2;
    min_l2 = std::min(min_l2, l2);
    if (all_dihedrals) {
      f.dihedral[std::size_t(e)] = dihedral(e);
    } else {
      const double sine = norm(cross(N[k], N[l])), cosine = -dot(N[k], N[l]);
      const double q = sine / (std::abs(cosine) + sine), pseudo = cosine >= 0 ? q : 2 - q;
      degenerate = degenerate || std::isnan(pseudo);
      if (pseudo < pseudo_min) pseudo_min = pseudo, smallest = e;
      if (pseudo > pseudo_max) pseudo_max = pseudo, largest = e;
    }
  }
  // r_mc: the circumradius when the circumcentre is inside, else the general search.
  const Ball sphere = tet_ball(a, b, c, d);
  const double R = std::sqrt(sphere.r2);
  double rmc = 0;
  bool inside = std::isfinite(sphere.r2);
  for (int i = 0; i < 4 && inside; ++i)  // the face opposite i contains p[(i + 1) % 4]
    inside = dot(sphere.center - p[(i + 1) % 4], N[i]) * volume <= 0;
  rmc = inside ? R : min_containing_ball_radius(a, b, c, d);
  f.shewchuk[0] = rmc > 0 ? volume / (rmc * rmc * rmc) : 0;
  f.shewchuk[1] = cross_sum > 0 ? volume * pow34(sum_a / cross_sum) : 0;
  f.shewchuk[2] = sum_a2 > 0 ? volume / pow34(0.25 * sum_a2) : 0;
  if (degenerate)
    for (int e = 0; e < 6; ++e) f.dihedral[std::size_t(e)] = dihedral(e);
  if (all_dihedrals || degenerate) {
    f.min_dihedral = *std::min_element(f.dihedral.begin(), f.dihedral.end());
    f.max_dihedral = *std::max_element(f.dihedral.begin(), f.dihedral.end());
  } else {
    f.min_dihedral = dihedral(smallest), f.max_dihedral = dihedral(largest);
  }
  f.radius_edge = min_l2 > 0 ? R / std::sqrt(min_l2) : kInf;
  return f;
}

namespace {

const Vec3& vtx(const TetMesh& mesh, std::int32_t v) {
  if (v < 0 || std::size_t(v) >= mesh.vertices.size())
    throw InputError("mesh: a tet references vertex " + std::to_string(v) + " but there are " +
                     std::to_string(mesh.vertices.size()) + " vertices");
  return mesh.vertices[std::size_t(v)];
}

}  // namespace

double measure_of(const TetFigures& f, Measure m) {
  switch (m) {
    case Measure::VOverRmc3:
      return f.shewchuk[0];
    case Measure::GradientError:
      return f.shewchuk[1];
    case Measure::ConditionNumber:
      return f.shewchuk[2];
    case Measure::MinDihedralDeg:
      return f.min_dihedral;
    case Measure::MaxDihedralDeg:
      return f.max_dihedral;
    case Measure::RadiusEdge:
      return f.radius_edge;
  }
  return 0;
}

namespace {

// Min/mean/max, Table I bins (when `edges` is given) and a histogram over [lo, hi].
MeasureStats summarise(const std::vector<double>& values, const std::array<double, 2>* edges,
                       double lo, double hi, int bins) {
  MeasureStats s;
  s.histogram_range = {lo, hi};
  s.histogram.assign(std::size_t(std::max(bins, 1)), 0);
  std::array<std::size_t, 3> table{};
  double sum = 0, mn = kInf, mx = -kInf;
  std::size_t finite = 0;
  const double width = (hi - lo) / double(s.histogram.size());
  for (double v : values) {
    if (!std::isfinite(v)) {
      ++s.non_finite;
      ++s.histogram.back();
      if (edges) ++table[v > 0 ? 2 : 0];
      continue;
    }
    ++finite, sum += v, mn = std::min(mn, v), mx = std::max(mx, v);
    const double t = std::floor((v - lo) / width);
    ++s.histogram[std::size_t(std::clamp(t, 0.0, double(s.histogram.size() - 1)))];
    if (edges) ++table[v < (*edges)[0] ? 0 : (v > (*edges)[1] ? 2 : 1)];
  }
  if (finite) s.min = mn, s.max = mx, s.mean = sum / double(finite);
  if (edges && !values.empty())
    for (int i = 0; i < 3; ++i)
      s.bins_percent[i] = 100.0 * double(table[i]) / double(values.size());
  return s;
}

nlohmann::json stats_json(const MeasureStats& s) {
  return {{"min", s.min},
          {"mean", s.mean},
          {"max", s.max},
          {"non_finite", s.non_finite},
          {"histogram", s.histogram},
          {"histogram_range", s.histogram_range}};
}

}  // namespace

std::string_view measure_key(Measure m) {
  switch (m) {
    case Measure::VOverRmc3:
      return "v_over_rmc3";
    case Measure::GradientError:
      return "gradient_error";
    case Measure::ConditionNumber:
      return "condition_number";
    case Measure::MinDihedralDeg:
      return "min_dihedral_deg";
    case Measure::MaxDihedralDeg:
      return "max_dihedral_deg";
    case Measure::RadiusEdge:
      return "radius_edge";
  }
  return "";
}

double regular_tet_value(Measure m) {
  switch (m) {
    case Measure::VOverRmc3:
      return 8.0 / (9.0 * std::sqrt(3.0));
    case Measure::GradientError:
      return std::pow(2.0, 0.75) / std::pow(3.0, 17.0 / 8.0);
    case Measure::ConditionNumber:
      return std::pow(2.0, 1.5) / std::pow(3.0, 1.75);
    case Measure::MinDihedralDeg:
    case Measure::MaxDihedralDeg:
      return std::acos(1.0 / 3.0) * kRadToDeg;
    case Measure::RadiusEdge:
      return std::sqrt(6.0) / 4.0;
  }
  return 1;
}

std::array<double, 2> table1_bin_edges(Measure m) {
  switch (m) {
    case Measure::VOverRmc3:
      return {0.01, 0.4};
    case Measure::GradientError:
      return {0.05, 0.15};
    case Measure::ConditionNumber:
      return {0.1, 0.4};
    default:
      return {0, 0};
  }
}

double min_containing_ball_radius(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  // The smallest ball containing the points is the circumball of 2, 3 or 4 of them, and any
  // other containing candidate is larger: take the smallest candidate that contains all four.
  const Vec3 p[4] = {a, b, c, d};
  Ball candidates[11];
  int n = 0;
  for (const auto& e : kEdge) candidates[n++] = segment_ball(p[e[0]], p[e[1]]);
  for (int i = 0; i < 4; ++i)
    candidates[n++] = triangle_ball(p[(i + 1) % 4], p[(i + 2) % 4], p[(i + 3) % 4]);
  candidates[n++] = tet_ball(a, b, c, d);
  double best = kInf, longest2 = 0;
  for (const auto& e : kEdge) longest2 = std::max(longest2, squared_distance(p[e[0]], p[e[1]]));
  const double slack = 1e-10 * longest2;  // rounding in the centre of an exact support ball
  for (const Ball& ball : candidates) {
    if (!std::isfinite(ball.r2) || ball.r2 >= best) continue;
    bool contains = true;
    for (const Vec3& q : p)
      contains = contains && squared_distance(q, ball.center) <= ball.r2 + slack;
    if (contains) best = ball.r2;
  }
  return std::isfinite(best) ? std::sqrt(best) : std::sqrt(longest2);
}

double circumradius(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return std::sqrt(tet_ball(a, b, c, d).r2);
}

std::array<double, 6> dihedral_angles_deg(const Vec3& a, const Vec3& b, const Vec3& c,
                                          const Vec3& d) {
  return tet_figures(a, b, c, d).dihedral;
}

double tet_measure(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, Measure m) {
  return measure_of(tet_figures(a, b, c, d), m);
}

std::array<std::vector<double>, kMeasureCount> tet_measures(const TetMesh& mesh) {
  std::array<std::vector<double>, kMeasureCount> out;
  for (auto& values : out) resize_large(values, mesh.tets.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.tets.size(), 4096), [&](const auto& r) {
    for (std::size_t t = r.begin(); t != r.end(); ++t) {
      const Tet& tet = mesh.tets[t];
      const TetFigures f = tet_figures(vtx(mesh, tet[0]), vtx(mesh, tet[1]), vtx(mesh, tet[2]),
                                       vtx(mesh, tet[3]), false);
      for (int k = 0; k < kMeasureCount; ++k) out[std::size_t(k)][t] = measure_of(f, Measure(k));
    }
  });
  return out;
}

QualityReport compute_quality(const TetMesh& mesh, const QualityOptions& options) {
  QualityReport rep;
  rep.tets = mesh.tets.size();
  rep.vertices = mesh.vertices.size();
  rep.validity = check_validity(mesh);  // also checks the vertex references

  const std::size_t n = mesh.tets.size();
  std::array<std::vector<double>, 3> q;
  for (auto& v : q) v.resize(n);
  std::vector<double> min_dih(n), max_dih(n), re(n), vol(n);
  const int dih_bins = std::max(1, int(std::lround(180.0 / options.dihedral_bin_deg)));
  const double dih_width = 180.0 / dih_bins;
  tbb::combinable<std::vector<std::size_t>> dih_hist(
      [&] { return std::vector<std::size_t>(std::size_t(dih_bins), 0); });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& r) {
    auto& hist = dih_hist.local();
    for (std::size_t t = r.begin(); t != r.end(); ++t) {
      const Tet& tet = mesh.tets[t];
      const Vec3 &a = mesh.vertices[tet[0]], &b = mesh.vertices[tet[1]], &c = mesh.vertices[tet[2]],
                 &d = mesh.vertices[tet[3]];
      const TetFigures f = tet_figures(a, b, c, d);
      for (int i = 0; i < 3; ++i) q[i][t] = f.shewchuk[i];
      min_dih[t] = f.min_dihedral, max_dih[t] = f.max_dihedral, re[t] = f.radius_edge;
      vol[t] = signed_volume(mesh, tet);
      for (double angle : f.dihedral)
        ++hist[std::size_t(std::clamp(int(angle / dih_width), 0, dih_bins - 1))];
    }
  });

  for (int i = 0; i < 3; ++i) {
    const auto edges = table1_bin_edges(kShewchukMeasures[i]);
    rep.shewchuk[i] = summarise(q[i], &edges, 0.0, regular_tet_value(kShewchukMeasures[i]),
                                options.histogram_bins);
  }
  rep.radius_edge = summarise(re, nullptr, regular_tet_value(Measure::RadiusEdge),
                              options.radius_edge_max, options.histogram_bins);
  for (double v : vol) rep.volume_mm3 += v;  // serial: the same sum whatever the thread count

  DihedralStats& d = rep.dihedral;
  d.bin_deg = dih_width;
  d.histogram.assign(std::size_t(dih_bins), 0);
  dih_hist.combine_each([&](const std::vector<std::size_t>& h) {
    for (std::size_t i = 0; i < h.size(); ++i) d.histogram[i] += h[i];
  });
  if (n) {
    d.min_deg = *std::min_element(min_dih.begin(), min_dih.end());
    d.max_deg = *std::max_element(max_dih.begin(), max_dih.end());
  }
  for (std::size_t t = 0; t < n; ++t) {
    d.below_5 += min_dih[t] < 5, d.below_10 += min_dih[t] < 10, d.below_20 += min_dih[t] < 20;
    d.above_160 += max_dih[t] > 160, d.above_170 += max_dih[t] > 170;
  }
  return rep;
}

nlohmann::json to_json(const QualityReport& rep) {
  nlohmann::json measures = nlohmann::json::object();
  for (int i = 0; i < 3; ++i) {
    const Measure m = kShewchukMeasures[i];
    nlohmann::json j = stats_json(rep.shewchuk[i]);
    j.erase("non_finite");
    j["bins_percent"] = rep.shewchuk[i].bins_percent;
    j["bin_edges"] = table1_bin_edges(m);
    j["regular_tet"] = regular_tet_value(m);  // multiply raw values by 1/this to normalise
    measures[std::string(measure_key(m))] = std::move(j);
  }
  const DihedralStats& d = rep.dihedral;
  const Validity& v = rep.validity;
  const SurfaceTopology& b = v.boundary;
  return {
      {"tets", rep.tets},
      {"vertices", rep.vertices},
      {"volume_mm3", rep.volume_mm3},
      {"measures", measures},
      {"dihedral_deg",
       {{"min", d.min_deg},
        {"max", d.max_deg},
        {"below_5", d.below_5},
        {"below_10", d.below_10},
        {"below_20", d.below_20},
        {"above_160", d.above_160},
        {"above_170", d.above_170},
        {"bin_deg", d.bin_deg},
        {"histogram", d.histogram}}},
      {"radius_edge", stats_json(rep.radius_edge)},
      {"validity",
       {{"inverted", v.inverted},
        {"zero_volume", v.zero_volume},
        {"unreferenced_vertices", v.unreferenced_vertices},
        {"faces_shared_by_more_than_two", v.faces_shared_by_more_than_two},
        {"overlapping_faces", v.overlapping_faces},
        {"boundary_triangles", b.triangles},
        {"boundary_edges", b.edges},
        {"boundary_vertices", b.vertices},
        {"non_manifold_edges", b.non_manifold_edges},
        {"misoriented_edges", b.misoriented_edges},
        {"non_manifold_vertices", b.non_manifold_vertices},
        {"boundary_closed_manifold", b.closed_manifold},
        {"euler_characteristic", b.euler_characteristic},
        {"boundary_components", b.components},
        {"valid", v.valid}}},
  };
}

}  // namespace cvt
