// The best any network could do: the drape solved in the network's output
// space. Per frame, the patch parameters a network predicts (jet, scale,
// centre, and with a warp head of order m each patch's in-plane warp) are
// optimised directly, by L-BFGS on the training loss (DrapeSolver::Evaluate,
// the same terms, weights, collisions and inertia from its own previous
// frames), starting from the frame before. A network trained on that loss
// cannot beat this drape on its metrics, so the gap between this and the
// reference drape (per-vertex slides, LM) is the output space's, and the gap
// between this and a trained network is the training's.
//
//   output_space_benchmark [DATA_DIR [GARMENT [FRAMES [AREA:WARP:ITERATIONS[:KC[:EPS[:FLOOR[:KB[:SF]]]]],...
//                          [MODEL [reference|network|swap|continuation [KC_LOW]]]]]]]
//   (DATA_DIR: ../shared/data/drape; WARP -1: no warp head; KC, EPS, FLOOR,
//   KB: the collision weight, margin and margin floor and the patch
//   boundary weight, the drape's defaults if not given; the default
//   configurations are the table of docs/benchmarks.md. MODEL: a .pfonefit
//   whose skinning and patching (frames, fit error, curved faces, jet
//   order) the garment takes, as `onefit drape` gives it; AREA and WARP
//   still come from the list.)
//   With `reference` after MODEL, per configuration: the reference drape on
//   that loss, its slides replaced by each patch's warp fitted to them (a
//   point of the network's output space), and ITERATIONS of L-BFGS from
//   there each frame: whether the output space holds a better drape than
//   the frame-to-frame solve finds. With `network`: MODEL's prediction per
//   frame and ITERATIONS of L-BFGS from it (KC, EPS, FLOOR, KB as it was
//   trained with; AREA and WARP its own), then MODEL's prediction with its
//   warps re-solved per patch (DrapeSolver::SolveWarps), and with its
//   warps and translations. `reference` and `network` also
//   split each drape's strain between the edges within a patch (both
//   vertices owned by it) and those across a seam. With `swap`: the reference drape's
//   fitted warps F and MODEL's prediction N per frame, and N with each
//   block of F's patch parameters swapped in (SwappedBlocks). With
//   `continuation`: the frame-to-frame solve at the collision weight KC_LOW
//   (default 1), and from each of its frames ITERATIONS more at KC
//   (Continuation): whether a drape settled under the gentle weight keeps
//   its strain when the weight rises, as a curriculum would ask of training.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <ceres/ceres.h>
#include <glog/logging.h>

#include "drape/eval/cloth_energy.h"
#include "drape/network/benchmark_walk.h"
#include "drape/network/onefit_draper.h"
#include "drape/network/onefit_model.h"
#include "drape/simulate/drape_solver.h"
#include "polyfit/jet/jet_basis.h"

namespace {

using polyfit::DrapeSolver;

// The loss of one frame as a function of the flat patch parameters; with
// `free_begin` > 0 only each patch's parameters from there on move (their
// gradient alone is kept, so L-BFGS leaves the others where they are).
class FrameLoss : public ceres::FirstOrderFunction {
 public:
  explicit FrameLoss(DrapeSolver* solver, int free_begin = 0) : solver_(solver), free_begin_(free_begin) {}
  bool Evaluate(const double* parameters, double* cost, double* gradient) const override {
    const int n = NumParameters();
    const std::vector<double> x(parameters, parameters + n);
    *cost = solver_->Evaluate(x, gradient ? &gradient_ : nullptr);
    if (gradient) {
      const int stride = solver_->num_patch_parameters();
      for (int i = 0; i < n; ++i) gradient[i] = i % stride >= free_begin_ ? gradient_[i] : 0.0;
    }
    return std::isfinite(*cost);
  }
  int NumParameters() const override { return solver_->num_patches() * solver_->num_patch_parameters(); }

 private:
  DrapeSolver* solver_;
  int free_begin_;
  mutable std::vector<double> gradient_;
};

struct Row {
  double energy = 0.0, inside = 0.0, strain = 0.0, iterations = 0.0;
  // The strain (%) of the edges whose two vertices belong to one patch
  // (their owners), and of those across a patch seam.
  double within = 0.0, seam = 0.0;
};

double PercentNegative(const Eigen::VectorXd& d) { return 100.0 * (d.array() < 0.0).count() / d.size(); }

constexpr int kLeadIn = 10;
// DrapeSolver::SolveWarps' sweeps in the `network` mode.
constexpr int kWarpSolveSweeps = 5;

std::vector<Eigen::Isometry3d> LeadInOrFrame(const polyfit::MotionRetargeter& clip, int k) {
  return k < kLeadIn ? clip.Pose(0, (k + 1.0) / (kLeadIn + 1.0)) : clip.Pose(k - kLeadIn);
}

ceres::GradientProblemSolver::Options LbfgsOptions(int iterations) {
  ceres::GradientProblemSolver::Options options;
  options.max_num_iterations = iterations;
  options.line_search_direction_type = ceres::LBFGS;
  options.max_num_line_search_step_size_iterations = 40;
  options.function_tolerance = 1e-10;
  options.gradient_tolerance = 1e-12;
  return options;
}

// Adds a frame's measures (inside %, strain %, its split by edge class)
// of positions x to row.
void Measure(const DrapeSolver& solver, const polyfit::ClothRest& rest, const Eigen::Matrix3Xd& x, int frames,
             Row* row) {
  row->inside += PercentNegative(solver.SignedDistances(x)) / frames;
  double sum[2] = {0.0, 0.0};
  int count[2] = {0, 0};
  for (size_t e = 0; e < rest.edges.size(); ++e) {
    const int seam = solver.model().owner(rest.edges[e][0]) != solver.model().owner(rest.edges[e][1]) ? 1 : 0;
    sum[seam] += polyfit::EdgeStrain(rest, x, e);
    ++count[seam];
  }
  row->strain += 100.0 * (sum[0] + sum[1]) / std::max(count[0] + count[1], 1) / frames;
  row->within += 100.0 * sum[0] / std::max(count[0], 1) / frames;
  row->seam += 100.0 * sum[1] / std::max(count[1], 1) / frames;
}

// L-BFGS on the posed solver's loss from params (moved in place); the
// result's loss, iterations and measures added to row.
void SolveAndMeasure(const ceres::GradientProblemSolver::Options& options, DrapeSolver* solver,
                     const polyfit::ClothRest& rest, int frames, std::vector<double>* params, Row* row,
                     int free_begin = 0) {
  ceres::GradientProblem problem(new FrameLoss(solver, free_begin));
  ceres::GradientProblemSolver::Summary summary;
  ceres::Solve(options, problem, params->data(), &summary);
  row->energy += summary.final_cost / frames;
  row->iterations += static_cast<double>(summary.iterations.size()) / frames;
  Measure(*solver, rest, solver->PositionsOf(*params), frames, row);
}

// One frame of the frame-to-frame solve: the solver posed at k with the
// chain's history, L-BFGS from params (moved in place).
ceres::GradientProblemSolver::Summary ChainStep(DrapeSolver* solver, const std::vector<Eigen::Isometry3d>& pose,
                                                int k, const Eigen::Matrix3Xd& previous,
                                                const Eigen::Matrix3Xd& before_previous,
                                                const ceres::GradientProblemSolver::Options& options,
                                                std::vector<double>* params) {
  solver->SetHistory(previous, before_previous);
  solver->Pose(pose, k);
  ceres::GradientProblem problem(new FrameLoss(solver));
  ceres::GradientProblemSolver::Summary summary;
  ceres::Solve(options, problem, params->data(), &summary);
  return summary;
}

// Lead-in from rest to the first pose, then `frames` frames, each solved
// from the one before with `iterations` L-BFGS iterations.
Row DrapeInOutputSpace(DrapeSolver* solver, const polyfit::MotionRetargeter& clip, int frames, int iterations) {
  std::vector<double> params = solver->RestPatchParameters();
  Eigen::Matrix3Xd previous = solver->PositionsOf(params), before_previous = previous;
  const polyfit::ClothRest rest = polyfit::PrepareClothRest(solver->rest_garment());
  const ceres::GradientProblemSolver::Options options = LbfgsOptions(iterations);
  Row row;
  const int lead_in = kLeadIn;
  for (int k = 0; k < lead_in + frames; ++k) {
    const ceres::GradientProblemSolver::Summary summary =
        ChainStep(solver, LeadInOrFrame(clip, k), k, previous, before_previous, options, &params);
    row.iterations += static_cast<double>(summary.iterations.size()) / (lead_in + frames);
    before_previous = previous;
    previous = solver->PositionsOf(params);
    if (k < lead_in) continue;
    row.energy += summary.final_cost / frames;
    Measure(*solver, rest, previous, frames, &row);
  }
  return row;
}

// The reference drape (Step: LM over the patch parameters and each vertex's
// slide) on the same loss; per frame, its slides replaced by each patch's
// warp fitted to them (PatchParameters: a point of the network's output
// space) and, from there, `iterations` L-BFGS iterations on the loss with
// the reference drape's frames as the history. Rows: the reference drape,
// the fitted warps (energy: the loss there), L-BFGS from them.
std::array<Row, 3> ReferenceAndFittedWarps(DrapeSolver* solver, const polyfit::MotionRetargeter& clip, int frames,
                                           int iterations) {
  const polyfit::ClothRest rest = polyfit::PrepareClothRest(solver->rest_garment());
  const ceres::GradientProblemSolver::Options options = LbfgsOptions(iterations);
  std::array<Row, 3> rows;
  Eigen::Matrix3Xd previous, before_previous;
  for (int k = 0; k < kLeadIn + frames; ++k) {
    const auto pose = LeadInOrFrame(clip, k);
    solver->Step(pose, k);
    const Eigen::Matrix3Xd x = solver->positions();
    if (k >= kLeadIn) {
      std::vector<double> params = solver->PatchParameters();
      // The loss as the reference drape's frame saw it (its history), then
      // the solver's own history back for its next step.
      solver->SetHistory(previous, before_previous);
      solver->Pose(pose, k);
      rows[1].energy += solver->Evaluate(params, nullptr) / frames;
      Measure(*solver, rest, x, frames, &rows[0]);
      Measure(*solver, rest, solver->PositionsOf(params), frames, &rows[1]);
      SolveAndMeasure(options, solver, rest, frames, &params, &rows[2]);
      solver->SetHistory(x, previous);
    }
    before_previous = k > 0 ? previous : x;
    previous = x;
  }
  return rows;
}

// The frame-to-frame solve (as DrapeInOutputSpace) on `gentle`'s loss and,
// from each of its frames, `iterations` L-BFGS iterations on `stiff`'s (the
// same patching and skinning, another collision weight; the gentle chain's
// frames as the history). Rows: the gentle chain, the stiff solves from it.
std::array<Row, 2> Continuation(DrapeSolver* gentle, DrapeSolver* stiff, const polyfit::MotionRetargeter& clip,
                                int frames, int iterations) {
  std::vector<double> params = gentle->RestPatchParameters();
  Eigen::Matrix3Xd previous = gentle->PositionsOf(params), before_previous = previous;
  const polyfit::ClothRest rest = polyfit::PrepareClothRest(gentle->rest_garment());
  const ceres::GradientProblemSolver::Options options = LbfgsOptions(iterations);
  std::array<Row, 2> rows;
  for (int k = 0; k < kLeadIn + frames; ++k) {
    const auto pose = LeadInOrFrame(clip, k);
    const ceres::GradientProblemSolver::Summary summary =
        ChainStep(gentle, pose, k, previous, before_previous, options, &params);
    const Eigen::Matrix3Xd x = gentle->PositionsOf(params);
    if (k >= kLeadIn) {
      rows[0].energy += summary.final_cost / frames;
      rows[0].iterations += static_cast<double>(summary.iterations.size()) / frames;
      Measure(*gentle, rest, x, frames, &rows[0]);
      stiff->SetHistory(previous, before_previous);
      stiff->Pose(pose, k);
      std::vector<double> raised = params;
      SolveAndMeasure(options, stiff, rest, frames, &raised, &rows[1]);
    }
    before_previous = previous;
    previous = x;
  }
  return rows;
}

// The model's prediction per frame (its own frames as the history) and,
// from it, `iterations` L-BFGS iterations on the loss: whether the
// network's drape is in the basin of the best the output space holds.
std::array<Row, 5> NetworkAndPolished(const polyfit::OneFitModel& model, const polyfit::SkinnedBody& body,
                                      const polyfit::SkinWeights& weights, DrapeSolver* solver,
                                      const polyfit::MotionRetargeter& clip, int frames, int iterations) {
  const polyfit::OneFitDraper draper(model, *solver, weights, body.skeleton, &body);
  const polyfit::ClothRest rest = polyfit::PrepareClothRest(solver->rest_garment());
  const ceres::GradientProblemSolver::Options options = LbfgsOptions(iterations);
  std::array<Row, 5> rows;
  Eigen::Matrix3Xd previous, before_previous;
  const auto pose = [&](int f) { return clip.Pose(std::max(f, 0)); };
  const int warp_begin = polyfit::NumJetCoefficients(model.jet_order) + 4;
  for (int f = 0; f < frames; ++f) {
    std::vector<double> params = draper.Predict(pose(f - 2), pose(f - 1), pose(f), 30.0, polyfit::BodyShape{});
    const Eigen::Matrix3Xd x = solver->PositionsAt(params, pose(f));
    if (f == 0) previous = before_previous = x;
    solver->SetHistory(previous, before_previous);
    solver->Pose(pose(f), kLeadIn + f);
    rows[0].energy += solver->Evaluate(params, nullptr) / frames;
    Measure(*solver, rest, x, frames, &rows[0]);
    for (const bool translations : {false, true}) {
      if (warp_begin == solver->num_patch_parameters()) break;
      Row& row = rows[translations ? 4 : 3];
      const auto start = std::chrono::steady_clock::now();
      const std::vector<double> solved = solver->SolveWarps(params, kWarpSolveSweeps, 2, translations);
      row.iterations += 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / frames;
      row.energy += solver->Evaluate(solved, nullptr) / frames;
      Measure(*solver, rest, solver->PositionsOf(solved), frames, &row);
    }
    std::vector<double> warped = params;
    SolveAndMeasure(options, solver, rest, frames, &params, &rows[1]);
    if (warp_begin < solver->num_patch_parameters()) {
      SolveAndMeasure(options, solver, rest, frames, &warped, &rows[2], warp_begin);
    }
    before_previous = previous;
    previous = x;
  }
  return rows;
}

// Which of a patch's outputs carries the network's strain: per frame, the
// reference drape's fitted warps F and the network's prediction N (from
// the poses alone), and N with one block of each patch's parameters
// taken from F (its jet; its scale and translation; its warp), and F
// with N's jets. Rows in that order.
std::array<Row, 6> SwappedBlocks(const polyfit::OneFitModel& model, const polyfit::SkinnedBody& body,
                                 const polyfit::SkinWeights& weights, DrapeSolver* solver,
                                 const polyfit::MotionRetargeter& clip, int frames) {
  const polyfit::OneFitDraper draper(model, *solver, weights, body.skeleton, &body);
  const polyfit::ClothRest rest = polyfit::PrepareClothRest(solver->rest_garment());
  const int stride = solver->num_patch_parameters(), num_jet = polyfit::NumJetCoefficients(model.jet_order);
  // [begin, end) of each block within a patch's parameters.
  const std::pair<int, int> jets{0, num_jet}, frame{num_jet, num_jet + 4}, warp{num_jet + 4, stride};
  const auto swap = [&](std::vector<double> into, const std::vector<double>& from, std::pair<int, int> block) {
    for (int p = 0; p < solver->num_patches(); ++p) {
      for (int i = block.first; i < block.second; ++i) into[p * stride + i] = from[p * stride + i];
    }
    return into;
  };
  std::array<Row, 6> rows;
  for (int k = 0; k < kLeadIn + frames; ++k) {
    solver->Step(LeadInOrFrame(clip, k), k);
    if (k < kLeadIn) continue;
    const int f = k - kLeadIn;
    const auto pose = [&](int g) { return clip.Pose(std::max(g, 0)); };
    const std::vector<double> fitted = solver->PatchParameters();
    const std::vector<double> network = draper.Predict(pose(f - 2), pose(f - 1), pose(f), 30.0, polyfit::BodyShape{});
    const std::vector<double> drapes[6] = {fitted,
                                           network,
                                           swap(network, fitted, jets),
                                           swap(network, fitted, frame),
                                           swap(network, fitted, warp),
                                           swap(fitted, network, jets)};
    for (int r = 0; r < 6; ++r) Measure(*solver, rest, solver->PositionsOf(drapes[r]), frames, &rows[r]);
  }
  return rows;
}

// One configuration: the patching (its area and warp order) and the loss's
// weights; the rest as the drape's defaults.
struct Config {
  double area;
  int warp, iterations;
  double collision, margin, floor, boundary, stretch = 1.0;
};

// The configurations of argv[4] (AREA:WARP:ITERATIONS[:KC[:EPS[:FLOOR[:KB[:SF]]]]],
// comma-separated), else the defaults (the table of docs/benchmarks.md);
// empty, after saying why, when one does not parse.
std::vector<Config> ParseConfigs(int argc, char** argv) {
  const polyfit::DrapingWeights defaults;
  const double kc = defaults.collision, eps = defaults.collision_margin, kb = defaults.boundary;
  const double floor = polyfit::DrapePhysicsOptions{}.margin_floor;
  if (argc <= 4) {
    return {Config{0.04, -1, 200, kc, eps, floor, kb}, Config{0.04, 2, 200, kc, eps, floor, kb},
            Config{0.04, 2, 1000, kc, eps, floor, kb}, Config{0.04, 4, 200, kc, eps, floor, kb},
            Config{0.02, 2, 200, kc, eps, floor, kb}};
  }
  std::vector<Config> configs;
  std::istringstream list(argv[4]);
  for (std::string item; std::getline(list, item, ',');) {
    Config c{0.0, 0, 0, kc, eps, floor, kb};
    if (std::sscanf(item.c_str(), "%lf:%d:%d:%lf:%lf:%lf:%lf:%lf", &c.area, &c.warp, &c.iterations, &c.collision,
                    &c.margin, &c.floor, &c.boundary, &c.stretch) < 3) {
      std::fprintf(stderr, "output_space_benchmark: '%s' is not AREA:WARP:ITERATIONS[:KC[:EPS[:FLOOR[:KB[:SF]]]]]\n",
                   item.c_str());
      return {};
    }
    configs.push_back(c);
  }
  return configs;
}

polyfit::DrapeSolverOptions SolverOptions(const Config& c, const polyfit::OneFitModel* model) {
  polyfit::DrapeSolverOptions options;
  if (model != nullptr) polyfit::PatchLikeModel(*model, &options);
  options.patching.patch_area = c.area;
  options.slide.warp_order = c.warp;
  options.slide.enabled = c.warp >= 0;
  options.physics.weights.collision = c.collision;
  options.physics.weights.collision_margin = c.margin;
  options.physics.margin_floor = c.floor;
  options.physics.weights.boundary = c.boundary;
  options.physics.stretch_factor = c.stretch;
  options.num_threads = 2;
  return options;
}

enum class Mode { kOutputSpace, kReference, kNetwork, kSwap, kContinuation };

// The strain of each row split by edge class (Row::within, Row::seam).
void PrintSplit(const std::vector<const char*>& names, const std::vector<Row>& rows) {
  std::printf("  strain within a patch / across a seam (%%):");
  for (size_t i = 0; i < rows.size(); ++i) std::printf(" %s %.2f / %.2f;", names[i], rows[i].within, rows[i].seam);
  std::printf("\n");
}

// One configuration's line (a table row in the output-space mode).
void RunConfig(const Config& c, Mode mode, const polyfit::OneFitModel* model, const polyfit::BenchmarkWalk& walk,
               const polyfit::SkinWeights& weights, int frames, double gentle_collision) {
  const polyfit::SkinnedBody& body = walk.walk.body;
  const polyfit::MotionRetargeter& clip = *walk.walk.clip;
  DrapeSolver solver(body, walk.walk.garment, weights, SolverOptions(c, model));
  if (mode == Mode::kContinuation) {
    Config gentle_config = c;
    gentle_config.collision = gentle_collision;
    DrapeSolver gentle(body, walk.walk.garment, weights, SolverOptions(gentle_config, model));
    const std::array<Row, 2> rows = Continuation(&gentle, &solver, clip, frames, c.iterations);
    std::printf(
        "k_c %g, eps %g mm, warp order %d: solved frame to frame at k_c %g %.2f / %.2f (loss %.0f J, %.0f "
        "iterations); from each of its frames at k_c %g %.2f / %.2f (loss %.0f J, %.0f iterations)\n",
        c.collision, 1e3 * c.margin, c.warp, gentle_collision, rows[0].inside, rows[0].strain, rows[0].energy,
        rows[0].iterations, c.collision, rows[1].inside, rows[1].strain, rows[1].energy, rows[1].iterations);
    PrintSplit({"gentle chain", "raised from it"}, {rows[0], rows[1]});
  } else if (mode == Mode::kNetwork) {
    const std::array<Row, 5> rows = NetworkAndPolished(*model, body, weights, &solver, clip, frames, c.iterations);
    std::printf(
        "k_c %g, eps %g mm, warp order %d: the network %.2f / %.2f (loss %.0f J); L-BFGS from it %.2f / %.2f "
        "(loss %.0f J, %.0f iterations); over its warps alone %.2f / %.2f (loss %.0f J, %.0f iterations)\n",
        c.collision, 1e3 * c.margin, c.warp, rows[0].inside, rows[0].strain, rows[0].energy, rows[1].inside,
        rows[1].strain, rows[1].energy, rows[1].iterations, rows[2].inside, rows[2].strain, rows[2].energy,
        rows[2].iterations);
    std::printf("  its warps solved per patch on their edges' strain (SolveWarps, %d sweeps): %.2f / %.2f (loss %.0f J, %.2f ms)\n",
                kWarpSolveSweeps, rows[3].inside, rows[3].strain, rows[3].energy, rows[3].iterations);
    std::printf("  its warps and translations solved so (%d sweeps): %.2f / %.2f (loss %.0f J, %.2f ms)\n",
                kWarpSolveSweeps, rows[4].inside, rows[4].strain, rows[4].energy, rows[4].iterations);
    PrintSplit({"the network", "L-BFGS from it", "over its warps alone", "warps solved", "warps and translations"},
               {rows[0], rows[1], rows[2], rows[3], rows[4]});
  } else if (mode == Mode::kSwap) {
    const std::array<Row, 6> rows = SwappedBlocks(*model, body, weights, &solver, clip, frames);
    const char* names[6] = {"fitted warps F",   "network N",      "N with F's jets", "N with F's scale and translation",
                            "N with F's warps", "F with N's jets"};
    for (int r = 0; r < 6; ++r) {
      std::printf("%-34s eps_c %.2f%%  eps_e %.2f%%  (within a patch %.2f, across a seam %.2f)\n", names[r],
                  rows[r].inside, rows[r].strain, rows[r].within, rows[r].seam);
    }
  } else if (mode == Mode::kReference) {
    const std::array<Row, 3> rows = ReferenceAndFittedWarps(&solver, clip, frames, c.iterations);
    std::printf(
        "k_c %g, eps %g mm, warp order %d: reference drape %.2f / %.2f; its slides as fitted warps %.2f / %.2f "
        "(loss %.0f J); L-BFGS from there %.2f / %.2f (loss %.0f J, %.0f iterations)\n",
        c.collision, 1e3 * c.margin, c.warp, rows[0].inside, rows[0].strain, rows[1].inside, rows[1].strain,
        rows[1].energy, rows[2].inside, rows[2].strain, rows[2].energy, rows[2].iterations);
    PrintSplit({"reference drape", "fitted warps", "L-BFGS from there"}, {rows[0], rows[1], rows[2]});
  } else {
    const Row row = DrapeInOutputSpace(&solver, clip, frames, c.iterations);
    char floor_mm[32] = "none";
    if (c.floor >= 0.0) std::snprintf(floor_mm, sizeof(floor_mm), "%g", 1e3 * c.floor);
    std::printf("| %g | %d | %d | %g | %g | %s | %g | %d (%.0f) | %.0f | %.2f | %.2f |\n", c.area, solver.num_patches(),
                c.warp, c.collision, 1e3 * c.margin, floor_mm, c.boundary, c.iterations, row.iterations, row.energy,
                row.inside, row.strain);
  }
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace polyfit;
  google::InitGoogleLogging(argv[0]);
  FLAGS_minloglevel = 2;
  const std::optional<BenchmarkWalk> loaded = LoadBenchmarkWalk(argc, argv);
  if (!loaded) return 1;
  const int frames = argc > 3 ? std::atoi(argv[3]) : 30;
  const std::vector<Config> configs = ParseConfigs(argc, argv);
  if (configs.empty()) return 2;
  SkinWeights weights = loaded->walk.weights;
  std::optional<OneFitModel> model;
  if (argc > 5) {
    try {
      model = LoadOneFitModel(argv[5]);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "output_space_benchmark: %s\n", e.what());
      return 1;
    }
    weights = TransferSkinWeights(loaded->walk.body, loaded->walk.garment, model->skin);
  }
  const std::string mode_name = argc > 6 ? argv[6] : "";
  const Mode mode = mode_name == "reference" ? Mode::kReference
                    : mode_name == "network" ? Mode::kNetwork
                    : mode_name == "swap"    ? Mode::kSwap
                    : mode_name == "continuation" ? Mode::kContinuation
                                                  : Mode::kOutputSpace;
  const double gentle_collision = argc > 7 ? std::atof(argv[7]) : 1.0;
  if (!mode_name.empty() && mode == Mode::kOutputSpace) {
    std::fprintf(stderr,
                 "output_space_benchmark: the mode after MODEL is 'reference', 'network', 'swap', 'continuation' or "
                 "nothing, not "
                 "'%s'\n",
                 mode_name.c_str());
    return 2;
  }
  std::printf("%s, walk frames 0-%d, the drape solved in the network's output space (L-BFGS per frame)\n\n",
              loaded->garment_path.c_str(), frames - 1);
  if (mode == Mode::kOutputSpace) {
    std::printf(
        "| patch area m^2 | patches | warp order | k_c | eps mm | floor mm | k_b | L-BFGS iterations (mean taken) | "
        "energy J | eps_c %% | eps_e %% |\n");
    std::printf("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  }
  for (const Config& c : configs) RunConfig(c, mode, model ? &*model : nullptr, *loaded, weights, frames, gentle_collision);
  return 0;
}
