#include "drape/network/onefit_features.h"

#include <cmath>
#include <stdexcept>

#include "polyfit/jet/jet_basis.h"

namespace polyfit {
namespace {

constexpr double kPi = 3.14159265358979323846;

// gamma(p): p, then sin and cos of 2^l pi p per frequency (3 (1 + 2L)).
void Encode(const Eigen::Vector3d& p, double* out) {
  int k = 0;
  for (int c = 0; c < 3; ++c) out[k++] = p[c];
  for (int l = 0; l < kPositionalFrequencies; ++l) {
    const double f = std::ldexp(kPi, l);
    for (int c = 0; c < 3; ++c) {
      out[k++] = std::sin(f * p[c]);
      out[k++] = std::cos(f * p[c]);
    }
  }
}

constexpr int kEncodedSize = 3 * (1 + 2 * kPositionalFrequencies);

// The first two columns of a rotation: a continuous 6D descriptor.
void SixD(const Eigen::Matrix3d& r, double* out) {
  for (int c = 0; c < 2; ++c) {
    for (int k = 0; k < 3; ++k) out[3 * c + k] = r(k, c);
  }
}

// Per joint, its rotation relative to its parent's (6D each).
Eigen::VectorXd LocalRotations(const Skeleton& skeleton, const JointTransforms& pose) {
  const int n = skeleton.num_joints();
  if (static_cast<int>(pose.size()) != n)
    throw std::invalid_argument("BodyFeatures: one transform per joint is needed");
  Eigen::VectorXd out(6 * n);
  for (int j = 0; j < n; ++j) {
    const int p = skeleton.parents[j];
    const Eigen::Matrix3d local =
        p < 0 ? pose[j].linear() : Eigen::Matrix3d(pose[p].linear().transpose() * pose[j].linear());
    SixD(local, out.data() + 6 * j);
  }
  return out;
}

// The root's three 6D blocks without its heading (RootRotation::kHeadingFree).
void HeadingFreeRoot(const JointTransforms& before_previous, const JointTransforms& previous,
                     const JointTransforms& now, int num_joints, double* out) {
  const Eigen::Matrix3d r0 = now[0].linear(), r1 = previous[0].linear(), r2 = before_previous[0].linear();
  const Eigen::Matrix3d tilt = Eigen::AngleAxisd(-HeadingAngle(r0), Eigen::Vector3d::UnitY()) * r0;
  double identity[6];
  SixD(Eigen::Matrix3d::Identity(), identity);
  SixD(tilt, out);
  SixD(r1.transpose() * r0, out + 6 * num_joints);
  SixD(r2.transpose() * r1, out + 12 * num_joints);
  for (int c = 0; c < 6; ++c) {
    out[6 * num_joints + c] -= identity[c];
    out[12 * num_joints + c] -= identity[c];
  }
}

// Where the root is, and how it is turned (the root's rest head, posed).
Eigen::Vector3d RootPosition(const Skeleton& skeleton, const JointTransforms& pose) {
  return pose[0] * Eigen::Vector3d(skeleton.rest_heads.col(0));
}

}  // namespace

int PatchFeatureSize(int jet_order, int num_joints) {
  return NumJetCoefficients(jet_order) + 1 + 6 + kEncodedSize + num_joints + kEncodedSize;
}

double HeadingAngle(const Eigen::Matrix3d& rotation) {
  const Eigen::Vector3d l = rotation.col(0), f = rotation.col(2);
  // Bending forward or back turns the body about l, which stays level.
  if (l.x() * l.x() + l.z() * l.z() > 1e-2) return std::atan2(-l.z(), l.x());
  return f.x() * f.x() + f.z() * f.z() > 1e-12 ? std::atan2(f.x(), f.z()) : 0.0;
}

int BodyFeatureSize(int num_joints) { return 3 * 6 * num_joints + 2 * 3 + 2 * 3 + 5; }

Eigen::MatrixXd PatchJointWeights(const PolyFitModel& model, const SkinWeights& weights, int num_joints) {
  const int num_patches = model.num_patches();
  if (weights.num_vertices() != model.num_vertices()) {
    throw std::invalid_argument("PatchJointWeights: skinning weights for another garment");
  }
  Eigen::MatrixXd patch_weights = Eigen::MatrixXd::Zero(num_joints, num_patches);
  Eigen::VectorXd members = Eigen::VectorXd::Zero(num_patches);
  for (int v = 0; v < model.num_vertices(); ++v) {
    for (int k : model.memberships(v)) {
      const int p = model.membership_patch[k];
      for (int i = weights.offsets[v]; i < weights.offsets[v + 1]; ++i) {
        if (weights.joint[i] < 0 || weights.joint[i] >= num_joints) {
          throw std::invalid_argument("PatchJointWeights: a skinning weight names a joint the rig lacks");
        }
        patch_weights(weights.joint[i], p) += weights.value[i];
      }
      members[p] += 1.0;
    }
  }
  for (int p = 0; p < num_patches; ++p) {
    if (members[p] > 0.0) patch_weights.col(p) /= members[p];
  }
  return patch_weights;
}

Eigen::MatrixXd LocalPoseFeatures(const Eigen::VectorXd& body_features, const Eigen::MatrixXd& joint_weights) {
  const int n = static_cast<int>(joint_weights.rows());
  if (body_features.size() != BodyFeatureSize(n)) {
    throw std::invalid_argument("LocalPoseFeatures: body features of another rig");
  }
  // Per joint its three 6D blocks: rotations at t, then the two changes.
  Eigen::Matrix<double, kLocalPoseSize, Eigen::Dynamic> blocks(kLocalPoseSize, n);
  for (int j = 0; j < n; ++j) {
    for (int b = 0; b < 3; ++b) blocks.block<6, 1>(6 * b, j) = body_features.segment<6>(6 * (b * n + j));
  }
  return blocks * joint_weights;
}

Eigen::VectorXd JointReach(const SkinWeights& weights, const Skeleton& skeleton) {
  const int n = skeleton.num_joints();
  Eigen::VectorXd reach = Eigen::VectorXd::Zero(n), subtree(n);
  for (int v = 0; v < weights.num_vertices(); ++v) {
    subtree.setZero();
    for (int i = weights.offsets[v]; i < weights.offsets[v + 1]; ++i) {
      if (weights.joint[i] < 0 || weights.joint[i] >= n) {
        throw std::invalid_argument("JointReach: skinning weights of another rig");
      }
      subtree[weights.joint[i]] += weights.value[i];
    }
    // Parents precede children: one backward pass sums every subtree.
    for (int j = n - 1; j > 0; --j) {
      if (skeleton.parents[j] >= 0) subtree[skeleton.parents[j]] += subtree[j];
    }
    reach = reach.cwiseMax(subtree);
  }
  return reach;
}

Eigen::VectorXd BodyFeatureMask(const SkinWeights& weights, const Skeleton& skeleton, double min_reach) {
  const int n = skeleton.num_joints();
  Eigen::VectorXd mask = Eigen::VectorXd::Ones(BodyFeatureSize(n));
  if (min_reach <= 0.0) return mask;
  const Eigen::VectorXd reach = JointReach(weights, skeleton);
  for (int j = 0; j < n; ++j) {
    if (reach[j] >= min_reach) continue;
    for (int b = 0; b < 3; ++b) mask.segment<6>(6 * (b * n + j)).setZero();
  }
  return mask;
}

Eigen::MatrixXd PatchFeatures(const PolyFitModel& model, const std::vector<double>& rest_parameters,
                              const Eigen::MatrixXd& units, int jet_order, const SkinWeights& weights,
                              const Skeleton& skeleton) {
  const int num_patches = model.num_patches();
  if (num_patches == 0) throw std::invalid_argument("PatchFeatures: the garment has no patch");
  const int stride = static_cast<int>(rest_parameters.size()) / num_patches;
  const int num_coefficients = NumJetCoefficients(jet_order);
  if (stride * num_patches != static_cast<int>(rest_parameters.size()) || jet_order < 1 ||
      stride < num_coefficients + 4) {
    throw std::invalid_argument("PatchFeatures: rest parameters do not fit the patches");
  }
  if (units.cols() != num_patches || units.rows() < num_coefficients + 4) {
    throw std::invalid_argument("PatchFeatures: output units do not fit the patches");
  }
  const int num_joints = skeleton.num_joints();
  // Checks that the weights are the garment's.
  const Eigen::MatrixXd patch_weights = PatchJointWeights(model, weights, num_joints);
  const int size = num_coefficients + 1 + 6 + kEncodedSize + num_joints + kEncodedSize;
  Eigen::MatrixXd features(size, num_patches);
  for (int p = 0; p < num_patches; ++p) {
    const double* rest = rest_parameters.data() + p * stride;
    double* out = features.col(p).data();
    int k = 0;
    for (int c = 0; c < num_coefficients; ++c) out[k++] = rest[c] / units(c, p);
    out[k++] = std::log(std::max(units(num_coefficients + 1, p), 1e-12));
    SixD(model.patches[p].frame.rotation, out + k);
    k += 6;
    const Eigen::Vector3d centre(rest[num_coefficients + 1], rest[num_coefficients + 2], rest[num_coefficients + 3]);
    Encode(centre, out + k);
    k += kEncodedSize;
    const Eigen::VectorXd w = patch_weights.col(p);
    for (int j = 0; j < num_joints; ++j) out[k++] = w[j];
    Eigen::Vector3d offset = Eigen::Vector3d::Zero();
    for (int j = 0; j < num_joints; ++j) offset += w[j] * (centre - skeleton.rest_heads.col(j));
    Encode(offset, out + k);
  }
  return features;
}

Eigen::VectorXd BodyFeatures(const Skeleton& skeleton, const JointTransforms& before_previous,
                             const JointTransforms& previous, const JointTransforms& now, double fps,
                             const BodyShape& shape, RootRotation root) {
  if (!(fps > 0.0)) throw std::invalid_argument("BodyFeatures: fps must be positive");
  const int n = skeleton.num_joints();
  const Eigen::VectorXd r2 = LocalRotations(skeleton, before_previous);
  const Eigen::VectorXd r1 = LocalRotations(skeleton, previous);
  const Eigen::VectorXd r0 = LocalRotations(skeleton, now);
  Eigen::VectorXd out(BodyFeatureSize(n));
  int k = 0;
  out.segment(k, 6 * n) = r0;
  k += 6 * n;
  out.segment(k, 6 * n) = r0 - r1;
  k += 6 * n;
  out.segment(k, 6 * n) = r1 - r2;
  k += 6 * n;
  if (root == RootRotation::kHeadingFree) HeadingFreeRoot(before_previous, previous, now, n, out.data());
  const Eigen::Vector3d down(0.0, -1.0, 0.0);
  for (const JointTransforms* pose : {&now, &previous}) {
    out.segment<3>(k) = (*pose)[0].linear().transpose() * down;
    k += 3;
  }
  const Eigen::Vector3d v0 = (RootPosition(skeleton, now) - RootPosition(skeleton, previous)) * fps;
  const Eigen::Vector3d v1 = (RootPosition(skeleton, previous) - RootPosition(skeleton, before_previous)) * fps;
  out.segment<3>(k) = now[0].linear().transpose() * v0;
  k += 3;
  out.segment<3>(k) = previous[0].linear().transpose() * v1;
  k += 3;
  for (double value : {shape.gender, shape.muscle, shape.weight, shape.height, shape.proportions}) out[k++] = value;
  return out;
}

FeatureNormalizer FeatureNormalizer::Fit(const Eigen::MatrixXd& samples) {
  FeatureNormalizer n;
  n.mean = samples.rowwise().mean();
  n.inv_std.resize(samples.rows());
  for (Eigen::Index i = 0; i < samples.rows(); ++i) {
    const double variance = samples.cols() > 1 ? (samples.row(i).array() - n.mean[i]).square().mean() : 0.0;
    // A feature constant in training carries nothing the network learnt
    // to read: it is ignored rather than fed to untrained weights.
    n.inv_std[i] = variance > 1e-12 ? 1.0 / std::max(std::sqrt(variance), kMinFeatureSpread) : 0.0;
  }
  return n;
}

Eigen::MatrixXd FeatureNormalizer::Apply(const Eigen::MatrixXd& x) const {
  if (x.rows() != mean.size()) throw std::invalid_argument("FeatureNormalizer: the features have the wrong size");
  return ((x.colwise() - mean).array().colwise() * inv_std.array()).cwiseMax(-kFeatureClamp).cwiseMin(kFeatureClamp);
}

}  // namespace polyfit
