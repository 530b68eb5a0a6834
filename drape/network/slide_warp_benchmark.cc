// How much of the reference drape's per-vertex slides a per-patch warp of
// order m (what a warp head predicts, DrapeSlideOptions::warp_order) can
// hold. The reference drape runs through a clip's first frames (slides
// free); every fifth frame its energy (DrapeSolver::Evaluate, same history
// and collisions) is measured three ways at its own patch parameters: with
// its slides (the solve's final cost), with the slides replaced by their
// least-squares fit by each patch's warp (DrapeSolver::PatchParameters),
// and with every slide zero (what a network without a warp head gives).
// An upper bound on what the warp leaves: the patch parameters are not
// re-optimised for it.
//
//   slide_warp_benchmark [DATA_DIR [GARMENT]]   (DATA_DIR: ../shared/data/drape)
#include <cstdio>
#include <filesystem>

#include "drape/network/benchmark_walk.h"
#include "drape/simulate/drape_solver.h"
#include "polyfit/jet/jet_basis.h"

int main(int argc, char** argv) {
  using namespace polyfit;
  const std::optional<BenchmarkWalk> loaded = LoadBenchmarkWalk(argc, argv);
  if (!loaded) return 1;
  const std::string& garment = loaded->garment_path;
  const SkinnedBody& body = loaded->walk.body;
  const TriangleMesh& mesh = loaded->walk.garment;
  const SkinWeights& weights = loaded->walk.weights;
  const auto& clip = loaded->walk.clip;
  const int lead_in = 10, frames = 30;
  std::printf("%s, walk frames 0-%d (every fifth), mean energy J\n\n", garment.c_str(), frames - 1);
  std::printf(
      "| warp order | coefficients per patch | reference (its slides) | slides fitted by the warp | slides zero |\n");
  std::printf("|---:|---:|---:|---:|---:|\n");
  for (const int order : {0, 1, 2, 3, 4}) {
    DrapeSolverOptions options;
    options.slide.warp_order = order;
    DrapeSolver solver(body, mesh, weights, options);
    const int coefficients = NumJetCoefficients(4), stride = solver.num_patch_parameters();
    for (int k = 0; k < lead_in; ++k) solver.Step(clip->Pose(0, (k + 1.0) / (lead_in + 1.0)), k);
    Eigen::Matrix3Xd previous = solver.positions(), before_previous = previous;
    double with_slides = 0.0, fitted = 0.0, zero = 0.0;
    int measured = 0;
    for (int f = 0; f < frames; ++f) {
      const double cost = solver.Step(clip->Pose(f), lead_in + f).final_cost;
      const Eigen::Matrix3Xd now = solver.positions();
      if (f % 5 == 4) {
        std::vector<double> params = solver.PatchParameters();
        // Evaluate with the history this frame was solved with.
        solver.SetHistory(previous, before_previous);
        solver.Pose(clip->Pose(f), lead_in + f);
        fitted += solver.Evaluate(params, nullptr);
        for (int p = 0; p < solver.num_patches(); ++p) {
          std::fill(params.begin() + p * stride + coefficients + 4, params.begin() + (p + 1) * stride, 0.0);
        }
        zero += solver.Evaluate(params, nullptr);
        with_slides += cost;
        ++measured;
        solver.SetHistory(now, previous);
      }
      before_previous = previous;
      previous = now;
    }
    std::printf("| %d | %d | %.0f | %.0f | %.0f |\n", order, 2 * NumJetCoefficients(order), with_slides / measured,
                fitted / measured, zero / measured);
  }
  return 0;
}
