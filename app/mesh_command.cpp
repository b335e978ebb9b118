// `cvtmesh mesh IMAGE -o OUT ...`: the whole pipeline, a progress line per stage on stderr,
// the mesh in the format of OUT's extension, optionally a JSON run report and the preset used.
#include <fcntl.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "base/errors.h"
#include "base/threads.h"
#include "commands.h"
#include "io/image_io.h"
#include "io/mesh_export.h"
#include "io/mesh_io.h"
#include "parameter_options.h"
#include "pipeline/pipeline.h"
#include "pipeline/preset.h"
#include "pipeline/run_report.h"
#include "signal_cancel.h"

namespace cvt::cli {
namespace {

struct MeshArgs {
  std::string image, output, report, save_preset;
  bool quiet = false;
  bool evaluate = false;
  std::unique_ptr<ParameterOptions> parameters;
};

// Fails early, before any work, when an output cannot be written: no folder, a folder in the
// way, or a folder that refuses new files (probed with an empty temp file, removed at once).
void ensure_writable_path(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw InputError("cannot write " + path + ": " +
                     (fs::exists(dir, ec) ? dir.string() + " is not a folder"
                                          : "folder " + dir.string() + " does not exist"));
  if (fs::is_directory(target, ec)) throw InputError("cannot write " + path + ": is a folder");
  const fs::path probe =
      dir / ("." + target.filename().string() + ".probe" + std::to_string(::getpid()));
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0)
    throw InputError("cannot write " + path + ": cannot create files in folder " + dir.string() +
                     " (" + std::strerror(errno) + ")");
  ::close(fd);
  ::unlink(probe.c_str());
}

// The mesh output also needs a known extension.
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
  if (ext == ".node" || ext == ".ele") {  // TetGen: both files are written
    ensure_writable_path(fs::path(path).replace_extension(".node").string());
    ensure_writable_path(fs::path(path).replace_extension(".ele").string());
  } else {
    ensure_writable_path(path);
  }
}

// The files a mesh output consists of (TetGen writes two).
std::vector<std::string> mesh_files(const std::string& path) {
  namespace fs = std::filesystem;
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".node" && ext != ".ele") return {path};
  return {fs::path(path).replace_extension(".node").string(),
          fs::path(path).replace_extension(".ele").string()};
}

void run(const MeshArgs& args) {
  Progress progress;
  progress.cancel = install_interrupt_cancel();
  const Parameters parameters = args.parameters->resolve();
  // Check the outputs before hours of work: the extension and the folders.
  ensure_writable_mesh_path(args.output);
  if (!args.report.empty()) ensure_writable_path(args.report);
  if (!args.save_preset.empty()) ensure_writable_path(args.save_preset);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            resolve_threads(parameters.threads));

  std::string last_step;
  if (!args.quiet)
    progress.report = [&](const std::string& step, double) {
      if (step != last_step) std::cerr << "cvtmesh: " << step << "\n";
      last_step = step;
    };
  Pipeline pipe;
  pipe.set_parameters(parameters);
  pipe.set_evaluate_fidelity(args.evaluate);
  auto image = std::make_shared<Image>(read_image(args.image, image_read_options(parameters)));
  print_image_warnings(*image);
  const nlohmann::json image_summary = image_json(*image);  // the pipeline frees the image
  pipe.set_image(std::move(image), Pipeline::Run::once);
  pipe.run_all(progress);

  const TetMesh& mesh = *pipe.final_mesh();
  // All outputs or none: a report or preset that fails after the mesh was written takes the
  // mesh with it, so a failed run never looks like a finished one; so does a cancel during
  // the last stage or the writing.
  const WritingOutputs writing;
  progress.check_cancelled();
  std::vector<std::string> written;
  try {
    write_mesh_with_quality(mesh, args.output);
    written = mesh_files(args.output);
    if (!args.report.empty()) {
      nlohmann::json report = run_report(pipe);
      report["image"] = image_summary;
      write_file_atomically(args.report, report.dump(2) + "\n");
      written.push_back(args.report);
    }
    if (!args.save_preset.empty()) {
      save_preset(parameters, args.save_preset);
      written.push_back(args.save_preset);
    }
    progress.check_cancelled();
  } catch (...) {
    std::error_code ec;
    for (const std::string& f : written) std::filesystem::remove(f, ec);
    throw;
  }
  if (!args.quiet) {
    double total = 0;
    for (const StageRecord& r : pipe.records()) total += r.wall_s;
    std::fprintf(stderr,
                 "cvtmesh: %zu vertices, %zu tets -> %s (%.2f s, peak %.0f MB, %s)\n",
                 mesh.vertices.size(), mesh.tets.size(), args.output.c_str(), total,
                 pipe.records().back().peak_rss_mb,
                 pipe.quality()->validity.valid ? "valid" : "NOT VALID");
    const CleanupReport& c = pipe.preprocess()->cleanup;
    if (c.components_removed + c.cavities_filled + c.cavities_kept > 0)
      std::fprintf(stderr,
                   "cvtmesh: clean-up: %d specks dropped (%zu voxels), %d cavities filled "
                   "(%zu voxels), %d too large to fill kept (%zu voxels)\n",
                   c.components_removed, c.voxels_removed, c.cavities_filled, c.voxels_filled,
                   c.cavities_kept, c.voxels_kept);
    if (const FidelityReport* f = pipe.fidelity())
      std::fprintf(stderr,
                   "cvtmesh: fidelity: Hausdorff %.2f mm, mean %.3f mm, 95th percentile %.2f mm, "
                   "volume error %+.2f %%\n",
                   f->distance.hausdorff_mm, f->distance.mean_mm, f->distance.p95_mm,
                   f->volume_error_percent);
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
  cmd->add_flag("--evaluate", args->evaluate,
                "Also measure the mesh's fidelity to the segmentation (distances, volume error) "
                "for the summary and the report; costs about as much as a stage");
  args->parameters = std::make_unique<ParameterOptions>(cmd);
  cmd->callback([args] { run(*args); });
}

}  // namespace cvt::cli
