// DrapeSolver::SolveWarps (drape_solver.h): each patch's warp (and
// translation) re-solved for given jets, patch by patch in Gauss-Seidel
// sweeps by colour.
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "drape/simulate/drape_solver.h"
#include "drape/simulate/drape_solver_impl.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {

void DrapeSolver::Impl::CollectPatchWarpTerms(const PolyFitModel& model) {
  members_by_patch.assign(model.num_patches(), {});
  member_index.assign(model.num_memberships(), -1);
  for (int k = 0; k < model.num_memberships(); ++k) {
    std::vector<int>& members = members_by_patch[model.membership_patch[k]];
    member_index[k] = static_cast<int>(members.size());
    members.push_back(k);
  }
  edges_by_patch.assign(model.num_patches(), {});
  for (const PatchEdge& e : patch_edges) {
    edges_by_patch[model.membership_patch[e.mi]].push_back({e.edge, member_index[e.mi], member_index[e.mj]});
  }
  seam_members_by_patch.assign(model.num_patches(), {});
  for (int v = 0; v < model.num_vertices(); ++v) {
    const IndexRange range = model.memberships(v);
    if (range.size() < 2) continue;
    for (int k : range) seam_members_by_patch[model.membership_patch[k]].push_back(member_index[k]);
  }
  near_members_by_patch.assign(model.num_patches(), {});
  // Greedy colouring of the patches that share a vertex.
  std::vector<std::vector<int>> neighbours(model.num_patches());
  for (int v = 0; v < model.num_vertices(); ++v) {
    const IndexRange range = model.memberships(v);
    for (int a : range) {
      for (int b : range) {
        if (a != b) neighbours[model.membership_patch[a]].push_back(model.membership_patch[b]);
      }
    }
  }
  std::vector<int> colour(model.num_patches(), -1);
  patches_by_colour.clear();
  for (int p = 0; p < model.num_patches(); ++p) {
    std::vector<char> taken(patches_by_colour.size() + 1, 0);
    for (int q : neighbours[p]) {
      if (colour[q] >= 0) taken[colour[q]] = 1;
    }
    colour[p] = static_cast<int>(std::find(taken.begin(), taken.end(), 0) - taken.begin());
    if (colour[p] == static_cast<int>(patches_by_colour.size())) patches_by_colour.emplace_back();
    patches_by_colour[colour[p]].push_back(p);
  }
}

void DrapeSolver::Impl::PatchPoints(int p, const double* c, const double* t, std::vector<Eigen::Vector3d>* x,
                                    std::vector<Eigen::Matrix<double, 3, 2, Eigen::RowMajor>>* dx_dslide) {
  const std::vector<int>& members = members_by_patch[p];
  x->resize(members.size());
  if (dx_dslide != nullptr) dx_dslide->resize(members.size());
  for (size_t i = 0; i < members.size(); ++i) {
    const int k = members[i];
    double slid[2];
    WarpSlide(k, c, slid);
    const PatchPointState state = points[k].State(alpha(p), slid);
    (*x)[i] = points[k].Position(state, scale(p), t);
    if (dx_dslide == nullptr) continue;
    double* jacobians[4] = {nullptr, nullptr, nullptr, (*dx_dslide)[i].data()};
    points[k].Chain<3>(Eigen::Matrix3d::Identity(), state, scale(p), jacobians, 3);
  }
}

namespace {

// A patch's residuals and their rows over its unknowns, gathered and then
// multiplied out at once: a rank-k update runs blocked, where one rank-1
// update per residual was most of a sweep. Kept per thread across calls.
class WarpRows {
 public:
  // Room for `most` rows of `width` values (grown rarely).
  void Start(int most, int width) {
    count_ = 0;
    if (jacobian_.rows() < most || jacobian_.cols() != width) {
      jacobian_.resize(2 * most, width);
      residuals_.resize(2 * most);
    }
  }
  // The next row, for residual r (its values to be filled).
  auto Add(double r) {
    residuals_[count_] = r;
    return jacobian_.row(count_++);
  }
  // J^T J and J^T r over the first `size` unknowns.
  template <typename System, typename Vector>
  void NormalEquations(int size, System* jtj, Vector* jtr) const {
    const auto j = jacobian_.topLeftCorner(count_, size);
    jtj->setZero(size, size);
    jtj->template selfadjointView<Eigen::Lower>().rankUpdate(j.transpose());
    jtj->template triangularView<Eigen::StrictlyUpper>() = jtj->transpose();
    jtr->noalias() = j.transpose() * residuals_.head(count_);
  }

 private:
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> jacobian_;
  Eigen::VectorXd residuals_;
  int count_ = 0;
};

}  // namespace

double DrapeSolver::Impl::PatchEdgeStrain(int p, const double* c, WarpSystem* jtj, WarpVector* jtr) {
  const int n = num_warp;
  const std::vector<int>& members = members_by_patch[p];
  // Each member's point once (buffers kept per thread across calls).
  thread_local std::vector<Eigen::Vector3d> x;
  thread_local std::vector<Eigen::Matrix<double, 3, 2, Eigen::RowMajor>> dx_dslide;
  PatchPoints(p, c, warp_solve_translation ? c + 2 * n : translation(p), &x, jtj != nullptr ? &dx_dslide : nullptr);
  const int size = 2 * n + (warp_solve_translation ? 3 : 0);
  thread_local WarpRows rows;
  if (jtj != nullptr) {
    rows.Start(static_cast<int>(edges_by_patch[p].size() + 3 * seam_members_by_patch[p].size() +
                                near_members_by_patch[p].size()),
               kMaxWarpUnknowns);
  }
  // Adds residual r with derivative dr_dx at member i (and -dr_dx at
  // member j >= 0) to the system.
  const auto add = [&](double r, const Eigen::Matrix<double, 1, 3>& dr_dx, int i, int j) {
    auto row = rows.Add(r).head(size);
    row.setZero();
    for (const auto& [m, sign] : {std::pair{i, 1.0}, std::pair{j, -1.0}}) {
      if (m < 0) continue;
      const Eigen::Matrix<double, 1, 2> dr_dslide = sign * dr_dx * dx_dslide[m];
      const double* phi = warp_monomials(members[m]);
      for (int l = 0; l < n; ++l) {
        row[l] += dr_dslide[0] * phi[l];
        row[n + l] += dr_dslide[1] * phi[l];
      }
      if (warp_solve_translation) {
        row.tail<3>() += sign * (dr_dx * skin_linear[membership_vertex[members[m]]]).transpose();
      }
    }
  };
  double cost = 0.0;
  for (const auto& [edge, i, j] : edges_by_patch[p]) {
    const double rest_length = rest.edge_length[edge];
    const double w = std::sqrt(edge_area[edge]) / rest_length;
    const Eigen::Vector3d d = x[i] - x[j];
    const double length = d.norm();
    const double r = w * (length - rest_length);
    cost += 0.5 * r * r;
    if (jtj != nullptr && length > 0.0) add(r, w * d.transpose() / length, i, j);
  }
  // A seam point pulled to its vertex's other points, as stiff as the
  // loss's agreement term: without it the patch drifts along itself (edge
  // lengths barely see a rigid slide) away from its neighbours.
  for (int i : seam_members_by_patch[p]) {
    const int k = members[i];
    const double w = std::sqrt(rest.vertex_area[membership_vertex[k]]) / mean_edge;
    const Eigen::Vector3d r = w * (x[i] - seam_targets.col(k));
    cost += 0.5 * r.squaredNorm();
    if (jtj == nullptr) continue;
    for (int axis = 0; axis < 3; ++axis) add(r[axis], w * Eigen::Matrix<double, 1, 3>::Unit(axis), i, -1);
  }
  // The collision term, in the same units (the loss's k_c kappa / 2
  // max(eps - d, 0)^2 over its stretch factor 2 k_mi sigma mu), at a
  // fraction of each vertex's margin.
  const DrapePhysicsOptions& o = options.physics;
  const double collision_weight =
      std::sqrt(o.weights.collision * o.collision_stiffness / (2.0 * stretch_weight() * o.material.mu));
  for (int i : near_members_by_patch[p]) {
    const int v = membership_vertex[members[i]];
    const SignedDistanceResult& hit = contact[v];
    const double gap = kWarpMarginScale * margin[v] - hit.normal.dot(x[i] - hit.closest);
    if (!(gap > 0.0)) continue;
    const double r = collision_weight * gap;
    cost += 0.5 * r * r;
    if (jtj != nullptr) add(r, -collision_weight * hit.normal.transpose(), i, -1);
  }
  if (jtj != nullptr) rows.NormalEquations(size, jtj, jtr);
  return cost;
}

void DrapeSolver::Impl::UpdateSeamPoints(int p, const double* warp, const double* t) {
  thread_local std::vector<Eigen::Vector3d> x;
  PatchPoints(p, warp, t, &x, nullptr);
  for (int i : seam_members_by_patch[p]) seam_points.col(members_by_patch[p][i]) = x[i];
}

void DrapeSolver::Impl::UpdateSeamTargets(const PolyFitModel& model) {
  seam_targets.resize(3, model.num_memberships());
  for (int v = 0; v < model.num_vertices(); ++v) {
    const IndexRange range = model.memberships(v);
    if (range.size() < 2) continue;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int k : range) sum += seam_points.col(k);
    // Each point's target: the mean of its vertex's other points.
    const double others = static_cast<double>(range.size() - 1);
    for (int k : range) seam_targets.col(k) = (sum - seam_points.col(k)) / others;
  }
}

namespace {

// x = H^-1 b for a small symmetric positive definite H by Cholesky,
// written out (Eigen's dense decompositions are kept out of code linked
// with Ceres: cmake/PolyFitHelpers.cmake). False if H is not positive
// definite.
template <typename Matrix, typename Vector>
bool SolveSmallSpd(Matrix h, const Vector& b, Vector* x) {
  const Eigen::Index n = h.rows();
  for (Eigen::Index j = 0; j < n; ++j) {
    double d = h(j, j);
    for (Eigen::Index k = 0; k < j; ++k) d -= h(j, k) * h(j, k);
    if (!(d > 0.0)) return false;
    h(j, j) = std::sqrt(d);
    for (Eigen::Index i = j + 1; i < n; ++i) {
      double v = h(i, j);
      for (Eigen::Index k = 0; k < j; ++k) v -= h(i, k) * h(j, k);
      h(i, j) = v / h(j, j);
    }
  }
  *x = b;
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index k = 0; k < i; ++k) (*x)[i] -= h(i, k) * (*x)[k];
    (*x)[i] /= h(i, i);
  }
  for (Eigen::Index i = n - 1; i >= 0; --i) {
    for (Eigen::Index k = i + 1; k < n; ++k) (*x)[i] -= h(k, i) * (*x)[k];
    (*x)[i] /= h(i, i);
  }
  return true;
}

}  // namespace

// Levenberg-Marquardt on the patch's edge strain: the damping scales the
// system's diagonal, grows on a rejected step and shrinks on an accepted one.
void DrapeSolver::Impl::SolvePatchWarp(int p, int iterations, double* warp, double* translation_out) {
  const int size = 2 * num_warp + (warp_solve_translation ? 3 : 0);
  WarpSystem jtj;
  WarpVector jtr, step;
  WarpVector c(size);
  c.head(2 * num_warp) = Eigen::Map<const Eigen::VectorXd>(warp, 2 * num_warp);
  if (warp_solve_translation) c.tail<3>() = Eigen::Map<const Eigen::Vector3d>(translation_out);
  double cost = PatchEdgeStrain(p, c.data(), &jtj, &jtr), damping = 1e-4;
  for (int it = 0; it < iterations && cost > 0.0; ++it) {
    WarpSystem h = jtj;
    h.diagonal() *= 1.0 + damping;
    h.diagonal().array() += 1e-12 * (1.0 + jtj.diagonal().maxCoeff());
    if (!SolveSmallSpd(h, WarpVector(-jtr), &step)) break;
    const WarpVector tried = c + step;
    const double tried_cost = PatchEdgeStrain(p, tried.data(), nullptr, nullptr);
    if (std::isfinite(tried_cost) && tried_cost < cost) {
      c = tried;
      cost = PatchEdgeStrain(p, c.data(), &jtj, &jtr);
      damping = std::max(damping / 3.0, 1e-8);
    } else {
      damping *= 8.0;
    }
  }
  std::copy(c.data(), c.data() + 2 * num_warp, warp);
  if (warp_solve_translation) std::copy(c.data() + 2 * num_warp, c.data() + size, translation_out);
}

std::vector<double> DrapeSolver::SolveWarps(const std::vector<double>& patch_parameters, int sweeps, int iterations,
                                            bool move_translations) {
  Impl& m = *impl_;
  m.warp_solve_translation = move_translations;
  if (m.num_warp == 0) throw std::logic_error("DrapeSolver::SolveWarps: the patches have no warp (warp_order < 0)");
  if (m.edges_by_patch.empty()) m.CollectPatchWarpTerms(model_);
  std::vector<double> out = patch_parameters;
  const int stride = m.packed_stride(), begin = m.num_coefficients + 4;
  // The solver's own state is put back at the end (as PositionsOf does).
  m.saved_params = m.params;
  m.saved_slides = m.slides;
  // The body where the given parameters put the garment.
  m.SetPatchParameters(model_, patch_parameters);
  m.warp_positions.resize(3, model_.num_vertices());
  m.Positions(model_, &m.warp_positions);
  m.QueryContacts(m.warp_positions);
  for (auto& members : m.near_members_by_patch) members.clear();
  if (m.options.physics.weights.collision > 0.0) {
    for (int k = 0; k < model_.num_memberships(); ++k) {
      if (m.contact[m.membership_vertex[k]].distance < m.options.physics.collision_band) {
        m.near_members_by_patch[model_.membership_patch[k]].push_back(m.member_index[k]);
      }
    }
  }
  // Gauss-Seidel sweeps by colour: each colour's patches together, against
  // their neighbours' latest points.
  m.seam_points.resize(3, model_.num_memberships());
  const int t_begin = m.num_coefficients + 1;
  for (int p = 0; p < model_.num_patches(); ++p) {
    m.UpdateSeamPoints(p, out.data() + p * stride + begin, out.data() + p * stride + t_begin);
  }
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    for (const std::vector<int>& patches : m.patches_by_colour) {
      m.UpdateSeamTargets(model_);
      ParallelFor(static_cast<int>(patches.size()), m.options.num_threads, [&](int, int i) {
        double* patch = out.data() + patches[i] * stride;
        m.SolvePatchWarp(patches[i], iterations, patch + begin, patch + t_begin);
        m.UpdateSeamPoints(patches[i], patch + begin, patch + t_begin);
      });
    }
  }
  m.params = m.saved_params;
  m.slides = m.saved_slides;
  return out;
}

}  // namespace polyfit
