#include "drape/network/body_proximity.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace polyfit {

PatchProbes MakePatchProbes(const PolyFitModel& model, const std::vector<double>& areas,
                            const Eigen::MatrixXd& joint_weights) {
  const int n = model.num_patches();
  if (static_cast<int>(areas.size()) != n || joint_weights.cols() != n) {
    throw std::invalid_argument("MakePatchProbes: one area and one column of joint weights per patch are needed");
  }
  PatchProbes probes;
  probes.rest_points.resize(3, kProximityProbes * n);
  probes.joint_weights = joint_weights;
  for (int p = 0; p < n; ++p) {
    const JetPatch& patch = model.patches[p];
    probes.frames.push_back(patch.frame.rotation);
    // (u, v) are in the frame's scaled units.
    const double a = kProbeReach * std::sqrt(std::max(areas[p], 0.0) / M_PI) / patch.frame.scale;
    const double uv[kProximityProbes][2] = {{0.0, 0.0}, {a, 0.0}, {-a, 0.0}, {0.0, a}, {0.0, -a}};
    for (int i = 0; i < kProximityProbes; ++i) {
      probes.rest_points.col(kProximityProbes * p + i) = patch.PointInWorld(uv[i][0], uv[i][1]);
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

void BodyProximityFeatures(const PatchProbes& probes, const JointTransforms& pose, const BodySignedDistance& body,
                           Eigen::MatrixXd* features, std::vector<int>* hints) {
  const int num_joints = static_cast<int>(probes.joint_weights.rows());
  if (static_cast<int>(pose.size()) != num_joints) {
    throw std::invalid_argument("BodyProximityFeatures: one transform per joint of the patches' weights is needed");
  }
  features->resize(kProximitySize, probes.num_patches());
  if (hints != nullptr) hints->resize(probes.rest_points.cols(), -1);
  for (int p = 0; p < probes.num_patches(); ++p) {
    Eigen::Matrix3d linear = Eigen::Matrix3d::Zero();
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();
    for (int j = 0; j < num_joints; ++j) {
      const double w = probes.joint_weights(j, p);
      if (w == 0.0) continue;
      linear += w * pose[j].linear();
      translation += w * pose[j].translation();
    }
    const Eigen::Matrix3d frame = GramSchmidt(linear * probes.frames[p]);
    for (int i = 0; i < kProximityProbes; ++i) {
      const int probe = kProximityProbes * p + i;
      const Eigen::Vector3d x = linear * probes.rest_points.col(probe) + translation;
      const SignedDistanceResult hit = body.Query(x, hints != nullptr ? (*hints)[probe] : -1);
      if (hints != nullptr) (*hints)[probe] = hit.face;
      const double d = std::clamp(hit.distance / kProximityScale, -kProximityClamp, kProximityClamp);
      auto out = features->col(p).segment<4>(4 * i);
      out[0] = std::isfinite(d) ? d : kProximityClamp;
      out.tail<3>() = frame.transpose() * hit.normal;
    }
  }
}

PosedBodyDistance::PosedBodyDistance(const SkinnedBody& body) : body_(body), distance_(body.mesh) {}

const BodySignedDistance& PosedBodyDistance::Pose(const JointTransforms& pose) {
  distance_.SetVertices(SkinVertices(body_, pose));
  return distance_;
}

}  // namespace polyfit
