// per_face_normals.h, face_centroids.h and unique_edges.h: one translation
// unit for the three small helpers.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "polyfit/mesh/face_centroids.h"
#include "polyfit/mesh/per_face_normals.h"
#include "polyfit/mesh/unique_edges.h"

namespace polyfit {

Eigen::Matrix3Xd PerFaceNormals(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& faces) {
  Eigen::Matrix3Xd normals(3, faces.cols());
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    const Eigen::Vector3d a = vertices.col(faces(0, f));
    const Eigen::Vector3d n = (vertices.col(faces(1, f)) - a).cross(vertices.col(faces(2, f)) - a);
    const double norm = n.norm();
    normals.col(f) = norm > 0.0 && std::isfinite(norm) ? Eigen::Vector3d(n / norm) : Eigen::Vector3d::Zero();
  }
  return normals;
}

Eigen::Matrix3Xd PerFaceNormals(const TriangleMesh& mesh) { return PerFaceNormals(mesh.vertices, mesh.faces); }

Eigen::Matrix3Xd FaceCentroids(const TriangleMesh& mesh) {
  Eigen::Matrix3Xd centroids(3, mesh.faces.cols());
  for (Eigen::Index f = 0; f < mesh.faces.cols(); ++f) {
    centroids.col(f) = (mesh.vertices.col(mesh.faces(0, f)) + mesh.vertices.col(mesh.faces(1, f)) +
                        mesh.vertices.col(mesh.faces(2, f))) /
                       3.0;
  }
  return centroids;
}

Eigen::Matrix2Xi UniqueEdges(const Eigen::Matrix3Xi& faces) {
  std::vector<std::uint64_t> keys;
  keys.reserve(3 * faces.cols());
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t a = static_cast<std::uint32_t>(faces(c, f));
      const std::uint32_t b = static_cast<std::uint32_t>(faces((c + 1) % 3, f));
      if (a == b) continue;
      keys.push_back((static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b));
    }
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  Eigen::Matrix2Xi edges(2, keys.size());
  for (size_t e = 0; e < keys.size(); ++e) {
    edges(0, e) = static_cast<int>(keys[e] >> 32);
    edges(1, e) = static_cast<int>(keys[e] & 0xffffffffu);
  }
  return edges;
}

int FindEdge(const Eigen::Matrix2Xi& edges, int i, int j) {
  const int a = std::min(i, j), b = std::max(i, j);
  Eigen::Index lo = 0, hi = edges.cols();
  while (lo < hi) {
    const Eigen::Index mid = (lo + hi) / 2;
    if (edges(0, mid) < a || (edges(0, mid) == a && edges(1, mid) < b)) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return lo < edges.cols() && edges(0, lo) == a && edges(1, lo) == b ? static_cast<int>(lo) : -1;
}

}  // namespace polyfit
