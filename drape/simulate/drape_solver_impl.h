// DrapeSolver's state (drape_solver.h), shared by the files that
// implement it: drape_solver.cc (the set-up, the frame's solve and the
// loss) and drape_solver_warps.cc (SolveWarps). Not a public header.
#ifndef POLYFIT_DRAPE_SIMULATE_DRAPE_SOLVER_IMPL_H_
#define POLYFIT_DRAPE_SIMULATE_DRAPE_SOLVER_IMPL_H_

#include <array>
#include <memory>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Core>

#include "drape/collision/signed_distance.h"
#include "drape/losses/skinned_patch_costs.h"
#include "drape/simulate/drape_solver.h"

namespace polyfit {

// The solver's state: parameters, per-frame data the costs read through
// pointers, and the Ceres problem built once over them.
struct DrapeSolver::Impl {
  SkinnedBody body;
  SkinWeights weights;
  DrapeSolverOptions options;
  BodySignedDistance distance;
  std::unique_ptr<NearestVertexDistance> nearest;  // built when asked for
  bool nearest_stale = true;
  ClothRest rest;
  int num_coefficients = 0;
  static constexpr int kStride = kMaxJetCoefficients + 4;  // alpha, s, T per patch
  std::vector<double> params, previous_params, rest_params;
  // Per membership: its point's slide (du, dv) along its patch.
  std::vector<double> slides, previous_slides;
  std::vector<double> saved_params, saved_slides;  // the state kept aside (DistanceTo, SolveWarps)
  // The warps' monomials per direction (DrapeSlideOptions::warp_order),
  // and their values at each membership's rest (u, v) (num_warp each).
  int num_warp = 0;
  std::vector<double> warp_basis;
  std::vector<double> warp_radius;  // per patch: r_p
  // Per membership.
  std::vector<int> membership_vertex;
  // The metric term's faces: a face of patch p with its corners'
  // memberships on p, their rest (u, v) and g0 at the centroid.
  struct FaceMetric {
    int face, patch;
    int membership[3];
    Eigen::Matrix<double, 2, 3> uv;
    Eigen::Vector3d rest_metric;
  };
  std::vector<FaceMetric> face_metrics;
  // One posed point per membership, reading skin_linear and
  // skin_translation (sized once, so the pointers stay valid).
  std::vector<SkinnedPatchPoint> points;
  // Per vertex.
  std::vector<double> mass;
  std::vector<Eigen::Matrix3d> skin_linear;
  std::vector<Eigen::Vector3d> skin_translation;
  Eigen::Matrix3Xd history1, history2;  // posed positions at t - 1, t - 2
  // Edges evaluated in a patch: (edge, membership of i, membership of j).
  struct PatchEdge {
    int edge, mi, mj;
  };
  std::vector<PatchEdge> patch_edges;
  std::vector<double> edge_area;  // per unique edge of `rest`
  std::vector<PatchBoundaryPoint> boundary;
  std::vector<Eigen::Vector3d> boundary_position_gap, boundary_normal_gap;
  double mean_edge = 0.0;
  double floor = 0.0;
  // Collision linearisation per vertex.
  std::vector<SignedDistanceResult> contact;
  // The problem, built once; its costs read these, updated per frame.
  std::unique_ptr<ceres::Problem> problem;
  std::vector<VertexTermsData> vertex_data;  // per membership
  std::vector<double> k_ext;                 // per vertex, set with the collisions
  std::vector<double> margin;                // per vertex: the collision margin (DrapePhysicsOptions::margin_floor)
  double epoch = 0.0;                        // k_ext's epoch
  // Levenberg-Marquardt's trust region carried from solve to solve.
  double trust_region_radius = 0.0;

  Impl(const SkinnedBody& b, const SkinWeights& w, const DrapeSolverOptions& o)
      : body(b), weights(w), options(o), distance(b.mesh) {}

  double* alpha(int p) { return params.data() + p * kStride; }
  double* scale(int p) { return params.data() + p * kStride + kMaxJetCoefficients; }
  double* translation(int p) { return params.data() + p * kStride + kMaxJetCoefficients + 1; }
  double* slide(int k) { return slides.data() + 2 * k; }
  const double* warp_monomials(int k) const { return warp_basis.data() + num_warp * k; }
  // The public layout's values per patch: alpha, s, T, warp.
  int packed_stride() const { return num_coefficients + 4 + 2 * num_warp; }

  // Set-up phases, in order.
  void InitializeParameters(const PolyFitModel& model);
  void CollectFaceMetrics(const PolyFitModel& model);
  void BuildPoints(const PolyFitModel& model);
  void CollectPatchEdges(const PolyFitModel& model);
  void CollectBoundary(const PolyFitModel& model);
  // The problem, by term.
  void BuildProblem(const PolyFitModel& model);
  void AddVertexTerms(const PolyFitModel& model);
  void AddMetricTerms(const PolyFitModel& model);
  void AddEdgeTerms(const PolyFitModel& model);
  void AddBoundaryTerms(const PolyFitModel& model);
  void AddSlideTerms(const PolyFitModel& model);
  void AddPriors(const PolyFitModel& model);
  // Per frame.
  void PoseBodyAndGarment(const std::vector<Eigen::Isometry3d>& rest_to_posed, Eigen::Matrix3Xd* body_vertices);
  void SetMotionTargets(const PolyFitModel& model);
  int LinearizeCollisions(const PolyFitModel& model);
  ceres::Solver::Options SolverOptions(int pass, int num_vertices) const;
  // Each vertex the mean of its patches' posed points (3 by #V).
  void Positions(const PolyFitModel& model, Eigen::Matrix3Xd* out);
  // The same for packed patch parameters (SetPatchParameters' layout),
  // the solver's own state untouched: inference's path, which copies
  // nothing.
  void PositionsOfPacked(const PolyFitModel& model, const std::vector<double>& packed, Eigen::Matrix3Xd* out) const;
  void CheckPackedSize(const std::vector<double>& packed) const;
  // skin_linear and skin_translation blended from the joints' transforms.
  void BlendGarmentSkin(const std::vector<Eigen::Isometry3d>& rest_to_posed);
  std::vector<Eigen::Matrix<double, 3, 4>> joint_affine;  // BlendGarmentSkin's scratch
  // Closest body points of `positions`; returns how many are inside.
  int QueryContacts(const Eigen::Matrix3Xd& positions);
  // The public patch-parameter layout (alpha, s, T, warp per patch,
  // packed); setting it sets the slides (zero without warps).
  void SetPatchParameters(const PolyFitModel& model, const std::vector<double>& packed);
  // Warps zero.
  std::vector<double> PackedPatchParameters(const std::vector<double>& strided) const;
  // Each patch's warp set to the least-squares fit of its points' slides.
  void FitWarpsToSlides(const PolyFitModel& model, std::vector<double>* packed) const;
  // Membership k's slide (du, dv) under its patch's warp (a then b,
  // num_warp each).
  void WarpSlide(int k, const double* warp, double slide[2]) const;
  // SolveWarps' terms, built on first use. Per patch: its memberships,
  // and its edges as (edge, i, j), i and j indices into its memberships.
  std::vector<std::vector<int>> members_by_patch;
  std::vector<std::vector<std::array<int, 3>>> edges_by_patch;
  // Per patch (indices into its memberships): those whose vertex other
  // patches share (seam points), pulled to the mean of the other patches'
  // points of their vertex (seam_targets, 3 by #memberships, per sweep),
  // and those whose vertex is within the collision band of the body
  // (contact, queried at the given parameters' positions), kept
  // kWarpMarginScale times the vertex's margin off the contact's tangent
  // plane.
  std::vector<std::vector<int>> seam_members_by_patch;
  Eigen::Matrix3Xd seam_targets;
  std::vector<std::vector<int>> near_members_by_patch;
  std::vector<int> member_index;                    // per membership: its index in members_by_patch
  static constexpr double kWarpMarginScale = 0.25;  // SolveWarps (drape_solver.h)
  Eigen::Matrix3Xd warp_positions;                  // SolveWarps' scratch, 3 by #V
  void CollectPatchWarpTerms(const PolyFitModel& model);
  // A patch's unknowns: its warp, then with warp_solve_translation its T
  // (at most 2 kMaxJetCoefficients + 3: fixed capacity, no allocation).
  static constexpr int kMaxWarpUnknowns = 2 * kMaxJetCoefficients + 3;
  using WarpSystem = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxWarpUnknowns, kMaxWarpUnknowns>;
  using WarpVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxWarpUnknowns, 1>;
  // Half the squared residuals of patch p's terms at its unknowns c and,
  // when jtj is given, their Gauss-Newton system and gradient.
  double PatchEdgeStrain(int p, const double* c, WarpSystem* jtj, WarpVector* jtr);
  // Patch p's points at its warp c, in its memberships' order: posed, and
  // their derivatives in the slide (3 by 2) when dx_dslide is given.
  void PatchPoints(int p, const double* c, const double* t, std::vector<Eigen::Vector3d>* x,
                   std::vector<Eigen::Matrix<double, 3, 2, Eigen::RowMajor>>* dx_dslide);
  // translation_out: with warp_solve_translation, the patch's T (packed).
  void SolvePatchWarp(int p, int iterations, double* warp, double* translation_out);
  bool warp_solve_translation = false;  // SolveWarps' move_translations
  // Patches coloured so that no two of a colour share a vertex (greedy):
  // a colour's patches are solved together, each against the latest
  // points of the others (Gauss-Seidel by colour).
  std::vector<std::vector<int>> patches_by_colour;
  // The seam points where the warps put them (3 by #memberships; seam
  // memberships only), and seam_targets from them.
  Eigen::Matrix3Xd seam_points;
  void UpdateSeamPoints(int p, const double* warp, const double* t);
  void UpdateSeamTargets(const PolyFitModel& model);
  // d(Ceres' parameters)/d(packed parameters), Ceres' layout being alpha,
  // s, T per patch, then with warps each membership's slide (a linear map
  // of its patch's warp), built once: Ceres' parameter c is the sum over
  // i in [chain_begin[c], chain_begin[c + 1]) of chain[i].weight times
  // packed parameter chain[i].packed. (Eigen's sparse module is not used:
  // its templates, instantiated here with our alignment, would replace
  // Ceres' own at link time.)
  struct ChainEntry {
    int packed;
    double weight;
  };
  std::vector<int> chain_begin;
  std::vector<ChainEntry> chain;
  void BuildChain(const PolyFitModel& model);
  // gradient (num_packed) = C^T raw, raw a gradient in Ceres' layout.
  void ChainGradient(const std::vector<double>& raw, int num_packed, std::vector<double>* gradient) const;
  // (J C)^T (J C), J Ceres' Jacobian (rows of a few entries), dense.
  void AccumulateGaussNewton(const ceres::CRSMatrix& jacobian, int num_packed, Eigen::MatrixXd* out) const;
  double EvaluatePacked(const PolyFitModel& model, const std::vector<double>& packed, std::vector<double>* gradient,
                        Eigen::MatrixXd* gauss_newton, std::vector<double>* residuals);
  // The cost and its gradient over `listed` (Ceres' layout: the blocks'
  // values concatenated) by evaluating every residual block directly:
  // ceres::Problem::Evaluate rebuilds its program on every call, which
  // was a quarter of a training batch. Blocks not listed, or constant,
  // get no gradient, as with Ceres; no term has a loss function.
  struct DirectBlock {
    const ceres::CostFunction* cost;
    std::vector<double*> parameters;
    std::vector<int> offsets;  // into the gradient, -1 for no gradient
  };
  std::vector<DirectBlock> direct_blocks;
  int direct_gradient_size = 0;
  // Per thread: gradient sums, residual and Jacobian scratch, cost; kept
  // across calls (training evaluates thousands of times).
  std::vector<std::vector<double>> direct_sums, direct_scratch;
  std::vector<double> direct_costs;
  std::vector<char> direct_failed;
  static constexpr int kMaxDirectBlocks = 8;  // parameter blocks per residual block
  void BuildDirectBlocks(const std::vector<double*>& listed);
  bool EvaluateDirect(const std::vector<double*>& listed, double* cost, std::vector<double>* gradient);

  double stretch_weight() const { return options.physics.weights.inextensibility * options.physics.stretch_base; }
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_SIMULATE_DRAPE_SOLVER_IMPL_H_
