// The per-frame Ceres costs of PolySfT, on the JetDeformationModel's
// parameters: one block per patch of its atlas (block_size() each), so that
// the solver's normal equations stay sparse by patch. Each evaluates the
// model once and chains its Jacobian by hand, so that a frame's thousands
// of residuals cost one model evaluation.
#ifndef POLYFIT_SFT_SOLVER_FRAME_COSTS_H_
#define POLYFIT_SFT_SOLVER_FRAME_COSTS_H_

#include <array>
#include <memory>
#include <vector>

#include <ceres/cost_function.h>
#include <ceres/evaluation_callback.h>
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "cost_functions/compressed_cost.h"
#include "cost_functions/edge_inextensibility.h"
#include "cost_functions/hinge_bending.h"
#include "sft/model/jet_deformation.h"
#include "sft/render/soft_rasterizer.h"
#include "sft/scene/scene.h"
#include "sft/solver/robust_loss.h"

namespace polyfit {

// Groups of patches a pixel may depend on together: which patches' blocks
// the render term of an atlas couples (SplitRenderTerm), so that its
// normal equations stay sparse by patch instead of dense over all of them.
struct PatchGroups {
  std::vector<std::vector<int>> groups;  // sorted patch lists
  // The smallest group holding all of `patches` (sorted; *whole true), or
  // else the one holding most of them (*whole false); -1 when empty.
  int Find(const int* patches, int size, bool* whole) const;
};

// Photometric and silhouette residuals over the pixels of `roi`:
//   r_rgb(p) = w_photo (I(p; theta) - I_obs(p))                (robustified per pixel)
//   r_s(p)   = w_sil (S(p; theta) - clamp(S(p; theta), M_lo(p), M_hi(p)))
// (with a mask only). I and S from the soft rasterizer with the observed
// frame as background. The mask's bounds are equal (r_s = w_sil (S - M)),
// or a tolerance band around its border (silhouette_band.h) where any coverage
// costs nothing.
class RenderCost : public ceres::CostFunction {
 public:
  struct Data {
    const JetDeformationModel* model = nullptr;
    const SoftRasterizer* rasterizer = nullptr;
    // Faces, corner texture coordinates, boundary flags, depth range.
    ScreenMesh mesh;
    PinholeCamera camera;
    cv::Mat image;       // CV_32FC3
    // What the surface is rendered over (CV_32FC3, the image's size):
    // empty, the image itself (so that pixels the surface does not reach
    // have no residual); or a background plate (sft/render/
    // background_plate.h) for Compositing::kOverBackground.
    cv::Mat background;
    cv::Mat mask;        // CV_32F or empty: M_lo
    cv::Mat mask_upper;  // CV_32F, M_hi; empty: M_lo
    cv::Rect roi;
    double photometric_weight = 1.0;
    double silhouette_weight = 1.0;
    RobustLoss robust_loss = RobustLoss::kNone;
    double robust_scale = 0.1;
    // The render's buffers, kept by the caller and reused by costs that
    // are never evaluated at the same time (a frame's cost at each level
    // and solve): fresh buffers of a few megabytes cost more in page
    // faults than a small mesh's render. Null: the cost's own.
    SoftRenderOutput* render_scratch = nullptr;
  };
  // Parameter blocks: one per patch of the model, in patch order.
  explicit RenderCost(Data data);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;
  // |r|^2, and J^T J and J^T r (when not null), without forming J, at theta
  // (all blocks, contiguous). Rows of pixels no triangle touches are zero
  // and skipped; a pixel's row is non-zero only in the blocks of the patches
  // its vertices belong to, and is gathered with the pixels of the same
  // patches: the work per pixel is that of one patch's block (two or three
  // on a seam), whatever the atlas's size.
  bool EvaluateNormalEquations(const double* theta, double* squared_norm, Eigen::MatrixXd* jtj,
                               Eigen::VectorXd* jtr) const;
  // Per vertex (#V): the squared residuals of the pixels it shapes, each
  // pixel's shared equally among its vertices, and the pixels so shared
  // (where the surface fits worse than elsewhere).
  bool VertexResiduals(const double* theta, Eigen::VectorXd* squared_residuals, Eigen::VectorXd* pixels) const;

  // How EvaluateSlottedNormalEquations renders the frame.
  enum class RenderReuse {
    kNone,  // for what is asked
    // The cost alone asked, but rendered with the gradients too, kept for
    // an evaluation of the normal equations at the same theta (kReuse).
    kKeep,
    // The render kept by the evaluation before (kKeep) where it was at
    // this theta; afresh otherwise.
    kReuse,
  };
  // The normal equations as SplitRenderTerm keeps them: patch p's
  // parameters at block slot[p] (n = #patches by block size), only the
  // blocks (slot[p], slot[q]) with slot[p] <= slot[q] of patches p, q that
  // one of `groups` holds together added to (the caller zeroes them; the
  // diagonal blocks whole). A pixel's rows go with the group of its patches
  // (PatchGroups::Find); when no group holds them all, with the one that
  // holds most, without the other patches' columns (its cost kept, its pull
  // on them lost). jtr (n) is set. `render`: whether the render is kept
  // for, or reused from, an evaluation at the same theta.
  bool EvaluateSlottedNormalEquations(const double* theta, const PatchGroups& groups, const std::vector<int>& slot,
                                      bool want_jacobian, double* squared_norm, Eigen::MatrixXd* jtj,
                                      Eigen::VectorXd* jtr, RenderReuse render = RenderReuse::kNone) const;

 private:
  static constexpr int kMaxPatchesPerPixel = 8;
  // Sorted patches of a pixel's vertices (at most kMaxPatchesPerPixel: the
  // strongest pulls).
  struct PixelPatches {
    int patches[kMaxPatchesPerPixel];
    int size = 0;
  };
  // Which of a pixel's patches keep their columns (bit i: patches[i]).
  struct PatchChoice {
    PixelPatches patches;
    unsigned kept = 0;
  };
  // H_vw (3 by 3, row-major) of a vertex pair v <= w; next: v's next block.
  struct VertexBlock {
    int w = 0;
    int next = -1;
    double h[9] = {};
  };
  // One part of the rows' normal equations in the vertices' screen
  // coordinates (x, y, depth): H_vw = sum over its pixels of d_v^T d_w and
  // g_v = sum of d_v^T r, d_v a pixel's 4 by 3 derivative against vertex
  // v with its rows' scales. The parameters' normal equations are then
  // S^T H S and S^T g (S = screen_theta_), a product per vertex pair
  // instead of a rank update over the patches' blocks per pixel.
  struct PartState {
    double squared_norm = 0.0;
    std::vector<int> head;     // #V: v's first block, -1 none
    std::vector<int> touched;  // vertices with blocks, in first-touch order
    std::vector<VertexBlock> blocks;
    std::vector<double> gradient;  // 3 #V
    // The pixel being added: its vertices (first-seen order), their
    // summed 4 by 3 derivatives, and each vertex's place in that list (#V,
    // -1 none); the previous pixel's vertices and their pairs' blocks.
    std::vector<int> local, pixel_vertices, last_vertices, last_blocks;
    std::vector<double> pixel_d;
    std::vector<PatchChoice> choices;
    int last_choice = 0;
    // The dense path: one pixel's 4 Jacobian rows over its patches' blocks
    // (row-major).
    std::vector<double> rows;
  };

  // Residuals and/or Jacobians, and with `normal` each part's normal
  // equations (when the Jacobian is wanted; a pixel keeps the columns of
  // the patches PatchGroups::Find keeps, all of them without groups).
  bool Compute(const double* theta, double* residuals, double** jacobians, bool normal, bool want_jacobian,
               const PatchGroups* groups, RenderReuse render = RenderReuse::kNone) const;
  // The surface at theta (with its Jacobian against each vertex's patch
  // block, in screen coordinates: screen_theta_), rendered (with the
  // render's gradients); false when it went behind the camera.
  bool Prepare(const double* theta, bool model_jacobian, bool render_gradients) const;
  void ResetParts(int parts, double** jacobians, bool normal) const;
  // The pixel's Jacobian rows, into the dense Jacobians.
  void AddPixelJacobian(PartState* state, int pixel, int r0, double jacobian_scale, bool in_band,
                        double** jacobians) const;
  // The pixel's rows, into its part's normal equations.
  void AddPixelNormal(PartState* state, int pixel, const double* r, double jacobian_scale, bool in_band,
                      const PatchGroups* groups) const;
  // The pixel's residuals (RGB, silhouette), the scale of its RGB Jacobian
  // rows (robust loss) and whether its silhouette is within the band.
  void PixelResiduals(int y, int x, double* r, double* jacobian_scale, bool* in_band) const;
  void GatherPatches(int pixel, PixelPatches* out) const;
  unsigned ChoosePatches(PartState* state, const PixelPatches& patches, const PatchGroups* groups) const;
  void ChainPixelJacobian(int pixel, const PixelPatches& patches, int block, double* local) const;
  static int FindVertexBlock(PartState* state, int v, int w);
  // The parts' normal equations over the parameters, in part order: with
  // `slot` (patch -> block) the blocks (slot[p], slot[q]) with slot[p] <=
  // slot[q] added to, without it the whole matrix set.
  void ReduceParts(const std::vector<int>* slot, Eigen::MatrixXd* jtj, Eigen::VectorXd* jtr) const;

  Data data_;
  int channels_;
  mutable ScreenMesh screen_;
  mutable SoftRenderOutput own_render_;
  SoftRenderOutput* render_;  // own_render_ or data_.render_scratch
  mutable Eigen::Matrix3Xd vertices_;
  mutable Eigen::MatrixXd model_jacobian_, screen_jacobian_;
  mutable std::vector<double> theta_;
  // Where the render kept for RenderReuse::kReuse was made (empty: none
  // kept).
  mutable std::vector<double> kept_theta_;
  // d(x, y, depth) / d theta_p per vertex, p its patch: 3 #V by block size,
  // row-major so that a vertex's three rows are contiguous.
  mutable Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> screen_theta_;
  mutable std::vector<PartState> parts_;
  // ReduceParts' buffers: per patch a vertex reaches, sum_w H_vw S_w (3
  // rows each, row-major).
  mutable std::vector<int> reach_patches_;
  mutable Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> reach_;
};

// For each face, the patches of every vertex of the faces that share a
// vertex with it (what a pixel within a soft edge's reach of the face
// depends on, for faces of a few pixels or more), with the groups inside
// another dropped. One patch: one group.
PatchGroups MakePatchGroups(const JetDeformationModel& model, const Eigen::Matrix3Xi& faces);

// One frame's render term, its normal equations compressed by a sparse
// block Cholesky over the patches (CompressBlockSparse): the patches
// ordered by minimum degree on the graph of PatchGroups (two patches are
// adjacent when a group or an attached term holds both), one residual
// block per patch over itself and the patches after it where its factor
// row is nonzero (row_block_patches), so that a solver's J^T J has the
// pattern of the patch graph and its fill, not of every group's pairs
// again and again.
// Read from what Prepare computed at the parameters in `theta` (the
// frame's blocks, contiguous). Ceres calls Prepare through
// RenderTermCallback before every evaluation, so the frame is rendered
// and factorised once, the window's frames side by side.
class SplitRenderTerm {
 public:
  SplitRenderTerm(RenderCost::Data data, PatchGroups groups, const double* theta);
  // A term over the same frame's patches `patches` (its parameter blocks,
  // in order; no loss function) whose normal equations join the render
  // term's before the factorisation instead of being a residual block of
  // its own: a regulariser then costs the solver nothing outside the
  // frame's row blocks. Takes ownership; before the first call below.
  void Attach(ceres::CostFunction* term, std::vector<int> patches);
  // False when the surface went behind the camera or an attached term
  // failed (every row block's Evaluate then fails).
  bool Prepare(bool jacobians, bool new_point);
  int num_row_blocks() const;
  // Row block i's patches: its own first, then the later ones it reaches.
  const std::vector<int>& row_block_patches(int i) const;
  // Row block i as a residual block over row_block_patches(i); Ceres takes
  // ownership.
  ceres::CostFunction* NewRowBlockCost(int i) const;
  // Row block i's compressed residuals (block_size rows, one more for the
  // last) and its Jacobians (over row_block_patches(i)).
  bool Write(int i, double* residuals, double** jacobians) const;

 private:
  struct Attached {
    std::unique_ptr<ceres::CostFunction> term;
    std::vector<int> patches;
  };
  // The elimination order and the factor's pattern, once the terms are in.
  void Plan() const;
  // Adds the attached terms' cost and normal equations at theta_.
  bool AddAttached(bool jacobians);
  // The normal equations compressed into the factor's row blocks
  // (CompressBlockSparse), what Write hands Ceres.
  void Factorize();

  RenderCost cost_;
  PatchGroups groups_;
  const double* theta_;
  int block_size_;
  std::vector<std::vector<char>> adjacent_;  // patch by patch
  std::vector<Attached> attached_;
  mutable bool planned_ = false;
  mutable std::vector<int> slot_;                // patch -> its place in the elimination
  mutable std::vector<std::vector<int>> later_;  // per slot: the later slots its factor row reaches
  mutable std::vector<std::vector<int>> row_patches_;
  mutable std::vector<int32_t> sizes_;           // per slot: the block size
  // AddAttached's buffers, kept: Prepare runs at every evaluation.
  // Eigen-aligned: the products below peel to their alignment, and a
  // heap address that varies from run to run changed their last bits.
  std::vector<double, Eigen::aligned_allocator<double>> attached_residuals_, attached_jacobian_;
  std::vector<const double*> attached_parameters_;
  std::vector<double*> attached_blocks_;
  bool ok_ = false, have_jacobians_ = false;
  double squared_norm_ = 0.0;
  // The normal equations in slot order (the pattern's upper blocks only),
  // factorised in place by Prepare where it computed them (Factorize).
  Eigen::MatrixXd jtj_;
  Eigen::VectorXd jtr_;
  std::vector<Eigen::MatrixXd> rows_;  // per slot: the factor's row block
  Eigen::VectorXd residuals_;
};

// Prepares every SplitRenderTerm of a problem before Ceres evaluates it,
// the frames side by side on num_threads threads (0: all), as Ceres would
// evaluate their residual blocks.
class RenderTermCallback : public ceres::EvaluationCallback {
 public:
  explicit RenderTermCallback(int num_threads = 1) : num_threads_(num_threads) {}
  void Add(SplitRenderTerm* term) { terms_.push_back(term); }
  void PrepareForEvaluation(bool evaluate_jacobians, bool new_evaluation_point) override;

 private:
  int num_threads_;
  std::vector<SplitRenderTerm*> terms_;
};

// RenderCost compressed (cost_functions/compressed_cost.h) from its normal
// equations: what the solver uses for one patch.
class CompressedRenderCost : public NormalEquationsCost {
 public:
  explicit CompressedRenderCost(RenderCost::Data data);
  bool EvaluateNormalEquations(double const* const* parameters, double* squared_norm, Eigen::MatrixXd* jtj,
                               Eigen::VectorXd* jtr) const override;

 private:
  RenderCost cost_;
  mutable std::vector<double> theta_;
};

// A term on a few vertices at a time (N: an edge's 2, a hinge's 4) over
// vertices of `patches` (those of the tuples' vertices, sorted): one
// residual per tuple, functors[t](x_1, .., x_N, &r) (a cost_functions/
// functor); parameter blocks, those patches' blocks.
template <int N, typename Functor>
class VertexTupleCost : public ceres::CostFunction {
 public:
  VertexTupleCost(const JetDeformationModel* model, const std::vector<int>& patches,
                  const std::vector<std::array<int, N>>& tuples, std::vector<Functor> functors);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  const JetDeformationModel* model_;
  std::vector<int> patches_;
  std::vector<int> vertices_;               // the tuples' vertices
  std::vector<int> slots_;                  // per vertex of vertices_, its patch's block among patches_
  std::vector<std::array<int, N>> tuples_;  // into vertices_
  std::vector<Functor> functors_;
  mutable Eigen::Matrix3Xd positions_;
  mutable Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> jacobian_;  // 3 per vertex
};

// Edge inextensibility (EdgeInextensibilityResidual, weight w, robust
// above the strain robust_strain; 0: squared) over edges.
class InextensibilityCost : public VertexTupleCost<2, EdgeInextensibilityResidual> {
 public:
  InextensibilityCost(const JetDeformationModel* model, const std::vector<int>& patches,
                      const std::vector<Eigen::Vector2i>& edges, const std::vector<double>& rest_lengths,
                      double weight, double robust_strain = 0.0);
};

// Bending (HingeBendingResidual) over hinges (i, j, k, l), each with its
// rest angle and weight.
class BendingCost : public VertexTupleCost<4, HingeBendingResidual> {
 public:
  BendingCost(const JetDeformationModel* model, const std::vector<int>& patches,
              const std::vector<std::array<int, 4>>& hinges, const std::vector<double>& rest_angles,
              const std::vector<double>& weights);
};

// The silhouette's long reach: every vertex of patch p projects inside the
// object's outline,
//   r_i = w max(0, D(pi(X_i)) - tolerance) / sqrt(#V),
// D = OutsideDistance(mask, margin) (px), sampled bilinearly. Zero while the surface is inside
// the outline; it pulls a surface the coverage term no longer sees (that
// term's gradient lives within the soft rasterizer's blur of the
// silhouette) from anywhere in the image. The 1 / sqrt(#V) makes the cost
// w^2 / 2 times the mean squared distance, whatever the mesh's resolution.
// One parameter block: patch p's.
class SilhouetteReachCost : public ceres::CostFunction {
 public:
  // outside_distance: OutsideDistance(mask, margin).
  SilhouetteReachCost(const JetDeformationModel* model, int patch, const PinholeCamera& camera,
                      const cv::Mat& outside_distance, int margin, double tolerance, double weight);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  const JetDeformationModel* model_;
  int patch_;
  std::vector<int> vertices_;
  PinholeCamera camera_;
  cv::Mat distance_;  // CV_32F
  int margin_;
  double tolerance_, weight_;
};

// A frame's keypoint correspondences (texture_features.h): each surface
// point, at barycentric b of face f, projects where the frame shows it,
//   e_j = pi(sum_k b_k X_{f_k}) - m_j                   (pixels)
//   r_j = L(|e_j|) e_j / |e_j|                          2 residuals each
// with L(l) = 0 within a dead zone d (a keypoint's own error), then
// m = w (l - d), Huber beyond a: L = m for m <= a, sqrt(2 a m - a^2) past it
// (so that |r_j|^2 is the Huber cost of m: a mismatch pulls with a bounded
// force). Continuous with its gradient. Each corner X_{f_k} comes from its
// own patch's block. One cost for the frame's keypoints, summed in a fixed
// order whatever the threads. Parameter blocks: the distinct patches of
// every keypoint's corners, in increasing order (patches()).
class FeatureCost : public ceres::CostFunction {
 public:
  struct Point {
    Eigen::Vector3i corners;      // vertices of the face
    Eigen::Vector3d barycentric;  // over them
    Eigen::Vector2d pixel;        // where the frame shows it
  };
  FeatureCost(const JetDeformationModel* model, std::vector<Point> points, const PinholeCamera& camera, double weight,
              double dead_zone, double huber);
  const std::vector<int>& patches() const { return patches_; }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  const JetDeformationModel* model_;
  std::vector<Point> points_;
  PinholeCamera camera_;
  double weight_, dead_zone_, huber_;
  std::vector<int> patches_;
  // Per point and corner: the index into patches_ of the corner's patch.
  std::vector<Eigen::Vector3i> corner_blocks_;
  // Each corner's d X / d theta (3 by block size, row-major), reused.
  mutable Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor> corner_jacobians_[3];
};

// D at pixel (x, y) of `distance` (pixel centres at integers), bilinear,
// and its gradient; beyond it, the border's value plus the distance to it.
double SampleOutsideDistance(const cv::Mat& distance, double x, double y, Eigen::Vector2d* gradient);

// Temporal smoothness of patch p's vertices over the frames before,
//   order 1: r = (w / L) (x_t - x_t-1)                (the paper's k_tc term,
//            TemporalConsistencyResidual: consecutive frames close)
//   order 2: r = (w / L) (x_t - (1 + b) x_t-1 + b x_t-2 - s)  (each frame
//            where the frame before carries on at b times its velocity,
//            moved by s; b = `velocity`, 1 by default: on the line through
//            the two before, constant velocity, inertia; with s = g dt^2,
//            InertiaResidual's target with gravity folded in, where a free
//            fall goes; b < 1: a damped inertia)
// 3 residuals per vertex of the patch. The earlier frames are parameter
// blocks (patch p's block of frame t-1, then of t-2) except the oldest
// `fixed.size()` of them, given as data (3 by #V each, the most recent
// first): frames before the window. Parameter blocks: this frame's, then
// the earlier frames' that are not fixed. `only`: the vertices of the
// patch it holds (empty: all of them).
class TemporalCost : public ceres::CostFunction {
 public:
  TemporalCost(const JetDeformationModel* model, int patch, double length_scale, double weight, int order,
               const std::vector<const Eigen::Matrix3Xd*>& fixed,
               const Eigen::Vector3d& shift = Eigen::Vector3d::Zero(), const std::vector<int>& only = {},
               double velocity = 1.0);
  // Order 1; `previous` given: the earlier frame is data.
  TemporalCost(const JetDeformationModel* model, int patch, double length_scale, double weight,
               const Eigen::Matrix3Xd* previous = nullptr);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  const JetDeformationModel* model_;
  int patch_;
  std::vector<int> vertices_;
  double scale_;
  // Per frame t, t-1, ...: its coefficient; the fixed frames' sum, per
  // vertex of vertices_.
  std::vector<double> coefficients_;
  int num_free_;  // frames that are parameter blocks (t included)
  Eigen::Matrix3Xd fixed_sum_;
};

// Continuity across the seam of patches a < b (the paper's eq. 5 on this
// model, as cost_functions/patch_boundary_residual.h): the middle of each
// template edge from one patch to the other is where both patches put it,
// with the same normal,
//   r = (w_x (X_a(m) - X_b(m)) / L, w_n (n_a(m) - n_b(m)))       6 per edge
// (L: the template's mean edge length). Each patch reaches half an edge
// past its own vertices, so two patches that meet at an angle along the
// edges' middles (a fold on the seam) cost nothing, and a gap or a shear
// costs its length in edges; at a split both are zero, children starting
// as their parent (the Jacobian chained by hand from one jet per edge
// and side: JetDeformationModel::EdgeMidpointJacobian).
// Parameter blocks: a's, b's.
ceres::CostFunction* CreateSeamCost(const JetDeformationModel* model, int patch_a, int patch_b,
                                    const std::vector<Eigen::Vector2i>& seam_edges, double length_scale,
                                    double position_weight, double normal_weight);

// The uv fields of patches a and b alike (their compact fields'
// coefficients): r = w (duv_a - duv_b), so that patches share how the
// surface slides and differ in shape and pose. With robust_scale b > 0, r
// is scaled to the pseudo-Huber penalty of the difference d = duv_a -
// duv_b (pseudo_huber.h): w^2 |d|^2 below b, 2 w^2 b |d| above. The fields
// then stay one while what pulls them apart is weaker than w^2 b, and a
// seam across which the images ask them to differ (a fold) is let go at
// that constant pull. Throws std::invalid_argument for weight <= 0 or b < 0
// (or not finite). Parameter blocks: a's, b's.
ceres::CostFunction* CreateSharedUvCost(const JetDeformationModel* model, double weight, double robust_scale = 0.0);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SOLVER_FRAME_COSTS_H_
