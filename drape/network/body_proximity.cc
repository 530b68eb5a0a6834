#include "drape/network/body_proximity.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>

#include "polyfit/eval/mesh_metrics.h"
#include "polyfit/jet/jet_basis.h"
#include "polyfit/jet/jet_surface.h"

namespace polyfit {

static_assert(kRimProximityProbes <= RefitPointTree::kMaxGroup, "a patch's probes are queried as one group");

void PatchProbes::SetJointWeights(const Eigen::MatrixXd& weights) {
  num_joints = static_cast<int>(weights.rows());
  joint_begin.assign(1, 0);
  joint.clear();
  weight.clear();
  for (int p = 0; p < weights.cols(); ++p) {
    for (int j = 0; j < weights.rows(); ++j) {
      if (weights(j, p) == 0.0) continue;
      joint.push_back(j);
      weight.push_back(weights(j, p));
    }
    joint_begin.push_back(static_cast<int>(joint.size()));
  }
}

PatchProbes MakePatchProbes(const PolyFitModel& model, const std::vector<double>& areas,
                            const Eigen::MatrixXd& joint_weights, int probes_per_patch) {
  const int n = model.num_patches(), m = probes_per_patch;
  if (static_cast<int>(areas.size()) != n || joint_weights.cols() != n) {
    throw std::invalid_argument("MakePatchProbes: one area and one column of joint weights per patch are needed");
  }
  if (!IsProximityLayout(m)) {
    throw std::invalid_argument("MakePatchProbes: " + std::to_string(m) + " probes per patch (" +
                                std::to_string(kProximityProbes) + " or " + std::to_string(kRimProximityProbes) +
                                " are laid out)");
  }
  PatchProbes probes;
  probes.probes_per_patch = m;
  probes.rest_points.resize(3, m * n);
  probes.uv.resize(2, m * n);
  probes.SetJointWeights(joint_weights);
  for (int p = 0; p < n; ++p) {
    const JetPatch& patch = model.patches[p];
    probes.frames.push_back(patch.frame.rotation);
    // (u, v) are in the frame's scaled units.
    const double rho = std::sqrt(std::max(areas[p], 0.0) / M_PI) / patch.frame.scale;
    const double a = kProbeReach * rho, b = rho / std::sqrt(2.0);
    const double uv[kRimProximityProbes][2] = {{0.0, 0.0}, {a, 0.0}, {-a, 0.0}, {0.0, a}, {0.0, -a},
                                               {b, b},     {-b, b},  {-b, -b},  {b, -b}};
    for (int i = 0; i < m; ++i) {
      probes.uv.col(m * p + i) = Eigen::Vector2d(uv[i][0], uv[i][1]);
      probes.rest_points.col(m * p + i) = patch.PointInWorld(uv[i][0], uv[i][1]);
    }
  }
  return probes;
}

namespace {

// The columns of b made orthonormal, the first kept in direction.
Eigen::Matrix3d GramSchmidt(const Eigen::Matrix3d& b) {
  Eigen::Matrix3d f;
  f.col(0) = b.col(0).normalized();
  f.col(1) = (b.col(1) - f.col(0).dot(b.col(1)) * f.col(0)).normalized();
  f.col(2) = f.col(0).cross(f.col(1));
  return f;
}

}  // namespace

void BodyProximityFeatures(const PatchProbes& probes, const JointTransforms& pose, const PosedBodySamples& body,
                           Eigen::MatrixXd* features, std::vector<int>* hints) {
  BodyProximityFeatures(probes, probes.rest_points, pose, body, features, nullptr, hints);
}

void BodyProximityFeatures(const PatchProbes& probes, const Eigen::Matrix3Xd& points, const JointTransforms& pose,
                           const PosedBodySamples& body, Eigen::MatrixXd* features,
                           Eigen::Matrix3Xd* distance_gradients, std::vector<int>* hints) {
  if (points.cols() != probes.rest_points.cols()) {
    throw std::invalid_argument("BodyProximityFeatures: one point per probe is needed");
  }
  if (static_cast<int>(pose.size()) != probes.num_joints) {
    throw std::invalid_argument("BodyProximityFeatures: one transform per joint of the patches' weights is needed");
  }
  if (static_cast<int>(probes.joint_begin.size()) != probes.num_patches() + 1) {
    throw std::invalid_argument("BodyProximityFeatures: the probes' joint weights were not set (SetJointWeights)");
  }
  const int m = probes.probes_per_patch;
  features->resize(ProximitySize(m), probes.num_patches());
  if (distance_gradients != nullptr) distance_gradients->resize(3, points.cols());
  if (hints != nullptr) hints->resize(points.cols(), -1);
  Eigen::Matrix3Xd posed(3, m);
  SignedDistanceResult hits[kRimProximityProbes];
  for (int p = 0; p < probes.num_patches(); ++p) {
    Eigen::Matrix3d linear = Eigen::Matrix3d::Zero();
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();
    for (int e = probes.joint_begin[p]; e < probes.joint_begin[p + 1]; ++e) {
      const double w = probes.weight[e];
      const int j = probes.joint[e];
      linear += w * pose[j].linear();
      translation += w * pose[j].translation();
    }
    const Eigen::Matrix3d frame = GramSchmidt(linear * probes.frames[p]);
    // The patch's probes lie within its radius of each other: one walk of
    // the body's tree for them all.
    posed = (linear * points.middleCols(m * p, m)).colwise() + translation;
    body.QueryGroup(posed, hints != nullptr ? hints->data() + m * p : nullptr, hits);
    for (int i = 0; i < m; ++i) {
      const SignedDistanceResult& hit = hits[i];
      if (hints != nullptr) (*hints)[m * p + i] = hit.face;
      const double scaled = hit.distance / kProximityScale;
      const double d = std::clamp(scaled, -kProximityClamp, kProximityClamp);
      auto out = features->col(p).segment<kProximityValuesPerProbe>(kProximityValuesPerProbe * i);
      out[0] = std::isfinite(d) ? d : kProximityClamp;
      out.tail<3>() = frame.transpose() * hit.normal;
      if (distance_gradients != nullptr) {
        const bool inside = std::abs(scaled) < kProximityClamp;  // false for NaN
        distance_gradients->col(m * p + i) =
            inside ? Eigen::Vector3d(linear.transpose() * hit.normal / kProximityScale) : Eigen::Vector3d::Zero();
      }
    }
  }
}

namespace {

// Patch p's alpha, s and T in DrapeSolver's layout.
struct PatchView {
  const double* alpha;
  double s;
  Eigen::Vector3d t;
};
PatchView ViewPatch(const std::vector<double>& parameters, int stride, int num_coefficients, int p) {
  const double* x = parameters.data() + static_cast<size_t>(p) * stride;
  return {x, x[num_coefficients],
          Eigen::Vector3d(x[num_coefficients + 1], x[num_coefficients + 2], x[num_coefficients + 3])};
}

// z(u, v) of the jet alpha (k coefficients), with its monomials.
double JetHeight(int jet_order, int k, const double* alpha, double u, double v, double* monomials) {
  JetMonomials(jet_order, u, v, monomials);
  double z = 0.0;
  for (int c = 0; c < k; ++c) z += alpha[c] * monomials[c];
  return z;
}

int CheckedCoefficients(const PatchProbes& probes, const std::vector<double>& parameters, int jet_order, int stride,
                        const char* who) {
  if (jet_order < 0 || jet_order > kMaxJetOrder) throw std::invalid_argument(std::string(who) + ": bad jet order");
  const int k = NumJetCoefficients(jet_order);
  if (stride < k + 4 || parameters.size() != static_cast<size_t>(stride) * probes.num_patches()) {
    throw std::invalid_argument(std::string(who) + ": the patch parameters do not fit the probes' patches");
  }
  return k;
}

}  // namespace

void PlaceProbes(const PatchProbes& probes, const std::vector<double>& patch_parameters, int jet_order, int stride,
                 Eigen::Matrix3Xd* points) {
  const int k = CheckedCoefficients(probes, patch_parameters, jet_order, stride, "PlaceProbes");
  const int m = probes.probes_per_patch;
  points->resize(3, probes.uv.cols());
  for (int p = 0; p < probes.num_patches(); ++p) {
    const PatchView patch = ViewPatch(patch_parameters, stride, k, p);
    for (int i = 0; i < m; ++i) {
      const double u = probes.uv(0, m * p + i), v = probes.uv(1, m * p + i);
      const double z = EvaluateJetHeight(jet_order, patch.alpha, u, v);
      points->col(m * p + i) = patch.s * (probes.frames[p] * Eigen::Vector3d(u, v, z)) + patch.t;
    }
  }
}

void ChainProbesToPatchParameters(const PatchProbes& probes, const std::vector<double>& patch_parameters, int jet_order,
                                  int stride, const Eigen::Matrix3Xd& distance_gradients,
                                  const Eigen::MatrixXd& d_features, std::vector<double>* gradient) {
  const int k = CheckedCoefficients(probes, patch_parameters, jet_order, stride, "ChainProbesToPatchParameters");
  const int m = probes.probes_per_patch;
  if (gradient->size() != patch_parameters.size() || distance_gradients.cols() != probes.uv.cols() ||
      d_features.rows() != ProximitySize(m) || d_features.cols() != probes.num_patches()) {
    throw std::invalid_argument("ChainProbesToPatchParameters: sizes do not fit the probes");
  }
  double monomials[kMaxJetCoefficients];
  for (int p = 0; p < probes.num_patches(); ++p) {
    const PatchView patch = ViewPatch(patch_parameters, stride, k, p);
    double* g = gradient->data() + static_cast<size_t>(p) * stride;
    for (int i = 0; i < m; ++i) {
      // dL/dX for the probe's canonical point X = s R_0 [u, v, z] + T.
      const Eigen::Vector3d d_x = d_features(kProximityValuesPerProbe * i, p) * distance_gradients.col(m * p + i);
      if (d_x.isZero(0.0)) continue;
      const double u = probes.uv(0, m * p + i), v = probes.uv(1, m * p + i);
      const double z = JetHeight(jet_order, k, patch.alpha, u, v, monomials);
      const Eigen::Vector3d r_x = probes.frames[p].transpose() * d_x;  // R_0^T dL/dX
      for (int c = 0; c < k; ++c) g[c] += patch.s * r_x.z() * monomials[c];
      g[k] += r_x.dot(Eigen::Vector3d(u, v, z));
      for (int a = 0; a < 3; ++a) g[k + 1 + a] += d_x[a];
    }
  }
}

PosedBodySamples::PosedBodySamples(const SkinnedBody& body, double spacing) : num_joints_(body.skeleton.num_joints()) {
  const Eigen::Matrix3Xd& v = body.mesh.vertices;
  if (!(spacing > 0.0) || v.cols() == 0) throw std::invalid_argument("PosedBodySamples: no body or spacing <= 0");
  // Per occupied cell, the vertex nearest its centre (ties: the first).
  std::map<std::array<long, 3>, std::pair<double, int>> cells;
  for (int i = 0; i < v.cols(); ++i) {
    std::array<long, 3> cell;
    double d2 = 0.0;
    for (int a = 0; a < 3; ++a) {
      cell[a] = static_cast<long>(std::floor(v(a, i) / spacing));
      const double offset = v(a, i) - (cell[a] + 0.5) * spacing;
      d2 += offset * offset;
    }
    const auto [it, added] = cells.emplace(cell, std::make_pair(d2, i));
    if (!added && d2 < it->second.first) it->second = {d2, i};
  }
  std::vector<int> chosen;
  for (const auto& [cell, best] : cells) chosen.push_back(best.second);
  std::sort(chosen.begin(), chosen.end());
  const Eigen::Matrix3Xd normals = VertexNormals(body.mesh);
  const int n = static_cast<int>(chosen.size());
  rest_points_.resize(3, n);
  rest_normals_.resize(3, n);
  offset_.push_back(0);
  for (int s = 0; s < n; ++s) {
    const int i = chosen[s];
    rest_points_.col(s) = v.col(i);
    rest_normals_.col(s) = normals.col(i);
    for (int k = body.weight_offsets[i]; k < body.weight_offsets[i + 1]; ++k) {
      joint_.push_back(body.weight_joint[k]);
      weight_.push_back(body.weight_value[k]);
    }
    offset_.push_back(static_cast<int>(joint_.size()));
  }
  points_ = rest_points_;
  normals_ = rest_normals_;
  tree_ = std::make_unique<RefitPointTree>(points_);
}

void PosedBodySamples::Pose(const JointTransforms& pose) {
  if (static_cast<int>(pose.size()) != num_joints_) {
    throw std::invalid_argument("PosedBodySamples::Pose: one transform per joint is needed");
  }
  for (int s = 0; s < num_samples(); ++s) {
    Eigen::Matrix3d linear = Eigen::Matrix3d::Zero();
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();
    for (int k = offset_[s]; k < offset_[s + 1]; ++k) {
      linear += weight_[k] * pose[joint_[k]].linear();
      translation += weight_[k] * pose[joint_[k]].translation();
    }
    points_.col(s) = linear * rest_points_.col(s) + translation;
    const Eigen::Vector3d n = linear * rest_normals_.col(s);
    const double length = n.norm();
    normals_.col(s) = length > 0.0 ? Eigen::Vector3d(n / length) : n;
  }
  tree_->Refit(points_);
}

SignedDistanceResult PosedBodySamples::Result(const Eigen::Vector3d& point, int nearest) const {
  SignedDistanceResult r;
  r.face = nearest;
  if (r.face < 0) {  // a point with a NaN: no sample is nearest
    r.distance = std::numeric_limits<double>::quiet_NaN();
    r.normal.setZero();
    return r;
  }
  r.closest = points_.col(r.face);
  r.normal = normals_.col(r.face);
  r.distance = (point - r.closest).dot(r.normal);
  return r;
}

SignedDistanceResult PosedBodySamples::Query(const Eigen::Vector3d& point, int hint) const {
  double d2 = 0.0;
  return Result(point, tree_->Nearest(point, &d2, hint));
}

void PosedBodySamples::QueryGroup(const Eigen::Matrix3Xd& points, const int* hints,
                                  SignedDistanceResult* results) const {
  int nearest[RefitPointTree::kMaxGroup];
  double d2[RefitPointTree::kMaxGroup];
  tree_->NearestGroup(points, hints, nearest, d2);
  for (int i = 0; i < points.cols(); ++i) results[i] = Result(points.col(i), nearest[i]);
}

}  // namespace polyfit
