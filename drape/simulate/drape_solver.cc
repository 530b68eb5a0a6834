#include "drape/simulate/drape_solver.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <vector>

#include <ceres/autodiff_cost_function.h>
#include <ceres/ceres.h>

#include "cost_functions/jet_order_dispatch.h"
#include "cost_functions/patch_boundary_residual.h"
#include "drape/collision/signed_distance.h"
#include "drape/losses/skinned_patch_costs.h"
#include "drape/simulate/drape_solver_impl.h"
#include "drape/simulate/strain_limit.h"
#include "polyfit/jet/jet_surface.h"
#include "polyfit/mesh/unique_edges.h"
#include "polyfit/model/orient_patches.h"
#include "polyfit/pipeline/adaptive_patches.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {
namespace {

double Seconds(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

TerminationType FromCeres(ceres::TerminationType type) {
  switch (type) {
    case ceres::CONVERGENCE:
    case ceres::USER_SUCCESS: return TerminationType::kConvergence;
    case ceres::NO_CONVERGENCE: return TerminationType::kNoConvergence;
    default: return TerminationType::kFailure;
  }
}

// The garment's patches: ACVD clusters sized by area, split where a jet
// cannot hold them, oriented like their faces (the boundary term compares
// normals).
PolyFitModel PatchGarment(const TriangleMesh& mesh, const GarmentPatchOptions& patching, int num_threads) {
  AdaptivePatchOptions options;
  options.clustering.num_patches = 0;  // the area rule, unclamped
  options.clustering.auto_area_per_patch = patching.patch_area;
  options.clustering.auto_min_patches = 1;
  options.clustering.auto_max_patches = std::max(1, mesh.num_faces());
  options.clustering.seed = patching.seed;
  options.face_subdivisions = patching.face_subdivisions;
  options.curved_faces = patching.curved_faces;
  options.jet.order = patching.jet_order;
  options.jet.num_threads = num_threads;
  options.max_fit_error = patching.max_fit_error;
  options.max_splits = patching.max_splits;
  PolyFitModel model = FitAdaptivePatches(options, mesh);
  OrientPatchesLikeFaces(mesh, &model);
  if (patching.align_frames) AlignPatchFrames(Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(), &model);
  return model;
}

// X = A^-1 B for a small symmetric positive definite A, by a plain
// Cholesky: Eigen's dense decompositions share their blocked kernels'
// symbols with the statically linked Ceres, built for another instruction
// set, and instantiating them here corrupted Ceres' sparse Cholesky.
Eigen::MatrixXd SolveSmallSpd(Eigen::MatrixXd a, Eigen::MatrixXd b) {
  const Eigen::Index n = a.rows();
  for (Eigen::Index j = 0; j < n; ++j) {
    for (Eigen::Index k = 0; k < j; ++k) a(j, j) -= a(j, k) * a(j, k);
    a(j, j) = std::sqrt(std::max(a(j, j), 1e-300));
    for (Eigen::Index i = j + 1; i < n; ++i) {
      for (Eigen::Index k = 0; k < j; ++k) a(i, j) -= a(i, k) * a(j, k);
      a(i, j) /= a(j, j);
    }
  }
  for (Eigen::Index c = 0; c < b.cols(); ++c) {
    for (Eigen::Index i = 0; i < n; ++i) {  // L y = b
      for (Eigen::Index k = 0; k < i; ++k) b(i, c) -= a(i, k) * b(k, c);
      b(i, c) /= a(i, i);
    }
    for (Eigen::Index i = n - 1; i >= 0; --i) {  // L^T x = y
      for (Eigen::Index k = i + 1; k < n; ++k) b(i, c) -= a(k, i) * b(k, c);
      b(i, c) /= a(i, i);
    }
  }
  return b;
}

}  // namespace

DrapeSolveOptions::DrapeSolveOptions() {
  // Each solve is a few iterations of a warm-started frame: never stop on
  // a small relative change of the cost.
  ceres.function_tolerance = 1e-12;
  ceres.parameter_tolerance = 1e-12;
  ceres.logging_type = ceres::SILENT;
  // Measured faster than CHOLMOD on the garments' normal equations.
  ceres.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;
}

std::string DrapeSolverOptions::Validate() const {
  const DrapePhysicsOptions& p = physics;
  if (patching.jet_order < 1 || patching.jet_order > kMaxJetOrder) {
    return "patching.jet_order must be in [1, " + std::to_string(kMaxJetOrder) + "]";
  }
  if (!(patching.patch_area > 0.0) || !std::isfinite(patching.patch_area)) {
    return "patching.patch_area must be positive";
  }
  if (patching.face_subdivisions < 0 || patching.face_subdivisions > 16) {
    return "patching.face_subdivisions must be in [0, 16]";
  }
  if (!(patching.max_fit_error > 0.0) || patching.max_splits < 0) {
    return "patching.max_fit_error must be > 0 and patching.max_splits >= 0";
  }
  if (!(p.fps > 0.0) || !std::isfinite(p.fps)) return "physics.fps must be positive";
  if (solve.max_iterations < 1 || solve.max_refine_iterations < 1 || solve.max_passes < 1) {
    return "solve.max_iterations, solve.max_refine_iterations and solve.max_passes must be >= 1";
  }
  if (!(solve.initial_trust_region_radius > 0.0) || !std::isfinite(solve.initial_trust_region_radius)) {
    return "solve.initial_trust_region_radius must be positive and finite";
  }
  if (!(solve.conjugate_gradients_tolerance > 0.0 && solve.conjugate_gradients_tolerance < 1.0)) {
    return "solve.conjugate_gradients_tolerance must be in (0, 1)";
  }
  if (solve.max_conjugate_gradients_iterations < 1) return "solve.max_conjugate_gradients_iterations must be >= 1";
  if (slide.warp_order < -1 || slide.warp_order > kMaxJetOrder) {
    return "slide.warp_order must be in [-1, " + std::to_string(kMaxJetOrder) + "]";
  }
  if (slide.warp_order >= 0 && !slide.enabled) return "slide.warp_order needs slides (slide.enabled)";
  if (num_threads < 1) return "num_threads must be >= 1";
  for (const double w :
       {p.weights.boundary, p.weights.inextensibility, p.weights.gravity, p.weights.collision, p.weights.inertia,
        p.weights.collision_margin, p.collision_stiffness, p.boundary_base, p.stretch_base, p.collision_band,
        solve.parameter_prior, slide.agreement, p.gravity, p.material.area_density, p.material.mu}) {
    if (!std::isfinite(w) || w < 0.0) return "weights, stiffnesses and material constants must be finite and >= 0";
  }
  if (!(p.material.area_density > 0.0)) return "physics.material.area_density must be positive";
  if (!(p.stretch_factor > 0.0) || !std::isfinite(p.stretch_factor)) {
    return "physics.stretch_factor must be finite and positive (1: symmetric)";
  }
  if (std::isnan(p.margin_floor) || p.margin_floor > p.weights.collision_margin) {
    return "physics.margin_floor must be at most the collision margin (< 0: off)";
  }
  return {};
}

std::string DrapeStepSummary::BriefReport() const {
  char line[256];
  std::snprintf(line, sizeof(line), "%s: %d passes, %d iterations, cost %.4g -> %.4g, %d collision terms, %.1f ms%s%s",
                TerminationTypeToString(termination_type), passes, iterations, initial_cost, final_cost,
                collision_terms, 1e3 * time_s, message.empty() ? "" : ": ", message.c_str());
  return line;
}

void DrapeSolver::Impl::InitializeParameters(const PolyFitModel& model) {
  num_coefficients = NumJetCoefficients(options.patching.jet_order);
  params.assign(static_cast<size_t>(model.num_patches()) * kStride, 0.0);
  for (int p = 0; p < model.num_patches(); ++p) {
    const JetPatch& patch = model.patches[p];
    for (int k = 0; k < NumJetCoefficients(patch.order); ++k) alpha(p)[k] = patch.coefficients[k];
    scale(p)[0] = patch.frame.scale;
    Eigen::Map<Eigen::Vector3d>(translation(p)) = patch.frame.translation;
  }
  previous_params = params;
  rest_params = params;
  slides.assign(2 * model.num_memberships(), 0.0);
  previous_slides = slides;
  membership_vertex.resize(model.num_memberships());
  for (int v = 0; v < model.num_vertices(); ++v) {
    for (int k : model.memberships(v)) membership_vertex[k] = v;
  }
  // The warp's monomials in (u, v) / r_p, r_p the patch's largest |(u, v)|,
  // times r_p: each coefficient moves a patch's points by up to its value
  // times the patch's extent, whatever the patch's size and order (raw
  // monomials needed coefficients in the hundreds at order 4).
  warp_radius.assign(model.num_patches(), 0.0);
  for (int k = 0; k < model.num_memberships(); ++k) {
    double& r = warp_radius[model.membership_patch[k]];
    r = std::max(r, model.membership_uv.col(k).norm());
  }
  for (double& r : warp_radius) r = std::max(r, 1e-9);
  num_warp = NumJetCoefficients(options.slide.warp_order);
  warp_basis.resize(static_cast<size_t>(num_warp) * model.num_memberships());
  if (num_warp == 0) return;
  for (int k = 0; k < model.num_memberships(); ++k) {
    const double r = warp_radius[model.membership_patch[k]];
    double* phi = warp_basis.data() + num_warp * k;
    JetMonomials(options.slide.warp_order, model.membership_uv(0, k) / r, model.membership_uv(1, k) / r, phi);
    for (int i = 0; i < num_warp; ++i) phi[i] *= r;
  }
}

// Every face whose corners' (u, v) on its patch span a triangle, with
// g0 = s^2 (E, F, G) at its centroid.
void DrapeSolver::Impl::CollectFaceMetrics(const PolyFitModel& model) {
  face_metrics.clear();
  const int order = options.patching.jet_order;
  for (int f = 0; f < model.faces.cols(); ++f) {
    FaceMetric m;
    m.face = f;
    m.patch = model.face_patch[f];
    bool found = true;
    for (int c = 0; c < 3; ++c) {
      m.membership[c] = model.FindMembership(model.faces(c, f), m.patch);
      found = found && m.membership[c] >= 0;
      if (found) m.uv.col(c) = model.membership_uv.col(m.membership[c]);
    }
    if (!found) continue;
    const Eigen::Vector2d e1 = m.uv.col(1) - m.uv.col(0), e2 = m.uv.col(2) - m.uv.col(0);
    const double extent = std::max(e1.squaredNorm(), e2.squaredNorm());
    // A face seen edge-on from its patch's plane holds no metric.
    if (!(std::abs(e1.x() * e2.y() - e1.y() * e2.x()) > 1e-6 * extent)) continue;
    const Eigen::Vector2d centroid = m.uv.rowwise().mean();
    const FundamentalForm<double> I =
        JetFirstFundamentalForm(EvaluateJetDerivatives(order, alpha(m.patch), centroid.x(), centroid.y()));
    m.rest_metric = scale(m.patch)[0] * scale(m.patch)[0] * Eigen::Vector3d(I.e, I.f, I.g);
    face_metrics.push_back(m);
  }
}

void DrapeSolver::Impl::BuildPoints(const PolyFitModel& model) {
  points.clear();
  points.reserve(model.num_memberships());
  for (int k = 0; k < model.num_memberships(); ++k) {
    const int v = membership_vertex[k];
    points.emplace_back(options.patching.jet_order, model.membership_uv(0, k), model.membership_uv(1, k),
                        model.patches[model.membership_patch[k]].frame.rotation, &skin_linear[v], &skin_translation[v]);
  }
}

// Every edge once per patch that holds it (both ends on the patch), and
// each unique edge's area: a third of its faces'.
void DrapeSolver::Impl::CollectPatchEdges(const PolyFitModel& model) {
  const Eigen::Matrix2Xi edges = UniqueEdges(rest.faces);
  // The same order as rest.edges (both sorted by (i, j)): edge_length reads it.
  if (edges.cols() != static_cast<Eigen::Index>(rest.edges.size())) {
    throw std::logic_error("DrapeSolver: the rest garment's edges disagree");
  }
  edge_area.assign(edges.cols(), 0.0);
  std::vector<std::pair<int, int>> seen;  // (edge, patch)
  for (int f = 0; f < rest.faces.cols(); ++f) {
    const int p = model.face_patch[f];
    for (int c = 0; c < 3; ++c) {
      const int e = FindEdge(edges, rest.faces(c, f), rest.faces((c + 1) % 3, f));
      edge_area[e] += rest.face_area[f] / 3.0;
      seen.emplace_back(e, p);
    }
  }
  // In order of first appearance (the term order is the problem's).
  std::vector<std::pair<int, int>> sorted = seen;
  std::sort(sorted.begin(), sorted.end());
  std::vector<bool> taken(sorted.size(), false);
  patch_edges.clear();
  for (const auto& [e, p] : seen) {
    const size_t i = std::lower_bound(sorted.begin(), sorted.end(), std::make_pair(e, p)) - sorted.begin();
    if (taken[i]) continue;
    taken[i] = true;
    const int mi = model.FindMembership(edges(0, e), p), mj = model.FindMembership(edges(1, e), p);
    if (mi >= 0 && mj >= 0) patch_edges.push_back({e, mi, mj});
  }
  mean_edge = 0.0;
  for (double length : rest.edge_length) mean_edge += length / static_cast<double>(rest.edge_length.size());
}

// Boundary points and the gaps the fits leave there at rest, kept rather
// than closed (PatchBoundaryCost's d_x, d_n).
void DrapeSolver::Impl::CollectBoundary(const PolyFitModel& model) {
  boundary = model.BoundaryPoints();
  for (const PatchBoundaryPoint& b : boundary) {
    const JetPatch& pa = model.patches[b.patch_a];
    const JetPatch& pb = model.patches[b.patch_b];
    boundary_position_gap.push_back(pa.PointInWorld(b.uv_a.x(), b.uv_a.y()) - pb.PointInWorld(b.uv_b.x(), b.uv_b.y()));
    boundary_normal_gap.push_back(pa.NormalInWorld(b.uv_a.x(), b.uv_a.y()) - pb.NormalInWorld(b.uv_b.x(), b.uv_b.y()));
  }
}

void DrapeSolver::Impl::BuildProblem(const PolyFitModel& model) {
  problem = std::make_unique<ceres::Problem>();
  direct_blocks.clear();  // they pointed into the old problem
  for (int p = 0; p < model.num_patches(); ++p) {
    problem->AddParameterBlock(alpha(p), num_coefficients);
    problem->AddParameterBlock(scale(p), 1);
    problem->AddParameterBlock(translation(p), 3);
  }
  for (int k = 0; k < model.num_memberships(); ++k) {
    problem->AddParameterBlock(slide(k), 2);
    if (!options.slide.enabled) problem->SetParameterBlockConstant(slide(k));
  }
  AddVertexTerms(model);
  AddMetricTerms(model);
  AddEdgeTerms(model);
  AddBoundaryTerms(model);
  AddSlideTerms(model);
  AddPriors(model);
}

// At every membership: collision (off while far from the body); at the
// owner also the motion (inertia with gravity folded in, or gravity alone).
void DrapeSolver::Impl::AddVertexTerms(const PolyFitModel& model) {
  const DrapePhysicsOptions& o = options.physics;
  const VertexMotion motion = o.weights.inertia > 0.0 ? VertexMotion::kInertia : VertexMotion::kGravity;
  vertex_data.assign(model.num_memberships(), VertexTermsData{});
  for (int v = 0; v < model.num_vertices(); ++v) {
    const IndexRange range = model.memberships(v);
    for (int k : range) {
      const int p = model.membership_patch[k];
      problem->AddResidualBlock(
          new SkinnedVertexCost(points[k], &vertex_data[k], k == range.front() ? motion : VertexMotion::kNone), nullptr,
          alpha(p), scale(p), translation(p), slide(k));
    }
  }
}

// The metric tensor per face, with the slides' warp.
void DrapeSolver::Impl::AddMetricTerms(const PolyFitModel& model) {
  const DrapePhysicsOptions& o = options.physics;
  const int order = options.patching.jet_order;
  for (const FaceMetric& m : face_metrics) {
    const double weight = std::sqrt(stretch_weight() * o.material.mu * rest.face_area[m.face] / 2.0);
    if (!(weight > 0.0)) continue;
    const Eigen::Matrix3d* skinning[3];
    const double* k[3];
    for (int c = 0; c < 3; ++c) {
      const int v = membership_vertex[m.membership[c]];
      skinning[c] = &skin_linear[v];
      k[c] = &k_ext[v];
    }
    auto* cost = new SkinnedFaceMetricCost(order, m.uv, m.rest_metric, model.patches[m.patch].frame.rotation, skinning,
                                           k, weight, o.stretch_factor);
    problem->AddResidualBlock(cost, nullptr, alpha(m.patch), scale(m.patch), slide(m.membership[0]),
                              slide(m.membership[1]), slide(m.membership[2]));
  }
}

void DrapeSolver::Impl::AddEdgeTerms(const PolyFitModel& model) {
  if (!(stretch_weight() > 0.0)) return;
  for (const PatchEdge& e : patch_edges) {
    const int p = model.membership_patch[e.mi];
    const double weight = std::sqrt(2.0 * stretch_weight() * options.physics.material.mu * edge_area[e.edge]);
    problem->AddResidualBlock(new SkinnedEdgeCost(points[e.mi], points[e.mj], rest.edge_length[e.edge], weight,
                                                  options.physics.stretch_factor),
                              nullptr, alpha(p), scale(p), translation(p), slide(e.mi), slide(e.mj));
  }
}

void DrapeSolver::Impl::AddBoundaryTerms(const PolyFitModel& model) {
  const DrapePhysicsOptions& o = options.physics;
  if (!(o.weights.boundary > 0.0)) return;
  for (size_t i = 0; i < boundary.size(); ++i) {
    const PatchBoundaryPoint& b = boundary[i];
    const double w = std::sqrt(2.0 * o.weights.boundary * o.boundary_base * o.material.mu * rest.vertex_area[b.vertex]);
    problem->AddResidualBlock(
        PatchBoundaryCost::Create(options.patching.jet_order, b.uv_a, model.patches[b.patch_a].frame.rotation, b.uv_b,
                                  model.patches[b.patch_b].frame.rotation, w / mean_edge, w, boundary_position_gap[i],
                                  boundary_normal_gap[i]),
        nullptr, alpha(b.patch_a), scale(b.patch_a), translation(b.patch_a), alpha(b.patch_b), scale(b.patch_b),
        translation(b.patch_b));
  }
}

// A vertex's points on its patches slide apart unless held together (the
// boundary term compares the jets at the rest parameters).
void DrapeSolver::Impl::AddSlideTerms(const PolyFitModel& model) {
  if (!options.slide.enabled) return;
  for (int v = 0; v < model.num_vertices(); ++v) {
    const IndexRange range = model.memberships(v);
    const int first = range.front();
    const double w = std::sqrt(2.0 * stretch_weight() * options.physics.material.mu * rest.vertex_area[v]) *
                     options.slide.agreement / mean_edge;
    for (int k : range) {
      if (k == first) continue;
      const int a = model.membership_patch[first], b = model.membership_patch[k];
      const Eigen::Vector3d gap =
          points[first].Canonical(points[first].State(alpha(a), nullptr), scale(a), translation(a)) -
          points[k].Canonical(points[k].State(alpha(b), nullptr), scale(b), translation(b));
      problem->AddResidualBlock(new SkinnedAgreementCost(points[first], points[k], gap, w), nullptr, alpha(a), scale(a),
                                translation(a), slide(first), alpha(b), scale(b), translation(b), slide(k));
    }
  }
}

void DrapeSolver::Impl::AddPriors(const PolyFitModel& model) {
  if (!(options.solve.parameter_prior > 0.0)) return;
  const double w = std::sqrt(options.solve.parameter_prior);
  for (int p = 0; p < model.num_patches(); ++p) {
    for (const auto& [block, size] :
         {std::pair<int, int>{0, num_coefficients}, {kMaxJetCoefficients, 1}, {kMaxJetCoefficients + 1, 3}}) {
      problem->AddResidualBlock(new ParameterPrior(size, w, previous_params.data() + p * kStride + block), nullptr,
                                params.data() + p * kStride + block);
    }
  }
  if (!options.slide.enabled) return;
  for (int k = 0; k < model.num_memberships(); ++k) {
    problem->AddResidualBlock(new ParameterPrior(2, w, previous_slides.data() + 2 * k), nullptr, slide(k));
  }
}

void DrapeSolver::Impl::Positions(const PolyFitModel& model, Eigen::Matrix3Xd* out) {
  for (int v = 0; v < out->cols(); ++v) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    const IndexRange range = model.memberships(v);
    for (int k : range) {
      const int p = model.membership_patch[k];
      sum += points[k].Position(alpha(p), scale(p), translation(p), slide(k));
    }
    out->col(v) = sum / range.size();
  }
}

void DrapeSolver::Impl::PositionsOfPacked(const PolyFitModel& model, const std::vector<double>& packed,
                                          Eigen::Matrix3Xd* out) const {
  CheckPackedSize(packed);
  const int stride = packed_stride();
  // Skinning is affine and each vertex's own: its memberships' canonical
  // points are averaged first and skinned once, M mean(X) + b = mean(M X
  // + b), with the jet's order a compile-time constant.
  const auto canonical_means = [&](auto order) {
    constexpr int kOrder = decltype(order)::value;
    for (int v = 0; v < out->cols(); ++v) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      const IndexRange range = model.memberships(v);
      for (int k : range) {
        const double* in = packed.data() + model.membership_patch[k] * stride;
        double slide[2];
        WarpSlide(k, in + num_coefficients + 4, slide);
        sum += points[k].CanonicalOf<kOrder>(in, in + num_coefficients, in + num_coefficients + 1, slide);
      }
      // One division a vertex, not one a coordinate (the three divisions'
      // latency was most of this loop), in scalars: Eigen's expression here
      // is not always inlined.
      const double inverse = 1.0 / range.size();
      const double x = inverse * sum[0], y = inverse * sum[1], z = inverse * sum[2];
      const Eigen::Matrix3d& m = skin_linear[v];
      const Eigen::Vector3d& b = skin_translation[v];
      double* o = out->col(v).data();
      for (int r = 0; r < 3; ++r) o[r] = m(r, 0) * x + m(r, 1) * y + m(r, 2) * z + b[r];
    }
  };
  switch (options.patching.jet_order) {
    case 2: canonical_means(std::integral_constant<int, 2>{}); break;
    case 3: canonical_means(std::integral_constant<int, 3>{}); break;
    case 4: canonical_means(std::integral_constant<int, 4>{}); break;
    case 5: canonical_means(std::integral_constant<int, 5>{}); break;
    case 6: canonical_means(std::integral_constant<int, 6>{}); break;
    default: canonical_means(std::integral_constant<int, -1>{}); break;
  }
}

void DrapeSolver::Impl::CheckPackedSize(const std::vector<double>& packed) const {
  const size_t expected = params.size() / kStride * packed_stride();
  if (packed.size() != expected) {
    throw std::invalid_argument("DrapeSolver: " + std::to_string(packed.size()) + " patch parameters, expected " +
                                std::to_string(expected));
  }
}

void DrapeSolver::Impl::BlendGarmentSkin(const std::vector<Eigen::Isometry3d>& rest_to_posed) {
  JointMaps(rest_to_posed, &joint_affine);
  for (int v = 0; v < static_cast<int>(skin_linear.size()); ++v) {
    const Eigen::Matrix<double, 3, 4> blended = weights.Blend(v, joint_affine);
    skin_linear[v] = blended.leftCols<3>();
    skin_translation[v] = blended.col(3);
  }
}

int DrapeSolver::Impl::QueryContacts(const Eigen::Matrix3Xd& positions) {
  const int n = static_cast<int>(positions.cols());
  // The last answer bounds the search: a vertex moves little between
  // iterations and frames.
  ParallelFor(n, options.num_threads,
              [&](int, int v) { contact[v] = distance.Query(positions.col(v), contact[v].face); });
  int inside = 0;
  for (int v = 0; v < n; ++v) inside += contact[v].distance < 0.0 ? 1 : 0;
  return inside;
}

void DrapeSolver::Impl::PoseBodyAndGarment(const std::vector<Eigen::Isometry3d>& rest_to_posed,
                                           Eigen::Matrix3Xd* body_vertices) {
  *body_vertices = SkinVertices(body, rest_to_posed);
  distance.SetVertices(*body_vertices);
  nearest_stale = true;
  BlendGarmentSkin(rest_to_posed);
}

// Inertia's target (constant velocity over the last two frames, gravity
// folded in) at each vertex's owner membership.
void DrapeSolver::Impl::SetMotionTargets(const PolyFitModel& model) {
  const DrapePhysicsOptions& o = options.physics;
  const double dt = 1.0 / o.fps;
  for (int v = 0; v < model.num_vertices(); ++v) {
    VertexTermsData& data = vertex_data[model.memberships(v).front()];
    if (o.weights.inertia > 0.0) {
      data.inertia.emplace(history1.col(v), history2.col(v), mass[v], dt, o.weights.inertia, o.weights.gravity,
                           o.gravity, Eigen::Vector3d::UnitY());
    } else if (o.weights.gravity > 0.0) {
      data.gravity.emplace(mass[v], o.gravity, Eigen::Vector3d::UnitY(), floor, o.weights.gravity);
    }
  }
}

// Collision terms at the vertices within the band, linearised at their
// closest body points, and each vertex's k_ext from its depth; returns how
// many membership terms are on.
int DrapeSolver::Impl::LinearizeCollisions(const PolyFitModel& model) {
  const DrapePhysicsOptions& o = options.physics;
  const double weight = std::sqrt(o.weights.collision * o.collision_stiffness);
  int terms = 0;
  for (int v = 0; v < model.num_vertices(); ++v) {
    k_ext[v] = o.k_ext(-contact[v].distance, epoch);
    const bool near = o.weights.collision > 0.0 && contact[v].distance < o.collision_band;
    for (int k : model.memberships(v)) {
      VertexTermsData& data = vertex_data[k];
      if (near) {
        data.collision.emplace(contact[v].closest, contact[v].normal, margin[v], weight, 2);
      } else {
        data.collision.reset();
      }
      terms += near ? 1 : 0;
    }
  }
  return terms;
}

ceres::Solver::Options DrapeSolver::Impl::SolverOptions(int pass, int num_vertices) const {
  const DrapeSolveOptions& o = options.solve;
  ceres::Solver::Options solver = o.ceres;
  const bool cg = o.linear_solver == DrapeLinearSolver::kConjugateGradients ||
                  (o.linear_solver == DrapeLinearSolver::kAuto && num_vertices >= o.conjugate_gradients_min_vertices);
  if (cg) {
    // Inexact steps: half the time of a sparse Cholesky on the 2k-vertex
    // suit, where forming and factoring J^T J over ~8k parameters
    // dominates. CG resolves the soft, rigid-like modes last.
    solver.linear_solver_type = ceres::CGNR;
    solver.eta = o.conjugate_gradients_tolerance;
    solver.max_linear_solver_iterations = o.max_conjugate_gradients_iterations;
  } else {
    solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  }
  solver.max_num_iterations = pass == 0 ? o.max_iterations : o.max_refine_iterations;
  solver.num_threads = options.num_threads;
  solver.logging_type = o.trace >= 2 ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  solver.minimizer_progress_to_stdout = o.trace >= 2;
  // Weakly determined directions (slides, the jets of small patches) make
  // the Gauss-Newton step huge: starting undamped, LM spent about eight
  // rejected iterations per solve shrinking its region.
  solver.initial_trust_region_radius = trust_region_radius;
  return solver;
}

void DrapeSolver::Impl::SetPatchParameters(const PolyFitModel& model, const std::vector<double>& packed) {
  CheckPackedSize(packed);
  const int stride = packed_stride();
  const int num_patches = static_cast<int>(params.size() / kStride);
  for (int p = 0; p < num_patches; ++p) {
    const double* in = packed.data() + p * stride;
    std::copy(in, in + num_coefficients, alpha(p));
    scale(p)[0] = in[num_coefficients];
    std::copy(in + num_coefficients + 1, in + num_coefficients + 4, translation(p));
  }
  for (int k = 0; k < model.num_memberships(); ++k) {
    WarpSlide(k, packed.data() + model.membership_patch[k] * stride + num_coefficients + 4, slide(k));
  }
}

void DrapeSolver::Impl::WarpSlide(int k, const double* warp, double slide[2]) const {
  const double* phi = warp_monomials(k);
  slide[0] = slide[1] = 0.0;
  for (int i = 0; i < num_warp; ++i) {
    slide[0] += warp[i] * phi[i];
    slide[1] += warp[num_warp + i] * phi[i];
  }
}

std::vector<double> DrapeSolver::Impl::PackedPatchParameters(const std::vector<double>& strided) const {
  const int stride = packed_stride();
  const int num_patches = static_cast<int>(strided.size() / kStride);
  std::vector<double> packed(static_cast<size_t>(num_patches) * stride, 0.0);
  for (int p = 0; p < num_patches; ++p) {
    const double* in = strided.data() + p * kStride;
    double* out = packed.data() + p * stride;
    std::copy(in, in + num_coefficients, out);
    std::copy(in + kMaxJetCoefficients, in + kMaxJetCoefficients + 4, out + num_coefficients);
  }
  return packed;
}

// Per patch: the warp minimising sum_k |Phi_k c - slide_k|^2 (a tiny
// ridge keeps a patch with fewer points than monomials solvable).
void DrapeSolver::Impl::FitWarpsToSlides(const PolyFitModel& model, std::vector<double>* packed) const {
  if (num_warp == 0) return;
  const int stride = packed_stride(), num_patches = model.num_patches();
  std::vector<Eigen::MatrixXd> normal(num_patches, Eigen::MatrixXd::Zero(num_warp, num_warp));
  std::vector<Eigen::MatrixXd> rhs(num_patches, Eigen::MatrixXd::Zero(num_warp, 2));
  for (int k = 0; k < model.num_memberships(); ++k) {
    const int p = model.membership_patch[k];
    const Eigen::Map<const Eigen::VectorXd> phi(warp_monomials(k), num_warp);
    normal[p] += phi * phi.transpose();
    rhs[p] += phi * Eigen::RowVector2d(slides[2 * k], slides[2 * k + 1]);
  }
  for (int p = 0; p < num_patches; ++p) {
    normal[p].diagonal().array() += 1e-9 * (1.0 + normal[p].diagonal().maxCoeff());
    const Eigen::MatrixXd c = SolveSmallSpd(normal[p], rhs[p]);
    double* out = packed->data() + p * stride + num_coefficients + 4;
    for (int i = 0; i < num_warp; ++i) {
      out[i] = c(i, 0);
      out[num_warp + i] = c(i, 1);
    }
  }
}

void DrapeSolver::Impl::BuildChain(const PolyFitModel& model) {
  const int stride = packed_stride(), block = num_coefficients + 4, num_patches = model.num_patches();
  chain_begin.assign(1, 0);
  chain.clear();
  for (int p = 0; p < num_patches; ++p) {
    for (int c = 0; c < block; ++c) {
      chain.push_back({p * stride + c, 1.0});
      chain_begin.push_back(static_cast<int>(chain.size()));
    }
  }
  // slide_k = (sum_i a_i phi_ki, sum_i b_i phi_ki) over its patch's warp.
  for (int k = 0; num_warp > 0 && k < model.num_memberships(); ++k) {
    const int warp = model.membership_patch[k] * stride + block;
    const double* phi = warp_monomials(k);
    for (int direction = 0; direction < 2; ++direction) {
      for (int i = 0; i < num_warp; ++i) chain.push_back({warp + direction * num_warp + i, phi[i]});
      chain_begin.push_back(static_cast<int>(chain.size()));
    }
  }
}

DrapeSolver::DrapeSolver(const SkinnedBody& body, const TriangleMesh& garment, const SkinWeights& weights,
                         const DrapeSolverOptions& options)
    : garment_(garment) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("DrapeSolverOptions: " + problem);
  if (garment.num_vertices() < 3 || garment.faces.cols() == 0) {
    throw std::invalid_argument("DrapeSolver: the garment has no face");
  }
  if (!garment.vertices.allFinite()) throw std::invalid_argument("DrapeSolver: the garment has non-finite vertices");
  if (weights.num_vertices() != garment.num_vertices()) {
    throw std::invalid_argument("DrapeSolver: skinning weights for " + std::to_string(weights.num_vertices()) +
                                " vertices, the garment has " + std::to_string(garment.num_vertices()));
  }
  impl_ = std::make_unique<Impl>(body, weights, options);
  Impl& m = *impl_;
  const int n = garment.num_vertices();

  model_ = PatchGarment(garment, options.patching, options.num_threads);
  if (model_.num_vertices() != n) throw std::invalid_argument("DrapeSolver: patching changed the garment's vertices");
  m.InitializeParameters(model_);

  // The patches' own rest shape is the garment's rest: lengths, areas and
  // boundary gaps are measured on it, so that the fit's residual is not
  // mistaken for stretch.
  m.skin_linear.assign(n, Eigen::Matrix3d::Identity());
  m.skin_translation.assign(n, Eigen::Vector3d::Zero());
  m.BuildPoints(model_);
  positions_.resize(3, n);
  m.Positions(model_, &positions_);  // skinned by the identity: the rest pose
  fit_error_mean_ = (positions_ - garment.vertices).colwise().norm().mean();
  fit_error_max_ = (positions_ - garment.vertices).colwise().norm().maxCoeff();
  rest_garment_ = garment;
  rest_garment_.vertices = positions_;
  m.rest = PrepareClothRest(rest_garment_);
  m.CollectPatchEdges(model_);
  m.CollectBoundary(model_);
  m.CollectFaceMetrics(model_);
  m.k_ext.assign(n, 1.0);
  m.margin.assign(n, options.physics.weights.collision_margin);
  if (options.physics.margin_floor >= 0.0) {
    const Eigen::VectorXd clearance = m.distance.SignedDistances(positions_, options.num_threads);
    for (int v = 0; v < n; ++v) {
      m.margin[v] = std::clamp(clearance[v], options.physics.margin_floor, options.physics.weights.collision_margin);
    }
  }

  m.mass.resize(n);
  for (int v = 0; v < n; ++v) m.mass[v] = options.physics.material.area_density * m.rest.vertex_area[v];
  m.floor = body.mesh.vertices.row(1).minCoeff() - 1.0;
  m.contact.assign(n, SignedDistanceResult{});
  m.history1 = positions_;
  m.history2 = positions_;
  m.trust_region_radius = options.solve.initial_trust_region_radius;
  body_vertices_ = body.mesh.vertices;
  m.BuildProblem(model_);
}

DrapeSolver::~DrapeSolver() = default;

DrapeStepSummary DrapeSolver::Step(const std::vector<Eigen::Isometry3d>& rest_to_posed, double epoch) {
  const auto start = std::chrono::steady_clock::now();
  Impl& m = *impl_;
  const DrapeSolveOptions& o = m.options.solve;
  if (static_cast<int>(rest_to_posed.size()) != m.body.skeleton.num_joints()) {
    throw std::invalid_argument("DrapeSolver::Step: one transform per joint is needed");
  }
  DrapeStepSummary summary;
  m.PoseBodyAndGarment(rest_to_posed, &body_vertices_);
  m.previous_params = m.params;
  m.previous_slides = m.slides;
  m.Positions(model_, &positions_);
  m.QueryContacts(positions_);
  m.epoch = epoch;
  m.SetMotionTargets(model_);

  ceres::TerminationType last = ceres::CONVERGENCE;
  for (int pass = 0; pass < o.max_passes; ++pass) {
    summary.collision_terms = m.LinearizeCollisions(model_);
    ceres::Solver::Summary solve;
    ceres::Solve(m.SolverOptions(pass, garment_.num_vertices()), m.problem.get(), &solve);
    if (o.trace >= 1) std::fprintf(stderr, "%s\n", solve.FullReport().c_str());
    last = solve.termination_type;
    summary.solve_time_s += solve.total_time_in_seconds;
    if (!solve.iterations.empty()) {
      m.trust_region_radius = std::clamp(solve.iterations.back().trust_region_radius, 1e-4, 1e12);
    }
    summary.iterations += static_cast<int>(solve.iterations.size()) - 1;
    if (pass == 0) summary.initial_cost = solve.initial_cost;
    summary.final_cost = solve.final_cost;
    ++summary.passes;
    m.Positions(model_, &positions_);
    if (pass + 1 == o.max_passes || m.QueryContacts(positions_) == 0) break;
  }
  summary.termination_type = FromCeres(last);
  if (!positions_.allFinite()) {
    // Keep the last good state rather than propagate NaN.
    m.params = m.previous_params;
    m.slides = m.previous_slides;
    m.trust_region_radius = o.initial_trust_region_radius;
    m.Positions(model_, &positions_);
    summary.termination_type = TerminationType::kFailure;
    summary.message = "non-finite garment positions; the previous frame's state is kept";
  }
  m.history2 = m.history1;
  m.history1 = positions_;
  summary.time_s = Seconds(start);
  return summary;
}

int DrapeSolver::num_patch_parameters() const { return impl_->packed_stride(); }

std::vector<double> DrapeSolver::RestPatchParameters() const {
  return impl_->PackedPatchParameters(impl_->rest_params);
}

std::vector<double> DrapeSolver::PatchRestAreas() const {
  std::vector<double> area(model_.num_patches(), 0.0);
  for (size_t f = 0; f < model_.face_patch.size(); ++f) area[model_.face_patch[f]] += impl_->rest.face_area[f];
  return area;
}

const std::vector<double>& DrapeSolver::WarpRadii() const { return impl_->warp_radius; }

std::vector<double> DrapeSolver::PatchParameters() const {
  std::vector<double> packed = impl_->PackedPatchParameters(impl_->params);
  impl_->FitWarpsToSlides(model_, &packed);
  return packed;
}

void DrapeSolver::SetCollisionWeight(double weight) { impl_->options.physics.weights.collision = weight; }

double DrapeSolver::collision_weight() const { return impl_->options.physics.weights.collision; }

void DrapeSolver::Pose(const std::vector<Eigen::Isometry3d>& rest_to_posed, double epoch) {
  Impl& m = *impl_;
  if (static_cast<int>(rest_to_posed.size()) != m.body.skeleton.num_joints()) {
    throw std::invalid_argument("DrapeSolver::Pose: one transform per joint is needed");
  }
  m.PoseBodyAndGarment(rest_to_posed, &body_vertices_);
  m.epoch = epoch;
  m.SetMotionTargets(model_);
}

void DrapeSolver::SetHistory(const Eigen::Matrix3Xd& previous, const Eigen::Matrix3Xd& before_previous) {
  if (previous.cols() != positions_.cols() || before_previous.cols() != positions_.cols()) {
    throw std::invalid_argument("DrapeSolver::SetHistory: 3 by #V positions are needed");
  }
  impl_->history1 = previous;
  impl_->history2 = before_previous;
}

Eigen::Matrix3Xd DrapeSolver::PositionsOf(const std::vector<double>& patch_parameters) const {
  Eigen::Matrix3Xd x(3, positions_.cols());
  impl_->PositionsOfPacked(model_, patch_parameters, &x);
  return x;
}

double DrapeSolver::DistanceTo(const std::vector<double>& patch_parameters, const Eigen::Matrix3Xd& target,
                               std::vector<double>* gradient) {
  Impl& m = *impl_;
  if (target.cols() != positions_.cols() || target.rows() != 3) {
    throw std::invalid_argument("DrapeSolver::DistanceTo: the target has " + std::to_string(target.cols()) +
                                " points, the garment " + std::to_string(positions_.cols()));
  }
  if (!target.allFinite()) throw std::invalid_argument("DrapeSolver::DistanceTo: the target has non-finite points");
  m.saved_params = m.params;
  m.saved_slides = m.slides;
  m.SetPatchParameters(model_, patch_parameters);
  if (m.chain_begin.empty()) m.BuildChain(model_);
  const int num_patches = model_.num_patches(), block = m.num_coefficients + 4;
  // Ceres' layout (alpha, s, T per patch, then with warps each slide),
  // chained to the packed one below as Evaluate's gradient is.
  std::vector<double> raw(gradient != nullptr ? m.chain_begin.size() - 1 : 0, 0.0);
  const double total_area = std::accumulate(m.rest.vertex_area.begin(), m.rest.vertex_area.end(), 0.0);
  double cost = 0.0;
  for (int v = 0; v < model_.num_vertices(); ++v) {
    const IndexRange range = model_.memberships(v);
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    for (int k : range) {
      const int p = model_.membership_patch[k];
      x += m.points[k].Position(m.alpha(p), m.scale(p), m.translation(p), m.slide(k));
    }
    x /= range.size();
    const double a = m.rest.vertex_area[v] / total_area;
    const Eigen::Vector3d d = x - target.col(v);
    cost += 0.5 * a * d.squaredNorm();
    if (gradient == nullptr) continue;
    // dE/dx_v, shared equally by the vertex's points on its patches.
    const Eigen::Matrix<double, 1, 3> de_dx = (a / range.size()) * d.transpose();
    for (int k : range) {
      const int p = model_.membership_patch[k];
      double* base = raw.data() + p * block;
      double slide_gradient[2];
      double* jacobians[4] = {base, base + m.num_coefficients, base + m.num_coefficients + 1,
                              m.num_warp > 0 ? slide_gradient : nullptr};
      const PatchPointState state = m.points[k].State(m.alpha(p), m.slide(k));
      m.points[k].Chain<1>(de_dx, state, m.scale(p), jacobians, 3, 1.0, true);
      if (m.num_warp > 0) {
        raw[num_patches * block + 2 * k] += slide_gradient[0];
        raw[num_patches * block + 2 * k + 1] += slide_gradient[1];
      }
    }
  }
  m.params = m.saved_params;
  m.slides = m.saved_slides;
  if (gradient != nullptr) m.ChainGradient(raw, num_patches * m.packed_stride(), gradient);
  return cost;
}

void DrapeSolver::WarmStart(const std::vector<double>& patch_parameters) {
  impl_->SetPatchParameters(model_, patch_parameters);
}

void DrapeSolver::Adopt(const std::vector<double>& patch_parameters) {
  Impl& m = *impl_;
  WarmStart(patch_parameters);
  m.previous_params = m.params;
  m.previous_slides = m.slides;
  m.Positions(model_, &positions_);
  m.history2 = m.history1;
  m.history1 = positions_;
}

void DrapeSolver::Adopt(const std::vector<double>& patch_parameters, const Eigen::Matrix3Xd& positions) {
  if (positions.cols() != positions_.cols() || positions.rows() != 3) {
    throw std::invalid_argument("DrapeSolver::Adopt: 3 by " + std::to_string(positions_.cols()) +
                                " positions are needed, not " + std::to_string(positions.rows()) + " by " +
                                std::to_string(positions.cols()));
  }
  Adopt(patch_parameters);
  positions_ = positions;
  impl_->history1 = positions_;
}

Eigen::Matrix3Xd DrapeSolver::PositionsAt(const std::vector<double>& patch_parameters,
                                          const std::vector<Eigen::Isometry3d>& rest_to_posed) {
  Impl& m = *impl_;
  if (static_cast<int>(rest_to_posed.size()) != m.body.skeleton.num_joints()) {
    throw std::invalid_argument("DrapeSolver::PositionsAt: one transform per joint is needed");
  }
  m.BlendGarmentSkin(rest_to_posed);
  return PositionsOf(patch_parameters);
}

void DrapeSolver::Impl::AccumulateGaussNewton(const ceres::CRSMatrix& jacobian, int num_packed,
                                              Eigen::MatrixXd* out) const {
  out->setZero(num_packed, num_packed);
  // Each row of J C, gathered densely over the packed parameters it touches.
  Eigen::VectorXd row = Eigen::VectorXd::Zero(num_packed);
  std::vector<char> marked(num_packed, 0);
  std::vector<int> touched;
  for (int r = 0; r < jacobian.num_rows; ++r) {
    for (int e = jacobian.rows[r]; e < jacobian.rows[r + 1]; ++e) {
      const int c = jacobian.cols[e];
      for (int i = chain_begin[c]; i < chain_begin[c + 1]; ++i) {
        if (!marked[chain[i].packed]) {
          marked[chain[i].packed] = 1;
          touched.push_back(chain[i].packed);
        }
        row[chain[i].packed] += chain[i].weight * jacobian.values[e];
      }
    }
    for (int a : touched) {
      for (int b : touched) (*out)(a, b) += row[a] * row[b];
    }
    for (int a : touched) {
      row[a] = 0.0;
      marked[a] = 0;
    }
    touched.clear();
  }
}

double DrapeSolver::Impl::EvaluatePacked(const PolyFitModel& model, const std::vector<double>& packed,
                                         std::vector<double>* gradient, Eigen::MatrixXd* gauss_newton,
                                         std::vector<double>* residuals) {
  // The solver's state is kept; priors vanish (their means set to the
  // evaluated point); slides follow the warps (zero without).
  const std::vector<double> kept_params = params, kept_previous = previous_params, kept_slides = slides,
                            kept_previous_slides = previous_slides;
  SetPatchParameters(model, packed);
  previous_params = params;
  previous_slides = slides;
  Eigen::Matrix3Xd x(3, static_cast<Eigen::Index>(mass.size()));
  Positions(model, &x);
  QueryContacts(x);
  LinearizeCollisions(model);
  ceres::Problem::EvaluateOptions evaluate;
  for (int p = 0; p < model.num_patches(); ++p) {
    evaluate.parameter_blocks.insert(evaluate.parameter_blocks.end(), {alpha(p), scale(p), translation(p)});
  }
  for (int k = 0; num_warp > 0 && k < model.num_memberships(); ++k) evaluate.parameter_blocks.push_back(slide(k));
  evaluate.num_threads = options.num_threads;
  double cost = 0.0;
  std::vector<double> raw;
  ceres::CRSMatrix jacobian;
  const bool ok = residuals == nullptr && gauss_newton == nullptr
                      ? EvaluateDirect(evaluate.parameter_blocks, &cost, gradient != nullptr ? &raw : nullptr)
                      : problem->Evaluate(evaluate, &cost, residuals, gradient != nullptr ? &raw : nullptr,
                                          gauss_newton != nullptr ? &jacobian : nullptr);
  params = kept_params;
  previous_params = kept_previous;
  slides = kept_slides;
  previous_slides = kept_previous_slides;
  if (!ok) throw std::runtime_error("DrapeSolver::Evaluate: a term could not be evaluated");
  // Ceres' parameters are a linear map of the packed ones (the warps set
  // the slides): J_packed = J C, gradient = C^T (J^T r).
  if (chain_begin.empty()) BuildChain(model);
  const int num_packed = model.num_patches() * packed_stride();
  if (gradient != nullptr) ChainGradient(raw, num_packed, gradient);
  if (gauss_newton != nullptr) AccumulateGaussNewton(jacobian, num_packed, gauss_newton);
  return cost;
}

void DrapeSolver::Impl::ChainGradient(const std::vector<double>& raw, int num_packed,
                                      std::vector<double>* gradient) const {
  gradient->assign(num_packed, 0.0);
  for (size_t c = 0; c + 1 < chain_begin.size(); ++c) {
    for (int i = chain_begin[c]; i < chain_begin[c + 1]; ++i) (*gradient)[chain[i].packed] += chain[i].weight * raw[c];
  }
}

void DrapeSolver::Impl::BuildDirectBlocks(const std::vector<double*>& listed) {
  std::unordered_map<const double*, int> offset;
  int size = 0;
  for (double* block : listed) {
    offset[block] = size;
    size += problem->ParameterBlockSize(block);
  }
  direct_gradient_size = size;
  std::vector<ceres::ResidualBlockId> ids;
  problem->GetResidualBlocks(&ids);
  for (ceres::ResidualBlockId id : ids) {
    DirectBlock b;
    b.cost = problem->GetCostFunctionForResidualBlock(id);
    problem->GetParameterBlocksForResidualBlock(id, &b.parameters);
    if (b.parameters.size() > kMaxDirectBlocks) {
      throw std::logic_error("DrapeSolver: a term with more parameter blocks than the direct evaluation holds");
    }
    for (double* block : b.parameters) {
      const auto it = offset.find(block);
      b.offsets.push_back(it == offset.end() || problem->IsParameterBlockConstant(block) ? -1 : it->second);
    }
    direct_blocks.push_back(std::move(b));
  }
}

bool DrapeSolver::Impl::EvaluateDirect(const std::vector<double*>& listed, double* cost,
                                       std::vector<double>* gradient) {
  if (direct_blocks.empty()) BuildDirectBlocks(listed);
  const int threads = std::max(1, ResolveNumThreads(options.num_threads));
  if (static_cast<int>(direct_sums.size()) != threads) {
    direct_sums.assign(threads, std::vector<double>(direct_gradient_size, 0.0));
    direct_scratch.assign(threads, {});
  }
  direct_costs.assign(threads, 0.0);
  direct_failed.assign(threads, 0);
  if (gradient != nullptr) {
    for (std::vector<double>& g : direct_sums) std::fill(g.begin(), g.end(), 0.0);
  }
  ParallelFor(static_cast<int>(direct_blocks.size()), threads, [&](int t, int i) {
    const DirectBlock& b = direct_blocks[i];
    const std::vector<int>& sizes = b.cost->parameter_block_sizes();
    const int m = b.cost->num_residuals();
    int needed = m;
    for (size_t j = 0; j < sizes.size(); ++j) needed += gradient != nullptr && b.offsets[j] >= 0 ? m * sizes[j] : 0;
    std::vector<double>& buffer = direct_scratch[t];
    if (static_cast<int>(buffer.size()) < needed) buffer.resize(needed);
    double* r = buffer.data();
    double* jacobians[kMaxDirectBlocks];
    double* next = r + m;
    for (size_t j = 0; j < sizes.size(); ++j) {
      jacobians[j] = gradient != nullptr && b.offsets[j] >= 0 ? next : nullptr;
      if (jacobians[j] != nullptr) next += m * sizes[j];
    }
    if (!b.cost->Evaluate(b.parameters.data(), r, gradient != nullptr ? jacobians : nullptr)) {
      direct_failed[t] = 1;
      return;
    }
    double s = 0.0;
    for (int k = 0; k < m; ++k) s += r[k] * r[k];
    direct_costs[t] += 0.5 * s;
    if (gradient == nullptr) return;
    std::vector<double>& g = direct_sums[t];
    for (size_t j = 0; j < sizes.size(); ++j) {
      if (jacobians[j] == nullptr) continue;
      double* out = g.data() + b.offsets[j];
      for (int k = 0; k < m; ++k) {
        const double* row = jacobians[j] + k * sizes[j];
        for (int c = 0; c < sizes[j]; ++c) out[c] += row[c] * r[k];
      }
    }
  });
  *cost = 0.0;
  for (int t = 0; t < threads; ++t) {
    if (direct_failed[t]) return false;
    *cost += direct_costs[t];
  }
  if (gradient != nullptr) {
    gradient->assign(direct_gradient_size, 0.0);
    for (const std::vector<double>& g : direct_sums) {
      for (size_t i = 0; i < g.size(); ++i) (*gradient)[i] += g[i];
    }
  }
  return true;
}

double DrapeSolver::Evaluate(const std::vector<double>& patch_parameters, std::vector<double>* gradient) {
  return impl_->EvaluatePacked(model_, patch_parameters, gradient, nullptr, nullptr);
}

double DrapeSolver::EvaluateGaussNewton(const std::vector<double>& patch_parameters, std::vector<double>* gradient,
                                        Eigen::MatrixXd* gauss_newton, std::vector<double>* residuals) {
  if (gauss_newton == nullptr) throw std::invalid_argument("DrapeSolver::EvaluateGaussNewton: no matrix to fill");
  std::vector<double> r;
  const double cost = impl_->EvaluatePacked(model_, patch_parameters, gradient, gauss_newton, &r);
  if (residuals != nullptr) *residuals = std::move(r);
  return cost;
}

Eigen::VectorXd DrapeSolver::SignedDistances(const Eigen::Matrix3Xd& points) const {
  return impl_->distance.SignedDistances(points, impl_->options.num_threads);
}

namespace {

// `points` (3 by N) with every one inside the body moved to its closest
// body point plus `offset` along the pseudonormal. hints (or null): each
// point's earlier query, whose face starts this one; closest (or null):
// each point's query, kept.
Eigen::Matrix3Xd ProjectOutOfBody(const BodySignedDistance& distance, int num_threads, const Eigen::Matrix3Xd& points,
                                  double offset, const std::vector<SignedDistanceResult>* hints,
                                  std::vector<SignedDistanceResult>* closest) {
  Eigen::Matrix3Xd out = points;
  if (closest) closest->resize(points.cols());
  ParallelFor(static_cast<int>(points.cols()), num_threads, [&](int, int v) {
    const SignedDistanceResult r = distance.Query(points.col(v), hints ? (*hints)[v].face : -1);
    if (r.distance < 0.0) out.col(v) = r.closest + offset * r.normal;
    if (closest) (*closest)[v] = r;
  });
  return out;
}

}  // namespace

Eigen::Matrix3Xd DrapeSolver::ProjectedOutOfBody(double offset) const {
  return ProjectOutOfBody(impl_->distance, impl_->options.num_threads, positions_, offset, nullptr, nullptr);
}

Eigen::Matrix3Xd DrapeSolver::PostProcessed(double offset, int strain_passes, const ClothRest& rest) const {
  if (strain_passes <= 0) return ProjectedOutOfBody(offset);
  std::vector<SignedDistanceResult> closest;
  Eigen::Matrix3Xd out =
      ProjectOutOfBody(impl_->distance, impl_->options.num_threads, positions_, offset, nullptr, &closest);
  std::vector<BodyContact> contacts;
  for (int v = 0; v < out.cols(); ++v) {
    if (closest[v].distance < kStrainLimitContactReach) contacts.push_back({v, closest[v].closest, closest[v].normal});
  }
  LimitStrain(rest, contacts, strain_passes, offset, &out);
  // The planes are the body linearised where the passes started: what the
  // passes moved inside it is projected out exactly, as with no passes.
  // Every vertex is queried again: skipping those that moved less than
  // their distance to the body left more inside (the posed body intersects
  // itself, so its signed distance is likely not 1-Lipschitz there).
  return ProjectOutOfBody(impl_->distance, impl_->options.num_threads, out, offset, &closest, nullptr);
}

Eigen::VectorXd DrapeSolver::NearestVertexDistances(const Eigen::Matrix3Xd& points) const {
  Impl& m = *impl_;
  if (!m.nearest) {
    TriangleMesh posed = m.body.mesh;
    posed.vertices = body_vertices_;
    m.nearest = std::make_unique<NearestVertexDistance>(posed);
  } else if (m.nearest_stale) {
    m.nearest->SetVertices(body_vertices_);
  }
  m.nearest_stale = false;
  Eigen::VectorXd d(points.cols());
  int hint = -1;  // consecutive points are mostly neighbours
  for (int v = 0; v < points.cols(); ++v) {
    const SignedDistanceResult r = m.nearest->Query(points.col(v), hint);
    d[v] = r.distance;
    hint = r.face;
  }
  return d;
}

}  // namespace polyfit
