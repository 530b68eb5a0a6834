// polyfit: fit meshes in batches, and compare meshes.
//
//   polyfit fit INPUT... --out DIR [--patches K|auto] [--order N] [--refine]
//   mpirun -n N polyfit fit ...     (built with MPI: the inputs shared by N ranks)
//   polyfit eval A B [--samples N]
//   polyfit remesh IN OUT (--decimate F | --subdivide N [--loop])
//
// Every default lives in the library's options; this file only maps flags
// onto them and makes one library call per command.
#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "polyfit/eval/mesh_metrics.h"
#include "polyfit/eval/surface_distance.h"
#include "polyfit/mesh/decimation.h"
#include "polyfit/mesh/mesh_io.h"
#include "polyfit/mesh/subdivision.h"
#include "polyfit/pipeline/batch_fit.h"
#include "polyfit/util/status.h"
#ifdef POLYFIT_WITH_MPI
#include "polyfit/pipeline/batch_fit_mpi.h"
#include "polyfit/util/mpi_session.h"
#endif

namespace {

// A bar redrawn in place on a terminal; one line per input otherwise (and
// always under MPI, each line naming its rank).
class Progress {
 public:
  Progress() : terminal_(::isatty(STDERR_FILENO) != 0) {}
  explicit Progress(std::string prefix) : terminal_(false), prefix_(std::move(prefix)) {}

  void operator()(int done, int total, const polyfit::BatchFitItemSummary& item) {
    const char* status = item.status == polyfit::BatchItemStatus::kFitted    ? "fitted"
                         : item.status == polyfit::BatchItemStatus::kSkipped ? "skipped (outputs exist)"
                                                                             : "FAILED";
    char line[512];
    if (item.status == polyfit::BatchItemStatus::kFailed) {
      std::snprintf(line, sizeof(line), "[%d/%d] %s: %s", done, total, status, item.error.c_str());
    } else {
      const auto& s = item.summary;
      std::snprintf(line, sizeof(line), "[%d/%d] %s %s: %d faces, %d patches, %.3f s, Chamfer x1e3 %.4f", done, total,
                    status, item.name.c_str(), s.input_faces, s.clustering.num_patches, s.total_time_s,
                    1e3 * s.chamfer);
    }
    if (!terminal_) {
      std::fprintf(stderr, "%s%s\n", prefix_.c_str(), line);
      return;
    }
    // Failures stay on screen; the bar is redrawn below them.
    if (item.status == polyfit::BatchItemStatus::kFailed) std::fprintf(stderr, "\r\033[K%s\n", line);
    const int width = 30, filled = total > 0 ? width * done / total : width;
    std::fprintf(stderr, "\r\033[K[%s%s] %d/%d %s", std::string(filled, '#').c_str(),
                 std::string(width - filled, '.').c_str(), done, total, item.name.c_str());
    if (done == total) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  }

 private:
  bool terminal_;
  std::string prefix_;
};

#ifdef POLYFIT_WITH_MPI
// The batch over the job's ranks (batch_fit_mpi.h); rank 0 reports.
int FitOverMpi(const polyfit::BatchFitOptions& batch, const std::vector<std::string>& inputs, int rank) {
  Progress progress("rank " + std::to_string(rank) + " ");
  const polyfit::MpiBatchSummary result = polyfit::FitMeshFilesMpi(
      batch, inputs, MPI_COMM_WORLD,
      [&progress](int done, int total, const polyfit::BatchFitItemSummary& item) { progress(done, total, item); });
  const polyfit::BatchFitSummary& summary = result.batch;
  if (rank == 0) {
    std::printf("%d fitted, %d skipped, %d failed in %.2f s on %d ranks x %d threads; report: %s/report.csv\n",
                summary.num_fitted, summary.num_skipped, summary.num_failed, summary.total_time_s, result.num_ranks,
                result.threads_per_rank, batch.output_dir.c_str());
  }
  return summary.num_failed > 0 ? polyfit::kExitPartial : polyfit::kExitSuccess;
}
#endif

// The fit command: over MPI ranks when started by mpirun, else here.
int RunFit(const polyfit::BatchFitOptions& batch, const std::vector<std::string>& inputs) {
#ifdef POLYFIT_WITH_MPI
  if (polyfit::LaunchedByMpi()) {
    polyfit::MpiSession mpi;
    return mpi.Run("polyfit", [&] { return FitOverMpi(batch, inputs, mpi.rank()); });
  }
#endif
  Progress progress;
  const polyfit::BatchFitSummary summary = polyfit::FitMeshFiles(
      batch, inputs,
      [&progress](int done, int total, const polyfit::BatchFitItemSummary& item) { progress(done, total, item); });
  std::printf("%d fitted, %d skipped, %d failed in %.2f s; report: %s/report.csv\n", summary.num_fitted,
              summary.num_skipped, summary.num_failed, summary.total_time_s, batch.output_dir.c_str());
  return summary.num_failed > 0 ? polyfit::kExitPartial : polyfit::kExitSuccess;
}

// The eval command: Chamfer distances between two meshes.
int RunEval(const std::string& mesh_a, const std::string& mesh_b, int samples) {
  const polyfit::TriangleMesh a = polyfit::ReadTriangleMesh(mesh_a);
  const polyfit::TriangleMesh b = polyfit::ReadTriangleMesh(mesh_b);
  const polyfit::ChamferDistance chamfer = polyfit::MeshChamferDistance(a, b, samples, 7);
  const polyfit::ChamferDistance floor = polyfit::MeshChamferDistance(a, a, samples, 7);
  const polyfit::ChamferDistance surface = polyfit::MeshToSurfaceChamferDistance(a, b, samples, 7);
  std::printf(
      "Chamfer x1e3 %.6f (A->B %.6f, B->A %.6f), %d samples each, A's unit-sphere normalisation\n"
      "  sampling floor (A against a second sampling of A) x1e3 %.6f\n"
      "  samples to surface (no floor) x1e3 %.6f (A->B %.6f, B->A %.6f)\n",
      1e3 * chamfer.sum(), 1e3 * chamfer.a_to_b, 1e3 * chamfer.b_to_a, samples, 1e3 * floor.sum(), 1e3 * surface.sum(),
      1e3 * surface.a_to_b, 1e3 * surface.b_to_a);
  return polyfit::kExitSuccess;
}

// The remesh command: the same surface, meshed coarser or finer (a
// resolution-agnostic method's test input). OUT's extension picks the format.
struct EvalFlags {
  std::string mesh_a, mesh_b;
  int samples = 10000;
};

CLI::App* AddEvalCommand(CLI::App* app, EvalFlags* f) {
  CLI::App* eval = app->add_subcommand("eval", "Chamfer distance between two meshes (A's unit-sphere normalisation)");
  eval->add_option("a", f->mesh_a, "Reference mesh")->required();
  eval->add_option("b", f->mesh_b, "Compared mesh")->required();
  eval->add_option("--samples", f->samples, "Uniform surface samples per mesh")->capture_default_str();
  return eval;
}

struct RemeshFlags {
  std::string input, output;
  double decimate = 0.0;
  int subdivide = 0;
  bool loop = false;
};

CLI::App* AddRemeshCommand(CLI::App* app, RemeshFlags* f) {
  CLI::App* remesh = app->add_subcommand("remesh", "The same surface meshed coarser (edge collapse) or finer");
  remesh->add_option("input", f->input, "Mesh file")->required();
  remesh->add_option("output", f->output, "Output mesh (.obj or .ply)")->required();
  CLI::Option* decimate =
      remesh->add_option("--decimate", f->decimate, "Collapse edges until this fraction of them is left, in (0, 1]")
          ->check(CLI::Range(1e-6, 1.0));
  CLI::Option* subdivide = remesh->add_option("--subdivide", f->subdivide, "Subdivision levels (each 4x the faces)")
                               ->check(CLI::Range(1, 4));
  decimate->excludes(subdivide);
  remesh->add_flag("--loop", f->loop, "With --subdivide: Loop's scheme (smooth) rather than midpoints");
  return remesh;
}

int RunRemesh(const RemeshFlags& f) {
  if (f.decimate <= 0.0 && f.subdivide <= 0) {
    std::cerr << "remesh: give --decimate F or --subdivide N\n";
    return polyfit::kExitUsage;
  }
  polyfit::SubdivisionOptions subdivision;
  subdivision.levels = f.subdivide;
  if (f.loop) subdivision.scheme = polyfit::SubdivisionScheme::kLoop;
  const std::string& input = f.input;
  const std::string& output = f.output;
  const double decimate = f.decimate;
  const std::string extension = output.size() >= 4 ? output.substr(output.size() - 4) : "";
  if (extension != ".obj" && extension != ".ply") {
    std::cerr << output << ": expected a .obj or .ply file name\n";
    return polyfit::kExitUsage;
  }
  const polyfit::TriangleMesh mesh = polyfit::ReadTriangleMesh(input);
  polyfit::TriangleMesh remeshed;
  try {
    remeshed = decimate > 0.0 ? polyfit::DecimateMesh(mesh, decimate) : polyfit::SubdivideMesh(mesh, subdivision);
  } catch (const std::invalid_argument& e) {
    std::cerr << input << ": " << e.what() << "\n";
    return polyfit::kExitInputError;
  }
  if (extension == ".obj") {
    polyfit::WriteObj(output, remeshed);
  } else {
    polyfit::WritePly(output, remeshed);
  }
  std::printf("%s: %d vertices, %d faces -> %s: %d vertices, %d faces\n", input.c_str(), mesh.num_vertices(),
              mesh.num_faces(), output.c_str(), remeshed.num_vertices(), remeshed.num_faces());
  return polyfit::kExitSuccess;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"PolyFit: patch-wise polynomial jets for meshes"};
  app.require_subcommand(1);

  polyfit::BatchFitOptions batch;
  std::vector<std::string> inputs;
  std::string patches = "auto", subdivision = "midpoint", seam = "average";
  CLI::App* fit = app.add_subcommand("fit", "Fit meshes: a model, a reconstruction and a report per input");
  fit->add_option("inputs", inputs, "Mesh files, directories or glob patterns")->required();
  fit->add_option("--out", batch.output_dir, "Output directory")->required();
  fit->add_option("--patches", patches, "Patch count K, or 'auto' (from the surface area)")->capture_default_str();
  fit->add_option("--area-per-patch", batch.fit.clustering.auto_area_per_patch,
                  "With --patches auto: surface area per patch, in the mesh's units squared")
      ->capture_default_str();
  fit->add_option("--normal-weight", batch.fit.clustering.normal_weight,
                  "Weight of face normals in the clustering (keeps sharp creases between patches)")
      ->capture_default_str();
  fit->add_option("--order", batch.fit.jet_fit.order, "Jet order n (1 to 8)")->capture_default_str();
  fit->add_flag("--refine", batch.fit.jet_fit.refine_orientation, "Refine each patch's orientation");
  fit->add_option("--min-vertices-per-patch", batch.fit.min_vertices_per_patch,
                  "Subdivide coarse meshes up to this many vertices per patch (0: never)")
      ->capture_default_str();
  fit->add_option("--subdivision", subdivision, "Subdivision scheme: midpoint or loop")
      ->check(CLI::IsMember({"midpoint", "loop"}))
      ->capture_default_str();
  fit->add_option("--seam", seam, "Seam reconciliation: owner or average")
      ->check(CLI::IsMember({"owner", "average"}))
      ->capture_default_str();
  fit->add_option("--smooth-boundary", batch.fit.reconstruction.boundary_smoothing_iterations,
                  "Laplacian smoothing iterations along patch boundaries")
      ->capture_default_str();
  fit->add_option("--samples", batch.fit.evaluation_samples, "Surface samples for the Chamfer distance")
      ->capture_default_str();
  bool no_eval = false;
  fit->add_flag("--no-eval", no_eval, "Skip scoring the reconstruction");
  fit->add_flag("--force", batch.force, "Refit inputs whose outputs exist");
  fit->add_option("--threads", batch.num_threads, "Threads (0: all)")->capture_default_str();

  EvalFlags eval_flags;
  CLI::App* eval = AddEvalCommand(&app, &eval_flags);

  RemeshFlags remesh_flags;
  CLI::App* remesh = AddRemeshCommand(&app, &remesh_flags);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? polyfit::kExitSuccess : polyfit::kExitUsage;
  }

  return polyfit::RunReportingErrors("polyfit", [&]() -> int {
    if (fit->parsed()) {
      if (patches == "auto") {
        batch.fit.clustering.num_patches = 0;
      } else {
        try {
          batch.fit.clustering.num_patches = std::stoi(patches);
        } catch (const std::exception&) {
          std::cerr << "--patches: expected a number or 'auto', got '" << patches << "'\n";
          return polyfit::kExitUsage;
        }
        if (batch.fit.clustering.num_patches < 1) {
          std::cerr << "--patches: must be at least 1\n";
          return polyfit::kExitUsage;
        }
      }
      batch.fit.subdivision_scheme =
          subdivision == "loop" ? polyfit::SubdivisionScheme::kLoop : polyfit::SubdivisionScheme::kMidpoint;
      batch.fit.reconstruction.seam_mode = seam == "owner" ? polyfit::SeamMode::kOwner : polyfit::SeamMode::kAverage;
      batch.fit.evaluate = !no_eval;
      return RunFit(batch, inputs);
    }
    if (eval->parsed()) {
      return RunEval(eval_flags.mesh_a, eval_flags.mesh_b, eval_flags.samples);
    }
    if (remesh->parsed()) return RunRemesh(remesh_flags);
    return polyfit::kExitSuccess;
  });
}
