// `cvtmesh mesh IMAGE -o OUT ...`: the whole pipeline, a progress line per stage on stderr,
// the mesh in the format of OUT's extension, optionally a JSON run report and the preset used.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include "commands.h"
#include "errors.h"
#include "image_io.h"
#include "mesh_io.h"
#include "parameter_options.h"
#include "pipeline.h"
#include "preset.h"
#include "run_report.h"
#include "signal_cancel.h"

namespace cvt::cli {
namespace {

struct MeshArgs {
  std::string image, output, report, save_preset;
  bool quiet = false;
  std::unique_ptr<ParameterOptions> parameters;
};

// Fails early, before any work, when OUT cannot be written: unknown extension or no folder.
void ensure_writable_mesh_path(const std::string& path) {
  namespace fs = std::filesystem;
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  const auto& known = mesh_write_extensions();
  if (std::find(known.begin(), known.end(), ext) == known.end()) {
    std::string list;
    for (const std::string& e : known) list += (list.empty() ? "" : " ") + e;
    throw InputError(path + ": unsupported mesh format '" + ext + "' (supported: " + list + ")");
  }
  const fs::path dir = fs::path(path).parent_path();
  if (!dir.empty() && !fs::is_directory(dir))
    throw InputError("cannot write " + path + ": folder " + dir.string() + " does not exist");
}

// Quality measures as cell data, so a .vtu can be coloured by them in ParaView.
MeshWriteOptions write_options(const TetMesh& mesh) {
  MeshWriteOptions o;
  for (Measure m : {Measure::VOverRmc3, Measure::GradientError, Measure::ConditionNumber,
                    Measure::MinDihedralDeg})
    o.cell_data.push_back({std::string(measure_key(m)), tet_measure(mesh, m)});
  return o;
}

void run(const MeshArgs& args) {
  const Parameters parameters = args.parameters->resolve();
  // Check the output path before hours of work: the extension and the folder.
  ensure_writable_mesh_path(args.output);
  const int threads = parameters.threads > 0 ? parameters.threads : tbb::info::default_concurrency();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);

  Progress progress;
  progress.cancel = install_interrupt_cancel();
  std::string last_step;
  if (!args.quiet)
    progress.report = [&](const std::string& step, double) {
      if (step != last_step) std::cerr << "cvtmesh: " << step << "\n";
      last_step = step;
    };
  Pipeline pipe;
  pipe.set_parameters(parameters);
  pipe.set_image(std::make_shared<Image>(read_image(args.image)));
  pipe.run_all(progress);

  const MeshGenerationResult& m = *pipe.mesh();
  write_mesh(m.mesh, args.output, write_options(m.mesh));
  if (!args.report.empty()) write_file_atomically(args.report, run_report(pipe).dump(2) + "\n");
  if (!args.save_preset.empty()) save_preset(parameters, args.save_preset);
  if (!args.quiet) {
    double total = 0;
    for (const StageRecord& r : pipe.records()) total += r.wall_s;
    std::fprintf(stderr,
                 "cvtmesh: %zu vertices, %zu tets -> %s (%.2f s, peak %.0f MB, %s)\n",
                 m.mesh.vertices.size(), m.mesh.tets.size(), args.output.c_str(), total,
                 pipe.records().back().peak_rss_mb,
                 pipe.quality()->validity.valid ? "valid" : "NOT VALID");
  }
}

}  // namespace

void add_mesh_command(CLI::App& app) {
  auto args = std::make_shared<MeshArgs>();
  CLI::App* cmd = app.add_subcommand("mesh", "Mesh the object of an image (the whole pipeline)");
  cmd->add_option("IMAGE", args->image, "Image file or DICOM/slice folder")->required();
  cmd->add_option("-o,--output", args->output,
                  "Output mesh: .mesh .vtu .msh .inp .feb .node .stl .ply .obj")
      ->required();
  cmd->add_option("--report", args->report, "Write a JSON run report here");
  cmd->add_option("--save-preset", args->save_preset, "Write the parameters used as a preset");
  cmd->add_flag("-q,--quiet", args->quiet, "No progress on stderr");
  args->parameters = std::make_unique<ParameterOptions>(cmd);
  cmd->callback([args] { run(*args); });
}

}  // namespace cvt::cli
