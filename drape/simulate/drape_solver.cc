#include "drape/simulate/drape_solver.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

#include <ceres/ceres.h>

#include "cost_functions/metric_inextensibility_residual.h"
#include "cost_functions/patch_boundary_residual.h"
#include <ceres/autodiff_cost_function.h>
#include "drape/collision/signed_distance.h"
#include "drape/simulate/skinned_patch_costs.h"
#include "polyfit/cluster/acvd_clustering.h"
#include "polyfit/pipeline/fit_mesh.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {
namespace {

double Seconds(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// PCA leaves each patch's normal axis with an arbitrary sign; the boundary
// term compares normals, so every patch is turned (180 degrees about its u
// axis: v -> -v, z -> -z) to agree with its faces' orientation.
void OrientPatchesLikeFaces(const TriangleMesh& mesh, PolyFitModel* model) {
  std::vector<Eigen::Vector3d> normal(model->num_patches(), Eigen::Vector3d::Zero());
  for (int f = 0; f < mesh.faces.cols(); ++f) {
    const Eigen::Vector3d a = mesh.vertices.col(mesh.faces(0, f)), b = mesh.vertices.col(mesh.faces(1, f)),
                          c = mesh.vertices.col(mesh.faces(2, f));
    normal[model->face_patch[f]] += (b - a).cross(c - a);
  }
  std::vector<bool> flip(model->num_patches(), false);
  for (int p = 0; p < model->num_patches(); ++p) {
    JetPatch& patch = model->patches[p];
    if (normal[p].dot(patch.frame.rotation.col(2)) >= 0.0) continue;
    flip[p] = true;
    patch.frame.rotation.col(1) *= -1.0;
    patch.frame.rotation.col(2) *= -1.0;
    // z'(u, v') = -z(u, -v'): alpha'_(a, b) = -(-1)^b alpha_(a, b).
    int k = 0;
    for (int d = 0; d <= patch.order; ++d) {
      for (int b = 0; b <= d; ++b, ++k) patch.coefficients[k] *= (b % 2 == 0) ? -1.0 : 1.0;
    }
  }
  for (size_t m = 0; m < model->membership_patch.size(); ++m) {
    if (flip[model->membership_patch[m]]) model->membership_uv(1, static_cast<Eigen::Index>(m)) *= -1.0;
  }
}

// The metric-tensor term (eq. 4) with the skinning Jacobian and the k_ext
// factor read at each evaluation (they change per frame).
class SkinnedMetricCost {
 public:
  SkinnedMetricCost(int order, double u, double v, const Eigen::Vector3d& rest_metric, const Eigen::Matrix3d& rotation,
                    const Eigen::Matrix3d* skinning, double weight, const double* factor)
      : order_(order), u_(u), v_(v), rest_(rest_metric), rotation_(rotation), skinning_(skinning), weight_(weight),
        factor_(factor) {}

  template <typename T>
  bool operator()(const T* alpha, const T* scale, T* residual) const {
    return MetricInextensibilityResidual(order_, u_, v_, rest_, rotation_, *skinning_, weight_ * *factor_)(alpha, scale,
                                                                                                         residual);
  }

 private:
  int order_;
  double u_, v_;
  Eigen::Vector3d rest_;
  Eigen::Matrix3d rotation_;
  const Eigen::Matrix3d* skinning_;
  double weight_;
  const double* factor_;
};

// w (x - mean), the mean read through a pointer (last frame's parameters).
class ParameterPrior : public ceres::CostFunction {
 public:
  ParameterPrior(int size, double weight, const double* mean) : weight_(weight), mean_(mean) {
    set_num_residuals(size);
    mutable_parameter_block_sizes()->assign({size});
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const int n = num_residuals();
    for (int i = 0; i < n; ++i) residuals[i] = weight_ * (parameters[0][i] - mean_[i]);
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::MatrixXd>(jacobians[0], n, n) = weight_ * Eigen::MatrixXd::Identity(n, n);
    }
    return true;
  }

 private:
  double weight_;
  const double* mean_;
};

// The distance from each membership's vertex to its patch's jet.
std::vector<double> PatchMaxErrors(const TriangleMesh& mesh, const PolyFitModel& model) {
  std::vector<double> error(model.num_patches(), 0.0);
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    for (int k = model.membership_offsets[v]; k < model.membership_offsets[v + 1]; ++k) {
      const int p = model.membership_patch[k];
      const double e = (model.patches[p].PointInWorld(model.membership_uv(0, k), model.membership_uv(1, k)) -
                        mesh.vertices.col(v)).norm();
      error[p] = std::max(error[p], e);
    }
  }
  return error;
}

// Patches for a garment without subdividing it (one point per vertex):
// ACVD clusters, then every patch whose jet misses one of its vertices by
// more than max_error (a fold, a cuff: no height field) is split in two by
// 2-means on its faces' normals and scaled positions, and all are refitted.
PolyFitModel PatchGarment(const TriangleMesh& mesh, const DrapeSolverOptions& options) {
  ClusteringOptions clustering;
  clustering.num_patches = std::max(1, mesh.num_vertices() / options.vertices_per_patch);
  PolyFitModel model;
  model.face_patch = ClusterMeshFaces(clustering, mesh);
  model.faces = mesh.faces;
  JetFitOptions jet;
  jet.order = options.jet_order;
  jet.num_threads = options.num_threads;
  const int nf = static_cast<int>(mesh.faces.cols());
  std::vector<Eigen::Vector3d> normal(nf), centroid(nf);
  for (int f = 0; f < nf; ++f) {
    const Eigen::Vector3d a = mesh.vertices.col(mesh.faces(0, f)), b = mesh.vertices.col(mesh.faces(1, f)),
                          c = mesh.vertices.col(mesh.faces(2, f));
    normal[f] = (b - a).cross(c - a).normalized();
    if (!normal[f].allFinite()) normal[f].setZero();
    centroid[f] = (a + b + c) / 3.0;
  }
  for (int round = 0;; ++round) {
    BuildPatchMemberships(mesh, model.face_patch, &model);
    FitPatchJets(jet, mesh, &model);
    if (round == options.max_patch_splits) break;
    const std::vector<double> error = PatchMaxErrors(mesh, model);
    std::vector<std::vector<int>> faces(model.num_patches());
    for (int f = 0; f < nf; ++f) faces[model.face_patch[f]].push_back(f);
    int next = model.num_patches();
    bool split = false;
    for (int p = 0; p < model.num_patches(); ++p) {
      if (error[p] <= options.max_fit_error || faces[p].size() < 4) continue;
      // Features: the normal and the position over the patch's radius.
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (int f : faces[p]) mean += centroid[f] / static_cast<double>(faces[p].size());
      double radius = 0.0;
      for (int f : faces[p]) radius = std::max(radius, (centroid[f] - mean).norm());
      const auto feature = [&](int f) {
        Eigen::Matrix<double, 6, 1> x;
        x << normal[f], (centroid[f] - mean) / std::max(radius, 1e-12);
        return x;
      };
      // Seeds: a face far from the first, then the face farthest from it.
      int s0 = faces[p][0], s1 = s0;
      for (int pass = 0; pass < 2; ++pass) {
        double best = -1.0;
        for (int f : faces[p]) {
          const double d = (feature(f) - feature(s0)).squaredNorm();
          if (d > best) best = d, s1 = f;
        }
        if (pass == 0) std::swap(s0, s1);
      }
      Eigen::Matrix<double, 6, 1> c0 = feature(s0), c1 = feature(s1);
      std::vector<int> side(faces[p].size(), 0);
      for (int it = 0; it < 10; ++it) {
        Eigen::Matrix<double, 6, 1> sum0 = Eigen::Matrix<double, 6, 1>::Zero(), sum1 = sum0;
        int n0 = 0, n1 = 0;
        for (size_t i = 0; i < faces[p].size(); ++i) {
          const Eigen::Matrix<double, 6, 1> x = feature(faces[p][i]);
          side[i] = (x - c0).squaredNorm() <= (x - c1).squaredNorm() ? 0 : 1;
          if (side[i] == 0) sum0 += x, ++n0;
          else sum1 += x, ++n1;
        }
        if (n0 == 0 || n1 == 0) break;
        c0 = sum0 / n0;
        c1 = sum1 / n1;
      }
      int moved = 0;
      for (size_t i = 0; i < faces[p].size(); ++i) moved += side[i];
      if (moved == 0 || moved == static_cast<int>(faces[p].size())) continue;
      for (size_t i = 0; i < faces[p].size(); ++i) {
        if (side[i] == 1) model.face_patch[faces[p][i]] = next;
      }
      ++next;
      split = true;
    }
    if (!split) break;
  }
  return model;
}

}  // namespace

std::string DrapeSolverOptions::Validate() const {
  if (jet_order < 1 || jet_order > kMaxJetOrder) return "jet_order must be in [1, " + std::to_string(kMaxJetOrder) + "]";
  if (vertices_per_patch < 3) return "vertices_per_patch must be >= 3";
  if (!(fps > 0.0)) return "fps must be positive";
  if (max_iterations < 1 || max_refine_iterations < 1 || max_passes < 1) return "max_iterations, max_refine_iterations and max_passes must be >= 1";
  if (!(initial_trust_region_radius > 0.0) || !std::isfinite(initial_trust_region_radius)) {
    return "initial_trust_region_radius must be positive and finite";
  }
  if (!(conjugate_gradients_tolerance > 0.0 && conjugate_gradients_tolerance < 1.0)) {
    return "conjugate_gradients_tolerance must be in (0, 1)";
  }
  for (const double w : {weights.boundary, weights.inextensibility, weights.gravity, weights.collision, weights.inertia,
                         weights.collision_margin, collision_stiffness, boundary_base, stretch_base, collision_band, parameter_prior, slide_agreement, gravity,
                         material.area_density, material.mu}) {
    if (!std::isfinite(w) || w < 0.0) return "weights, stiffnesses and material constants must be finite and >= 0";
  }
  if (!(material.area_density > 0.0)) return "material.area_density must be positive";
  return {};
}

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
  std::vector<double> params, previous_params;
  // Per membership: its point's slide (du, dv) along its patch.
  std::vector<double> slides, previous_slides;
  // Per membership.
  std::vector<int> membership_vertex;
  std::vector<Eigen::Vector3d> rest_metric;
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
  std::vector<double> edge_area;
  std::vector<PatchBoundaryPoint> boundary;
  std::vector<Eigen::Vector3d> boundary_position_gap, boundary_normal_gap;
  double mean_edge = 0.0;
  double floor = 0.0;
  // Collision linearisation per vertex.
  std::vector<SignedDistanceResult> contact;
  // The problem, built once; its costs read these, updated per frame.
  std::unique_ptr<ceres::Problem> problem;
  std::vector<VertexTermsData> vertex_data;  // per membership
  double metric_factor = 1.0;                // sqrt(k_ext)
  // Levenberg-Marquardt's trust region carried from solve to solve.
  double trust_region_radius = 0.0;

  explicit Impl(const SkinnedBody& b) : body(b), distance(b.mesh) {}

  double* alpha(int p) { return params.data() + p * kStride; }
  double* scale(int p) { return params.data() + p * kStride + kMaxJetCoefficients; }
  double* translation(int p) { return params.data() + p * kStride + kMaxJetCoefficients + 1; }
  double* slide(int k) { return slides.data() + 2 * k; }

  // One posed point per membership, reading skin_linear and
  // skin_translation (sized once, so the pointers stay valid).
  std::vector<SkinnedPatchPoint> points;

  void BuildPoints(const PolyFitModel& model) {
    points.clear();
    points.reserve(model.membership_patch.size());
    for (size_t k = 0; k < model.membership_patch.size(); ++k) {
      const int p = model.membership_patch[k];
      const int v = membership_vertex[k];
      const Eigen::Index i = static_cast<Eigen::Index>(k);
      points.emplace_back(options.jet_order, model.membership_uv(0, i), model.membership_uv(1, i),
                          model.patches[p].frame.rotation, &skin_linear[v], &skin_translation[v]);
    }
  }
  // Each vertex the mean of its patches' posed points (3 by #V).
  void Positions(const PolyFitModel& model, Eigen::Matrix3Xd* out) {
    for (int v = 0; v < out->cols(); ++v) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (int k = model.membership_offsets[v]; k < model.membership_offsets[v + 1]; ++k) {
        const int p = model.membership_patch[k];
        sum += points[k].Position(alpha(p), scale(p), translation(p), slide(k));
      }
      out->col(v) = sum / (model.membership_offsets[v + 1] - model.membership_offsets[v]);
    }
  }

  void BuildProblem(const PolyFitModel& model);
};

DrapeSolver::DrapeSolver(const SkinnedBody& body, const TriangleMesh& garment, const SkinWeights& weights,
                         const DrapeSolverOptions& options)
    : garment_(garment) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("DrapeSolverOptions: " + problem);
  if (garment.num_vertices() < 3 || garment.faces.cols() == 0) throw std::invalid_argument("DrapeSolver: the garment has no face");
  if (!garment.vertices.allFinite()) throw std::invalid_argument("DrapeSolver: the garment has non-finite vertices");
  if (weights.num_vertices() != garment.num_vertices()) {
    throw std::invalid_argument("DrapeSolver: skinning weights for " + std::to_string(weights.num_vertices()) +
                                " vertices, the garment has " + std::to_string(garment.num_vertices()));
  }
  impl_ = std::make_unique<Impl>(body);
  Impl& m = *impl_;
  m.weights = weights;
  m.options = options;
  const int n = garment.num_vertices();

  model_ = PatchGarment(garment, options);
  if (model_.num_vertices() != n) throw std::invalid_argument("DrapeSolver: patching changed the garment's vertices");
  OrientPatchesLikeFaces(garment, &model_);

  m.num_coefficients = NumJetCoefficients(options.jet_order);
  m.params.assign(static_cast<size_t>(model_.num_patches()) * Impl::kStride, 0.0);
  for (int p = 0; p < model_.num_patches(); ++p) {
    const JetPatch& patch = model_.patches[p];
    for (int k = 0; k < NumJetCoefficients(patch.order); ++k) m.alpha(p)[k] = patch.coefficients[k];
    m.scale(p)[0] = patch.frame.scale;
    Eigen::Map<Eigen::Vector3d>(m.translation(p)) = patch.frame.translation;
  }
  m.previous_params = m.params;
  m.slides.assign(2 * model_.membership_patch.size(), 0.0);
  m.previous_slides = m.slides;

  const int num_memberships = static_cast<int>(model_.membership_patch.size());
  m.membership_vertex.resize(num_memberships);
  m.rest_metric.resize(num_memberships);
  for (int v = 0; v < n; ++v) {
    for (int k = model_.membership_offsets[v]; k < model_.membership_offsets[v + 1]; ++k) {
      m.membership_vertex[k] = v;
      const int p = model_.membership_patch[k];
      const auto d = EvaluateJetDerivatives(options.jet_order, m.alpha(p), model_.membership_uv(0, k),
                                            model_.membership_uv(1, k));
      const double s2 = m.scale(p)[0] * m.scale(p)[0];
      m.rest_metric[k] = s2 * Eigen::Vector3d(1.0 + d.z_u * d.z_u, d.z_u * d.z_v, 1.0 + d.z_v * d.z_v);
    }
  }
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

  const auto membership_in = [&](int v, int p) {
    for (int k = model_.membership_offsets[v]; k < model_.membership_offsets[v + 1]; ++k) {
      if (model_.membership_patch[k] == p) return k;
    }
    return -1;
  };

  // Edges, each in the patches of its faces.
  std::map<std::pair<int, int>, int> edge_index;
  for (size_t e = 0; e < m.rest.edges.size(); ++e) edge_index[{m.rest.edges[e][0], m.rest.edges[e][1]}] = static_cast<int>(e);
  m.edge_area.assign(m.rest.edges.size(), 0.0);
  std::map<std::pair<int, int>, bool> seen;  // (edge, patch)
  for (int f = 0; f < garment.faces.cols(); ++f) {
    const int p = model_.face_patch[f];
    for (int c = 0; c < 3; ++c) {
      const int a = garment.faces(c, f), b = garment.faces((c + 1) % 3, f);
      const int e = edge_index.at({std::min(a, b), std::max(a, b)});
      m.edge_area[e] += m.rest.face_area[f] / 3.0;
      if (seen.emplace(std::make_pair(e, p), true).second) {
        const int mi = membership_in(m.rest.edges[e][0], p), mj = membership_in(m.rest.edges[e][1], p);
        if (mi >= 0 && mj >= 0) m.patch_edges.push_back({e, mi, mj});
      }
    }
  }
  for (double length : m.rest.edge_length) m.mean_edge += length / static_cast<double>(m.rest.edge_length.size());
  m.boundary = model_.BoundaryPoints();
  for (const PatchBoundaryPoint& b : m.boundary) {
    const JetPatch& pa = model_.patches[b.patch_a];
    const JetPatch& pb = model_.patches[b.patch_b];
    m.boundary_position_gap.push_back(pa.PointInWorld(b.uv_a.x(), b.uv_a.y()) - pb.PointInWorld(b.uv_b.x(), b.uv_b.y()));
    m.boundary_normal_gap.push_back(pa.NormalInWorld(b.uv_a.x(), b.uv_a.y()) - pb.NormalInWorld(b.uv_b.x(), b.uv_b.y()));
  }

  m.mass.resize(n);
  for (int v = 0; v < n; ++v) m.mass[v] = options.material.area_density * m.rest.vertex_area[v];
  m.floor = body.mesh.vertices.row(1).minCoeff() - 1.0;
  m.contact.assign(n, SignedDistanceResult{});

  m.history1 = positions_;
  m.history2 = positions_;
  body_vertices_ = body.mesh.vertices;
  m.BuildProblem(model_);
}

void DrapeSolver::Impl::BuildProblem(const PolyFitModel& model) {
  const DrapeSolverOptions& o = options;
  const double dt = 1.0 / o.fps;
  const double mu = o.material.mu;
  const double k_mi = o.weights.inextensibility * o.stretch_base;
  const int n = model.num_vertices();
  problem = std::make_unique<ceres::Problem>();
  for (int p = 0; p < model.num_patches(); ++p) {
    problem->AddParameterBlock(alpha(p), num_coefficients);
    problem->AddParameterBlock(scale(p), 1);
    problem->AddParameterBlock(translation(p), 3);
  }
  for (size_t k = 0; k < model.membership_patch.size(); ++k) {
    problem->AddParameterBlock(slide(static_cast<int>(k)), 2);
    if (!o.slide) problem->SetParameterBlockConstant(slide(static_cast<int>(k)));
  }
  // Vertex terms at every membership: collision everywhere (off while far
  // from the body), gravity and inertia at the owner.
  vertex_data.assign(model.membership_patch.size(), VertexTermsData{});
  for (int v = 0; v < n; ++v) {
    for (int k = model.membership_offsets[v]; k < model.membership_offsets[v + 1]; ++k) {
      VertexTermsData& data = vertex_data[k];
      data.margin = o.weights.collision_margin;
      data.collision_weight = std::sqrt(o.weights.collision * o.collision_stiffness);
      if (k == model.membership_offsets[v]) {
        data.gravity_weight = o.weights.gravity * mass[v] * o.gravity;
        data.floor = floor;
        data.inertia_weight = std::sqrt(o.weights.inertia * mass[v]) / dt;
      }
      const int p = model.membership_patch[k];
      const bool owner = k == model.membership_offsets[v];
      problem->AddResidualBlock(new SkinnedVertexCost(points[k], &data, owner), nullptr, alpha(p), scale(p),
                                translation(p), slide(k));
      const double metric_area = rest.vertex_area[v] / (model.membership_offsets[v + 1] - model.membership_offsets[v]);
      const double metric_weight = std::sqrt(k_mi * mu * metric_area / 2.0);
      if (metric_weight > 0.0) {
        auto* functor = new SkinnedMetricCost(o.jet_order, model.membership_uv(0, k), model.membership_uv(1, k),
                                              rest_metric[k], model.patches[p].frame.rotation, &skin_linear[v],
                                              metric_weight, &metric_factor);
        ceres::CostFunction* cost = DispatchJetCoefficients(o.jet_order, "SkinnedMetricCost", [&](auto c) -> ceres::CostFunction* {
          return new ceres::AutoDiffCostFunction<SkinnedMetricCost, 3, decltype(c)::value, 1>(functor);
        });
        problem->AddResidualBlock(cost, nullptr, alpha(p), scale(p));
      }
    }
  }
  if (k_mi > 0.0) {
    for (const PatchEdge& e : patch_edges) {
      const int p = model.membership_patch[e.mi];
      const double weight = std::sqrt(2.0 * k_mi * mu * edge_area[e.edge]);
      problem->AddResidualBlock(new SkinnedEdgeCost(points[e.mi], points[e.mj], rest.edge_length[e.edge], weight),
                                nullptr, alpha(p), scale(p), translation(p), slide(e.mi), slide(e.mj));
    }
  }
  if (o.weights.boundary > 0.0) {
    for (size_t i = 0; i < boundary.size(); ++i) {
      const PatchBoundaryPoint& b = boundary[i];
      const double w = std::sqrt(2.0 * o.weights.boundary * o.boundary_base * mu * rest.vertex_area[b.vertex]);
      problem->AddResidualBlock(
          PatchBoundaryResidual::Create(o.jet_order, b.uv_a, model.patches[b.patch_a].frame.rotation, b.uv_b,
                                        model.patches[b.patch_b].frame.rotation, w / mean_edge, w,
                                        boundary_position_gap[i], boundary_normal_gap[i]),
          nullptr, alpha(b.patch_a), scale(b.patch_a), translation(b.patch_a), alpha(b.patch_b), scale(b.patch_b),
          translation(b.patch_b));
    }
  }
  // A vertex's points on its patches slide apart unless held together (the
  // boundary term above compares the jets at the rest parameters).
  if (o.slide) {
    for (int v = 0; v < n; ++v) {
      const int first = model.membership_offsets[v];
      const double w = std::sqrt(2.0 * k_mi * mu * rest.vertex_area[v]) * o.slide_agreement / mean_edge;
      for (int k = first + 1; k < model.membership_offsets[v + 1]; ++k) {
        const int a = model.membership_patch[first], b = model.membership_patch[k];
        const Eigen::Vector3d gap =
            points[first].Canonical(points[first].State(alpha(a), nullptr), scale(a), translation(a)) -
            points[k].Canonical(points[k].State(alpha(b), nullptr), scale(b), translation(b));
        problem->AddResidualBlock(new SkinnedAgreementCost(points[first], points[k], gap, w), nullptr, alpha(a), scale(a),
                                  translation(a), slide(first), alpha(b), scale(b), translation(b), slide(k));
      }
    }
  }
  if (o.parameter_prior > 0.0) {
    const double w = std::sqrt(o.parameter_prior);
    for (int p = 0; p < model.num_patches(); ++p) {
      for (const auto& [block, size] : {std::pair<int, int>{0, num_coefficients}, {kMaxJetCoefficients, 1},
                                        {kMaxJetCoefficients + 1, 3}}) {
        problem->AddResidualBlock(new ParameterPrior(size, w, previous_params.data() + p * kStride + block), nullptr,
                                  params.data() + p * kStride + block);
      }
    }
    if (o.slide) {
      for (size_t k = 0; k < model.membership_patch.size(); ++k) {
        problem->AddResidualBlock(new ParameterPrior(2, w, previous_slides.data() + 2 * k), nullptr,
                                  slide(static_cast<int>(k)));
      }
    }
  }
}

DrapeSolver::~DrapeSolver() = default;

DrapeStepReport DrapeSolver::Step(const std::vector<Eigen::Isometry3d>& rest_to_posed, double k_ext) {
  const auto start = std::chrono::steady_clock::now();
  Impl& m = *impl_;
  const DrapeSolverOptions& o = m.options;
  const int n = garment_.num_vertices();
  if (static_cast<int>(rest_to_posed.size()) != m.body.skeleton.num_joints()) {
    throw std::invalid_argument("DrapeSolver::Step: one transform per joint is needed");
  }
  DrapeStepReport report;
  body_vertices_ = SkinVertices(m.body, rest_to_posed);
  m.distance.SetVertices(body_vertices_);
  m.nearest_stale = true;
  for (int v = 0; v < n; ++v) m.weights.Blend(v, rest_to_posed, &m.skin_linear[v], &m.skin_translation[v]);
  m.previous_params = m.params;
  m.previous_slides = m.slides;

  const auto evaluate = [&]() { m.Positions(model_, &positions_); };
  const auto query = [&]() {
    int inside = 0;
    ParallelFor(n, o.num_threads, [&](int, int v) { m.contact[v] = m.distance.Query(positions_.col(v)); });
    for (int v = 0; v < n; ++v) inside += m.contact[v].distance < 0.0 ? 1 : 0;
    return inside;
  };

  evaluate();
  query();
  // Per-frame data of the vertex terms.
  m.metric_factor = std::sqrt(k_ext);
  for (int v = 0; v < n; ++v) {
    const int owner = model_.membership_offsets[v];
    m.vertex_data[owner].target = 2.0 * m.history1.col(v) - m.history2.col(v);
  }
  for (int pass = 0; pass < o.max_passes; ++pass) {
    // Collisions linearised at the current positions.
    report.collision_terms = 0;
    for (int v = 0; v < n; ++v) {
      const bool near = o.weights.collision > 0.0 && m.contact[v].distance < o.collision_band;
      for (int k = model_.membership_offsets[v]; k < model_.membership_offsets[v + 1]; ++k) {
        VertexTermsData& data = m.vertex_data[k];
        data.collision = near;
        data.closest = m.contact[v].closest;
        data.normal = m.contact[v].normal;
        report.collision_terms += near ? 1 : 0;
      }
    }
    ceres::Solver::Options solver;
    if (n >= o.conjugate_gradients_min_vertices) {
      // Inexact steps (block-Jacobi preconditioned CG on the normal
      // equations): half the time of a sparse Cholesky on the 2k-vertex
      // suit, where forming and factoring J^T J over ~8k parameters
      // dominates; smaller garments get exact steps.
      solver.linear_solver_type = ceres::CGNR;
      solver.eta = o.conjugate_gradients_tolerance;
      // Fewer (50) left a free-falling sheet at 7% of its drop: CG resolves
      // the soft, rigid-like modes last.
      solver.max_linear_solver_iterations = 200;
    } else {
      solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
      solver.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;  // measured faster than CHOLMOD here
    }
    solver.max_num_iterations = pass == 0 ? o.max_iterations : o.max_refine_iterations;
    solver.num_threads = o.num_threads;
    const char* trace = std::getenv("POLYFIT_DRAPE_TRACE");
    solver.logging_type = trace != nullptr && std::string(trace) == "2" ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
    solver.minimizer_progress_to_stdout = solver.logging_type != ceres::SILENT;
    // Weakly determined directions (slides, the jets of small patches) make
    // the Gauss-Newton step huge: starting from an undamped step, LM spent
    // about eight rejected iterations per solve shrinking its region.
    if (m.trust_region_radius <= 0.0) m.trust_region_radius = o.initial_trust_region_radius;
    solver.initial_trust_region_radius = m.trust_region_radius;
    // Do not stop on a small relative change of the cost.
    solver.function_tolerance = 1e-12;
    solver.parameter_tolerance = 1e-12;
    ceres::Solver::Summary summary;
    ceres::Solve(solver, m.problem.get(), &summary);
    if (trace != nullptr) std::fprintf(stderr, "%s\n", summary.FullReport().c_str());
    report.solve_time_s += summary.total_time_in_seconds;
    if (!summary.iterations.empty()) {
      m.trust_region_radius = std::clamp(summary.iterations.back().trust_region_radius, 1e-4, 1e12);
    }
    report.iterations += static_cast<int>(summary.iterations.size()) - 1;
    if (pass == 0) report.initial_cost = summary.initial_cost;
    report.final_cost = summary.final_cost;
    ++report.passes;
    evaluate();
    if (pass + 1 == o.max_passes || query() == 0) break;
  }
  report.finite = positions_.allFinite();
  if (!report.finite) {
    // Keep the last good state rather than propagate NaN.
    m.params = m.previous_params;
    m.slides = m.previous_slides;
    m.trust_region_radius = o.initial_trust_region_radius;
    evaluate();
  }
  m.history2 = m.history1;
  m.history1 = positions_;
  report.time_s = Seconds(start);
  return report;
}

Eigen::VectorXd DrapeSolver::SignedDistances(const Eigen::Matrix3Xd& points) const {
  return impl_->distance.SignedDistances(points, impl_->options.num_threads);
}

Eigen::Matrix3Xd DrapeSolver::ProjectedOutOfBody(double offset) const {
  Eigen::Matrix3Xd out = positions_;
  ParallelFor(static_cast<int>(out.cols()), impl_->options.num_threads, [&](int, int v) {
    const SignedDistanceResult r = impl_->distance.Query(positions_.col(v));
    if (r.distance < 0.0) out.col(v) = r.closest + offset * r.normal;
  });
  return out;
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
  for (int v = 0; v < points.cols(); ++v) d[v] = m.nearest->Query(points.col(v)).distance;
  return d;
}

}  // namespace polyfit
