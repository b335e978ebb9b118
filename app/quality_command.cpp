// `cvtmesh quality MESH [--image IMAGE [--labels ...]] [--json]`: Table I, dihedral angles,
// validity, and with an image the fidelity to its segmentation. Judges any tool's mesh. The
// segmentation is cleaned up as `cvtmesh mesh` would with the same selection and clean-up
// options (or --preset), so its fidelity figures are the ones in that run's report.
#include <cstdio>
#include <functional>
#include <iostream>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "base/errors.h"
#include "evaluate/fidelity.h"
#include "io/image_io.h"
#include "io/mesh_io.h"
#include "parameter_options.h"
#include "pipeline/pipeline.h"
#include "pipeline/preset.h"
#include "evaluate/quality.h"

namespace cvt::cli {
namespace {

struct QualityArgs {
  std::string mesh, image;
  // The object and its clean-up, named, defaulted and resolved as in `cvtmesh mesh`.
  std::unique_ptr<ParameterOptions> object;
  bool json = false;
};

void print_text(const QualityReport& q, const FidelityReport* f) {
  std::printf("tets %zu, vertices %zu, volume %.3f mm^3\n", q.tets, q.vertices, q.volume_mm3);
  std::printf("%-18s %10s %12s %10s   min      mean\n", "measure (raw)", "bad %", "middle %", "good %");
  for (std::size_t i = 0; i < kShewchukMeasures.size(); ++i) {
    const MeasureStats& s = q.shewchuk[i];
    std::printf("%-18s %10.2f %12.2f %10.2f   %.4f   %.4f\n",
                std::string(measure_key(kShewchukMeasures[i])).c_str(), s.bins_percent[0],
                s.bins_percent[1], s.bins_percent[2], s.min, s.mean);
  }
  const DihedralStats& d = q.dihedral;
  std::printf("dihedral: min %.2f deg, max %.2f deg; tets with min < 5/10/20 deg: %zu/%zu/%zu\n",
              d.min_deg, d.max_deg, d.below_5, d.below_10, d.below_20);
  std::printf("radius-edge: min %.3f mean %.3f max %.3f\n", q.radius_edge.min, q.radius_edge.mean,
              q.radius_edge.max);
  const Validity& v = q.validity;
  std::printf("validity: %s (inverted %zu, zero volume %zu, unreferenced vertices %zu, "
              "boundary %s, Euler %lld, components %zu)\n",
              v.valid ? "valid" : "NOT VALID", v.inverted, v.zero_volume, v.unreferenced_vertices,
              v.boundary.closed_manifold ? "closed 2-manifold" : "NOT a closed 2-manifold",
              v.boundary.euler_characteristic, v.boundary.components);
  if (f)
    std::printf("fidelity: volume error %.3f %%, Hausdorff %.3f mm, mean %.3f mm, p95 %.3f mm\n",
                f->volume_error_percent, f->distance.hausdorff_mm, f->distance.mean_mm,
                f->distance.p95_mm);
}

void run(const QualityArgs& args) {
  const TetMesh mesh = read_mesh(args.mesh);
  const QualityReport q = compute_quality(mesh);
  std::unique_ptr<FidelityReport> f;
  if (!args.image.empty()) {
    const Parameters parameters = args.object->resolve();
    const PreprocessOptions pre = preprocess_options(parameters);
    const Mask object = [&] {  // the image is freed once its object is taken
      const Image image = read_image(args.image, image_read_options(parameters));
      print_image_warnings(image);
      return fidelity_object(image, pre.selection, pre.cleanup);
    }();
    f = std::make_unique<FidelityReport>(compute_fidelity(mesh, object));
  }
  if (args.json) {
    nlohmann::json j = to_json(q);
    if (f) j["fidelity"] = to_json(*f);
    std::cout << j.dump(2) << "\n";
  } else {
    print_text(q, f.get());
  }
}

}  // namespace

void add_quality_command(CLI::App& app) {
  auto args = std::make_shared<QualityArgs>();
  CLI::App* cmd = app.add_subcommand("quality", "Quality, validity and fidelity of a .mesh/.vtu");
  cmd->add_option("MESH", args->mesh, "Tet mesh (.mesh or .vtu)")->required();
  cmd->add_option("--image", args->image, "Segmentation to measure fidelity against");
  args->object = std::make_unique<ParameterOptions>(cmd, ParameterOptions::Scope::object);
  cmd->add_flag("--json", args->json, "Print JSON");
  cmd->callback([args] { run(*args); });
}

}  // namespace cvt::cli
