#include "io/mesh_export.h"

#include "evaluate/quality.h"
#include "io/mesh_io.h"

namespace cvt {

void write_mesh_with_quality(const TetMesh& mesh, const std::string& path) {
  MeshWriteOptions options;
  for (Measure m : {Measure::VOverRmc3, Measure::GradientError, Measure::ConditionNumber,
                    Measure::MinDihedralDeg})
    options.cell_data.push_back({std::string(measure_key(m)), tet_measure(mesh, m)});
  write_mesh(mesh, path, options);
}

}  // namespace cvt
