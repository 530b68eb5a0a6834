#include "polyfit/eval/mesh_metrics.h"

#include <algorithm>
#include <random>
#include <stdexcept>
#include <vector>

#include <Eigen/Geometry>

namespace polyfit {

Eigen::Matrix3Xd SampleSurfaceUniform(const TriangleMesh& mesh, int count, std::uint64_t seed) {
  if (mesh.num_faces() == 0 || count <= 0) throw std::invalid_argument("SampleSurfaceUniform: empty mesh or count");
  const Eigen::VectorXd areas = FaceAreas(mesh);
  std::vector<double> cumulative(areas.size());
  double total = 0.0;
  for (Eigen::Index f = 0; f < areas.size(); ++f) cumulative[f] = (total += areas[f]);
  if (!(total > 0.0)) throw std::invalid_argument("SampleSurfaceUniform: the mesh has zero area");
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Eigen::Matrix3Xd points(3, count);
  for (int i = 0; i < count; ++i) {
    const double target = uniform(rng) * total;
    const size_t f = std::min<size_t>(
        std::lower_bound(cumulative.begin(), cumulative.end(), target) - cumulative.begin(), cumulative.size() - 1);
    double r1 = uniform(rng), r2 = uniform(rng);
    if (r1 + r2 > 1.0) {
      r1 = 1.0 - r1;
      r2 = 1.0 - r2;
    }
    const Eigen::Vector3d a = mesh.vertices.col(mesh.faces(0, f));
    points.col(i) = a + r1 * (mesh.vertices.col(mesh.faces(1, f)) - a) + r2 * (mesh.vertices.col(mesh.faces(2, f)) - a);
  }
  return points;
}

Normalization UnitSphereNormalization(const Eigen::Matrix3Xd& points) {
  Normalization n;
  if (points.cols() == 0) return n;
  n.centre = 0.5 * (points.rowwise().maxCoeff() + points.rowwise().minCoeff());
  const double radius = (points.colwise() - n.centre).colwise().norm().maxCoeff();
  n.scale = radius > 0.0 ? 1.0 / radius : 1.0;
  return n;
}

ChamferDistance MeshChamferDistance(const TriangleMesh& reference, const TriangleMesh& candidate, int count,
                                    std::uint64_t seed) {
  const Normalization normalization = UnitSphereNormalization(reference.vertices);
  const Eigen::Matrix3Xd a = normalization.Apply(SampleSurfaceUniform(reference, count, seed));
  const Eigen::Matrix3Xd b = normalization.Apply(SampleSurfaceUniform(candidate, count, seed + 1));
  return ComputeChamferDistance(a, b);
}

Eigen::Matrix3Xd VertexNormals(const TriangleMesh& mesh) {
  Eigen::Matrix3Xd normals = Eigen::Matrix3Xd::Zero(3, mesh.num_vertices());
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const Eigen::Vector3d a = mesh.vertices.col(mesh.faces(0, f));
    const Eigen::Vector3d n = (mesh.vertices.col(mesh.faces(1, f)) - a).cross(mesh.vertices.col(mesh.faces(2, f)) - a);
    for (int c = 0; c < 3; ++c) normals.col(mesh.faces(c, f)) += n;  // |n| = 2 area
  }
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    const double norm = normals.col(v).norm();
    if (norm > 0.0) normals.col(v) /= norm;
  }
  return normals;
}

}  // namespace polyfit
