#include "io/mesh_export.h"

#include <tbb/parallel_for.h>

#include "evaluate/quality.h"
#include "io/mesh_io.h"

namespace cvt {

void write_mesh_with_quality(const TetMesh& mesh, const std::string& path) {
  MeshWriteOptions options;
  if (mesh_format_has_cell_data(path)) {  // the other formats would drop them
    const Measure measures[] = {Measure::VOverRmc3, Measure::GradientError,
                                Measure::ConditionNumber, Measure::MinDihedralDeg};
    for (Measure m : measures)
      options.cell_data.push_back({std::string(measure_key(m)), std::vector<double>(mesh.tets.size())});
    tbb::parallel_for(std::size_t(0), mesh.tets.size(), [&](std::size_t t) {
      const Tet& tet = mesh.tets[t];
      for (std::int32_t v : tet)  // write_mesh names the bad reference
        if (v < 0 || std::size_t(v) >= mesh.vertices.size()) return;
      const TetFigures f = tet_figures(mesh.vertices[tet[0]], mesh.vertices[tet[1]],
                                       mesh.vertices[tet[2]], mesh.vertices[tet[3]]);
      for (std::size_t k = 0; k < 4; ++k) options.cell_data[k].second[t] = measure_of(f, measures[k]);
    });
  }
  write_mesh(mesh, path, options);
}

}  // namespace cvt
