#include "polyfit/mesh/triangle_mesh.h"

#include <cmath>

#include <Eigen/Geometry>

namespace polyfit {

std::string TriangleMesh::Validate() const {
  if (faces.cols() == 0) return "the mesh has no faces";
  if (vertices.cols() == 0) return "the mesh has no vertices";
  for (Eigen::Index v = 0; v < vertices.cols(); ++v) {
    if (!vertices.col(v).allFinite()) {
      return "vertex " + std::to_string(v) + " has a non-finite coordinate";
    }
  }
  const Eigen::Index num_vertices = vertices.cols();
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int index = faces(c, f);
      if (index < 0 || index >= num_vertices) {
        return "face " + std::to_string(f) + " refers to vertex " + std::to_string(index) + " but there are " +
               std::to_string(num_vertices) + " vertices";
      }
    }
  }
  if (corner_texcoords.cols() != 0) {
    if (corner_texcoords.cols() != 3 * faces.cols()) {
      return "texture coordinates: " + std::to_string(corner_texcoords.cols()) + " corners for " +
             std::to_string(faces.cols()) + " faces";
    }
    if (!corner_texcoords.allFinite()) return "texture coordinates are not all finite";
  }
  return {};
}

Eigen::VectorXd FaceAreas(const TriangleMesh& mesh) {
  Eigen::VectorXd areas(mesh.num_faces());
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const Eigen::Vector3d a = mesh.vertices.col(mesh.faces(0, f));
    const Eigen::Vector3d b = mesh.vertices.col(mesh.faces(1, f));
    const Eigen::Vector3d c = mesh.vertices.col(mesh.faces(2, f));
    areas[f] = 0.5 * (b - a).cross(c - a).norm();
  }
  return areas;
}

double SurfaceArea(const TriangleMesh& mesh) { return FaceAreas(mesh).sum(); }

Eigen::VectorXd VertexAreas(const TriangleMesh& mesh) {
  const Eigen::VectorXd face_areas = FaceAreas(mesh);
  Eigen::VectorXd areas = Eigen::VectorXd::Zero(mesh.num_vertices());
  for (int f = 0; f < mesh.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) areas[mesh.faces(c, f)] += face_areas[f] / 3.0;
  }
  return areas;
}

double BoundingBoxDiagonal(const Eigen::Matrix3Xd& points) {
  if (points.cols() == 0) return 0.0;
  return (points.rowwise().maxCoeff() - points.rowwise().minCoeff()).norm();
}

}  // namespace polyfit
