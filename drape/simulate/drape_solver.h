// The reference drape: OneFit's losses minimised directly, frame by frame,
// over the garment's patch parameters (jet coefficients alpha, scale s,
// translation T per patch, in the body's rest pose; the garment is posed by
// skinning weights transferred from the body) and each vertex's slide
// (du, dv) along its patch, with Ceres, warm-started from the previous
// frame. The slides keep every vertex on its patch's jet; without them a
// patch moves its vertices only along its normal, and skinning's in-plane
// distortion at the joints could not be undone.
//
// Per frame the objective (joules, so that the paper's weights multiply
// physical energies) is
//   k_c    sum_v kappa / 2 max(eps - d_v, 0)^2          collision (eq. 3), d along the body's normal
//   k_mi   sum_e sigma mu A_e ((l_e - L_e) / L_e)^2     edge inextensibility (eq. 1)
//   k_mi sum_f sigma mu A_f / 4 |g - k_ext g0|_F^2     metric tensor (eq. 4) per face of a patch, at its
//                                                        slid centroid with the slides' warp; k_ext per
//                                                        point from its penetration and the epoch
//   k_b    sum_boundary beta mu A (|X_a - X_b|^2 / h^2 + |n_a - n_b|^2)   patch boundary (eq. 5)
//   k_mi   sum_(v, p != p0) sigma mu A_v |X_p - X_p0 - g|^2 / h^2   a vertex's slid points on its
//                                                        patches kept together (g: their rest gap)
//   k_g    sum_v m_v g (x_v . up)                       gravity (eq. 7), folded into inertia
//   k_i    sum_v m_v / (2 dt^2) |x_v - (2 x_v^{t-1} - x_v^{t-2})|^2   inertia (eq. 8)
// plus a small prior pulling the parameters to the previous frame's. mu is
// the material's Lame mu, A vertex or edge areas, m_v = density A_v, h the
// mean edge length, kappa a stiffness in N/m, sigma and beta the stretch and
// boundary bases (DrapePhysicsOptions). Collisions are linearised at the
// start of each pass (closest body point and pseudonormal) and passes
// repeat while a vertex is inside the body. The terms are the costs of
// drape/losses/skinned_patch_costs.h and cost_functions/.
#ifndef POLYFIT_DRAPE_SIMULATE_DRAPE_SOLVER_H_
#define POLYFIT_DRAPE_SIMULATE_DRAPE_SOLVER_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <ceres/solver.h>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "drape/body/makehuman_body.h"
#include "drape/eval/cloth_energy.h"
#include "drape/garment/skin_transfer.h"
#include "drape/losses/draping_weights.h"
#include "polyfit/mesh/triangle_mesh.h"
#include "polyfit/model/polyfit_model.h"
#include "polyfit/util/status.h"

namespace polyfit {

// What the cloth is and what acts on it.
struct DrapePhysicsOptions {
  DrapingWeights weights;
  KextOptions k_ext;
  ClothMaterial material;
  // kappa: collision stiffness per vertex, N/m.
  double collision_stiffness = 1e6;
  // beta: the boundary term's base, a fraction of mu (with 1 the paper's
  // k_b = 5e3 glues every patch to its rest shape; docs/drape.md).
  double boundary_base = 1e-3;
  // sigma: the inextensibility terms' base, a multiple of mu (measured in
  // docs/drape.md).
  double stretch_base = 5.0;
  // The inextensibility terms' residuals where the cloth stretches (an
  // edge longer than at rest, a metric's diagonal above the rest's) times
  // this: cloth resists stretch far more than compression, which it
  // relieves by buckling. 1: the paper's symmetric terms.
  double stretch_factor = 1.0;
  // Collision terms for vertices closer to the body than this (m).
  double collision_band = 0.03;
  // >= 0 (m): each vertex's margin is its rest clearance (its signed
  // distance to the body at rest) clamped to [margin_floor,
  // weights.collision_margin]. Where a garment is cut closer to the body
  // than the margin, holding it the margin off must stretch it (a cuff of
  // radius r by eps / r); the floor keeps a margin where it was cut into
  // the body. < 0: every vertex has weights.collision_margin.
  double margin_floor = -1.0;
  double gravity = 9.81;  // m/s^2
  double fps = 30.0;
};

// How the garment becomes patches (polyfit/pipeline/adaptive_patches.h).
struct GarmentPatchOptions {
  int jet_order = 4;
  // Initial patches: the garment's area over patch_area (m^2, at least 1),
  // so that a remeshed garment gets the same patches (the paper's rule,
  // which uses 0.008 m^2 and clamps to [100, 400]; docs/drape.md).
  double patch_area = 0.04;
  // Jets fitted to a barycentric grid of this many subdivisions per face
  // edge rather than to the vertices alone: a small patch of a coarse
  // garment has fewer vertices than a jet has coefficients.
  int face_subdivisions = 3;
  // The grid on the faces' Phong tessellation (FitPatchJets' curved_faces):
  // a coarse garment's flat faces cut chords inside the surface its
  // vertices sample, so that its patches would sit closer to the body than
  // a fine meshing's of the same garment. A model records it
  // (OneFitModel::curved_faces).
  bool curved_faces = false;
  // The clustering's seed (ClusteringOptions::seed): another seed, another
  // layout of patches of the same size.
  std::uint64_t seed = 1;
  // Patches whose jet misses a vertex by more (m) are split, up to
  // max_splits rounds.
  double max_fit_error = 8e-3;
  int max_splits = 4;
  // Turn each patch's frame about its normal so that its u axis follows
  // the body's up axis (y; forward z where a patch faces up or down):
  // AlignPatchFrames. PCA's in-plane axes are arbitrary (random on a round
  // patch), so a network reading and predicting jets in them sees noise; a
  // remeshed garment's patches share aligned frames. A model records
  // whether it was trained so (OneFitModel::aligned_frames).
  bool align_frames = false;
};

// Each vertex's slide along its patch ((u, v) a parameter too); disabled,
// vertices keep their rest (u, v). A vertex's points on several patches are
// held together by a term `agreement` times as stiff as stretch over the
// mean edge length.
//
// warp_order >= 0: the patch parameters that Evaluate, PositionsOf,
// WarmStart and Adopt take (a network's prediction) also carry each
// patch's in-plane warp, a polynomial of that order in the rest (u, v),
//   (du, dv) = r (sum_ij a_ij (u/r)^i (v/r)^j, sum_ij b_ij (u/r)^i (v/r)^j)
// with r the patch's largest rest |(u, v)| (coefficients relative to its
// extent),
// which sets the slides of its points: a mesh-agnostic stand-in for the
// per-vertex slides, which a network cannot predict. Needs `enabled`.
struct DrapeSlideOptions {
  bool enabled = true;
  double agreement = 1.0;
  int warp_order = -1;
};

enum class DrapeLinearSolver {
  kAuto,               // CG from conjugate_gradients_min_vertices, else Cholesky
  kSparseCholesky,     // exact steps
  kConjugateGradients  // inexact steps (CGNR, block Jacobi)
};

// The per-frame minimisation.
struct DrapeSolveOptions {
  DrapeSolveOptions();

  // Levenberg-Marquardt iterations in the first pass and in each further
  // pass (collisions re-linearised while a vertex is inside), and passes.
  int max_iterations = 4;
  int max_refine_iterations = 2;
  int max_passes = 2;
  // Weight of the prior on parameter changes, J per unit squared.
  double parameter_prior = 1e-4;
  // The first solve's trust region; later solves carry the last one over.
  double initial_trust_region_radius = 100.0;
  DrapeLinearSolver linear_solver = DrapeLinearSolver::kAuto;
  int conjugate_gradients_min_vertices = 1500;
  // CG's relative residual per step (Ceres' eta) and its iteration cap
  // (docs/drape.md: 50 left a free-falling sheet at 7% of its drop).
  double conjugate_gradients_tolerance = 0.3;
  int max_conjugate_gradients_iterations = 200;
  // 0: silent; 1: Ceres' full report per solve on stderr; 2: also per
  // iteration.
  int trace = 0;
  // Everything else about Ceres (tolerances, ...). Per solve the fields
  // above override max_num_iterations, initial_trust_region_radius, the
  // linear solver, logging and num_threads.
  ceres::Solver::Options ceres;
};

struct DrapeSolverOptions {
  DrapePhysicsOptions physics;
  GarmentPatchOptions patching;
  DrapeSlideOptions slide;
  DrapeSolveOptions solve;
  int num_threads = 2;

  // Empty when valid, else the first problem.
  std::string Validate() const;
};

struct DrapeStepSummary {
  // kConvergence: Ceres converged; kNoConvergence: the iteration budget
  // ran out (the normal case at a fixed cost per frame); kFailure: the
  // result was not finite and the previous frame's state is kept.
  TerminationType termination_type = TerminationType::kConvergence;
  std::string message;
  double time_s = 0.0;        // the whole step: posing, queries, solves
  double solve_time_s = 0.0;  // Ceres alone
  int passes = 0;
  int iterations = 0;
  int collision_terms = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;

  bool IsSolutionUsable() const { return termination_type != TerminationType::kFailure; }
  std::string BriefReport() const;
};

class DrapeSolver {
 public:
  // garment: triangles in the body's rest pose. Throws std::invalid_argument
  // for invalid options and a garment that cannot be patched.
  DrapeSolver(const SkinnedBody& body, const TriangleMesh& garment, const SkinWeights& weights,
              const DrapeSolverOptions& options);
  ~DrapeSolver();

  // Advances one frame with the body posed by `rest_to_posed` (one
  // transform per joint); `epoch` is k_ext's (DrapePhysicsOptions::k_ext).
  DrapeStepSummary Step(const std::vector<Eigen::Isometry3d>& rest_to_posed, double epoch = 0.0);

  // The same objective as a loss, for training a network that predicts
  // the patch parameters (drape/network): Pose() poses the body and sets
  // the motion targets from the history without solving; Evaluate()
  // gives the energy at given patch parameters, with every slide at zero
  // (a network predicts none) or set by the patches' warps, collisions
  // linearised at the positions those parameters give, and its gradient.
  // Parameters, per patch: alpha (NumJetCoefficients(order)), s, T, then
  // with slide.warp_order >= 0 the warp's a and b (NumJetCoefficients(
  // warp_order) each); num_patch_parameters() in all.
  // Not thread-safe: use one solver per thread.
  void Pose(const std::vector<Eigen::Isometry3d>& rest_to_posed, double epoch = 0.0);
  // The collision weight k_c from the next Pose() on (a training's
  // schedule, OneFitTrainerOptions::collision_start).
  void SetCollisionWeight(double weight);
  double collision_weight() const;
  double Evaluate(const std::vector<double>& patch_parameters, std::vector<double>* gradient);
  // The same energy and gradient with the Gauss-Newton approximation of
  // its Hessian, J^T J (num_patch_parameters() #patches square, dense), J
  // the residuals' Jacobian in the patch parameters' layout (the energy is
  // half their squared norm): what a second-order step on a network's
  // output layer needs (OneFitTrainer::PolishOutputLayer). residuals
  // (when not null): r, in a fixed order.
  double EvaluateGaussNewton(const std::vector<double>& patch_parameters, std::vector<double>* gradient,
                             Eigen::MatrixXd* gauss_newton, std::vector<double>* residuals = nullptr);
  // Half the area-weighted mean squared distance between the positions
  // given patch parameters take (posed as last posed: Pose, Step or
  // PositionsAt) and `target` (3 by #V),
  //   E = 1/2 sum_v a_v |x_v - target_v|^2,  a_v = A_v / sum A (rest areas),
  // in m^2, and its gradient over the parameters (num_patch_parameters()
  // #patches): a supervised loss, the reference drape as a network's
  // teacher (OneFitTrainer::Teach). Throws std::invalid_argument for a
  // target of another size or with non-finite points.
  double DistanceTo(const std::vector<double>& patch_parameters, const Eigen::Matrix3Xd& target,
                    std::vector<double>* gradient);
  // The given patch parameters with each patch's warp re-solved for its
  // jet, scale and translation (held), posed as last posed by Pose or
  // Step (the body too): `sweeps` Gauss-Seidel sweeps (the patches by
  // colour, no two of a colour sharing a vertex), each `iterations`
  // damped Gauss-Newton steps per patch from its warp, on
  //   sum_e a_e ((l_e - L_e) / L_e)^2                its own edges' strain
  //   + sum_k A_v / h^2 |x_k - mean_(k' != k) x_k'|^2 its seam points against
  //                                                   the other patches' points
  //                                                   of their vertex (as
  //                                                   last solved)
  //   + k_c kappa / (2 k_mi sigma mu) sum_k max(eps_v / 4 - d_k, 0)^2
  // (a_e, A_v: rest areas; h the mean edge; d_k along the normal of the
  // body's point closest to the vertex where the given parameters put it,
  // for vertices within the collision band; eps_v the vertex's margin, a
  // quarter of it so that the warps keep the garment out of the body but
  // need not hold it off: with the whole margin, on the suit's walk, the
  // strain fell half as far). The loss's own agreement and collision
  // weights in units of its stretch. Needs warp_order >= 0 (throws
  // std::logic_error otherwise). Not thread-safe.
  // move_translations: each patch's translation T solved with its warp
  // (dx/dT the skinning's linear part), so that a patch held off or
  // pushed into the body moves back to a quarter of the margin, as the
  // warps alone cannot (they move the material along the patch).
  std::vector<double> SolveWarps(const std::vector<double>& patch_parameters, int sweeps = 5, int iterations = 2,
                                 bool move_translations = false);
  int num_patch_parameters() const;
  // The rest patch parameters (the fit; no warp), the current ones (the
  // last Step; warps fitted to the slides by least squares), and the
  // positions (3 by #V) of given ones (slides from their warps, else
  // zero), posed.
  std::vector<double> RestPatchParameters() const;
  std::vector<double> PatchParameters() const;
  // Per patch: its faces' rest area (m^2), and r_p, its members' largest
  // rest |(u, v)| (the warp's radius, DrapeSlideOptions).
  std::vector<double> PatchRestAreas() const;
  const std::vector<double>& WarpRadii() const;
  Eigen::Matrix3Xd PositionsOf(const std::vector<double>& patch_parameters) const;
  // The same with the garment's skinning posed by `rest_to_posed` (and left
  // there; the body is not posed: cheap, for a history of frames or the
  // network's inference). Pose() or Step() poses both again.
  Eigen::Matrix3Xd PositionsAt(const std::vector<double>& patch_parameters,
                               const std::vector<Eigen::Isometry3d>& rest_to_posed);
  // Takes given patch parameters (slides from their warps) as the current state,
  // posed as last posed (Pose or Step): positions() and the history follow,
  // so that a Step refines from there (a network's prediction).
  void Adopt(const std::vector<double>& patch_parameters);
  // ... with the garment at `positions` (3 by #V: the parameters' drape
  // moved further, e.g. relaxed) instead of the parameters' own.
  void Adopt(const std::vector<double>& patch_parameters, const Eigen::Matrix3Xd& positions);
  // Takes given patch parameters (slides from their warps) as the start of the
  // next Step, the history untouched: a refinement of a prediction.
  void WarmStart(const std::vector<double>& patch_parameters);
  // The positions inertia predicts from: at t - 1 and t - 2 (3 by #V each).
  void SetHistory(const Eigen::Matrix3Xd& previous, const Eigen::Matrix3Xd& before_previous);

  // The garment now (3 by #V): each vertex the mean of its patches' points.
  const Eigen::Matrix3Xd& positions() const { return positions_; }
  const Eigen::Matrix3Xd& body_vertices() const { return body_vertices_; }
  const TriangleMesh& garment() const { return garment_; }
  // The garment as its patches rebuild it at rest: what stretch is measured
  // against. The fit's error against the input garment, mean and max (m).
  const TriangleMesh& rest_garment() const { return rest_garment_; }
  double fit_error_mean() const { return fit_error_mean_; }
  double fit_error_max() const { return fit_error_max_; }
  const PolyFitModel& model() const { return model_; }
  int num_patches() const { return model_.num_patches(); }
  // Signed distances (exact, negative inside) of the current positions, or
  // of other points (3 by N), to the body as last posed.
  Eigen::VectorXd SignedDistances() const { return SignedDistances(positions_); }
  Eigen::VectorXd SignedDistances(const Eigen::Matrix3Xd& points) const;
  // The same with the nearest-vertex approximation (SNUG, GAPS).
  Eigen::VectorXd NearestVertexDistances() const { return NearestVertexDistances(positions_); }
  Eigen::VectorXd NearestVertexDistances(const Eigen::Matrix3Xd& points) const;
  // The current positions with every vertex inside the body moved to its
  // closest body point plus `offset` along the pseudonormal: a post-process
  // for display, off the patches' surfaces. 3 by #V.
  Eigen::Matrix3Xd ProjectedOutOfBody(double offset) const;
  // ProjectedOutOfBody, then `strain_passes` of LimitStrain over `rest`'s
  // edges, every vertex within kStrainLimitContactReach of the body kept
  // above its tangent plane there. 0 passes: ProjectedOutOfBody.
  Eigen::Matrix3Xd PostProcessed(double offset, int strain_passes, const ClothRest& rest) const;
  static constexpr double kStrainLimitContactReach = 0.02;  // m

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  TriangleMesh garment_;
  TriangleMesh rest_garment_;
  double fit_error_mean_ = 0.0, fit_error_max_ = 0.0;
  PolyFitModel model_;
  Eigen::Matrix3Xd positions_;
  Eigen::Matrix3Xd body_vertices_;
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_SIMULATE_DRAPE_SOLVER_H_
