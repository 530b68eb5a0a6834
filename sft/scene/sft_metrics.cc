#include "sft/scene/sft_metrics.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>

#include "polyfit/eval/mesh_metrics.h"
#include "polyfit/eval/metrics.h"

namespace polyfit {

double ComputeE3D(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xd& ground_truth) {
  if (vertices.cols() != ground_truth.cols() || vertices.cols() < 3) {
    throw std::invalid_argument("ComputeE3D: need the same number (>= 3) of vertices");
  }
  const Eigen::Matrix4d similarity = Eigen::umeyama(vertices, ground_truth, true);
  const Eigen::Matrix3Xd aligned =
      (similarity.topLeftCorner<3, 3>() * vertices).colwise() + similarity.topRightCorner<3, 1>();
  return (aligned - ground_truth).norm() / ground_truth.norm();
}

double ComputeNormalErrorDeg(const Eigen::Matrix3Xi& faces, const Eigen::Matrix3Xd& vertices,
                             const Eigen::Matrix3Xd& ground_truth) {
  TriangleMesh a, b;
  a.faces = b.faces = faces;
  a.vertices = vertices;
  b.vertices = ground_truth;
  const Eigen::Matrix3Xd na = VertexNormals(a), nb = VertexNormals(b);
  double sum = 0.0;
  int count = 0;
  for (Eigen::Index v = 0; v < na.cols(); ++v) {
    if (na.col(v).squaredNorm() == 0.0 || nb.col(v).squaredNorm() == 0.0) continue;
    sum += std::acos(std::clamp(na.col(v).dot(nb.col(v)), -1.0, 1.0)) * 180.0 / M_PI;
    ++count;
  }
  return count > 0 ? sum / count : 0.0;
}

double ComputeRmseMm(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xd& ground_truth) {
  return 1e3 * std::sqrt((vertices - ground_truth).colwise().squaredNorm().mean());
}

double ComputePointChamfer1e4(const TriangleMesh& reconstruction, const Eigen::Matrix3Xd& cloud, std::uint64_t seed) {
  const Eigen::Matrix3Xd samples = SampleSurfaceUniform(reconstruction, static_cast<int>(cloud.cols()), seed);
  return 1e4 * ComputeChamferDistance(samples, cloud).sum();
}

}  // namespace polyfit
