#include "sft/solver/fold_mirror.h"

#include <algorithm>
#include <numeric>

#include <Eigen/SVD>

namespace polyfit {

namespace {

int Find(std::vector<int>* parent, int x) {
  while ((*parent)[x] != x) x = (*parent)[x] = (*parent)[(*parent)[x]];
  return x;
}

}  // namespace

int MirrorFoldFlap(const TriangleMesh& mesh, const std::vector<MeshHinge>& hinges,
                   const std::vector<std::uint8_t>& crease, const Eigen::Matrix3Xd& vertices,
                   Eigen::Matrix3Xd* mirrored, int min_flap_faces) {
  *mirrored = vertices;
  const int num_faces = static_cast<int>(mesh.faces.cols());
  const int num_vertices = static_cast<int>(vertices.cols());
  if (crease.size() != hinges.size() || num_faces == 0) return 0;
  // Faces joined across every hinge off the crease.
  std::vector<int> parent(num_faces);
  std::iota(parent.begin(), parent.end(), 0);
  for (size_t h = 0; h < hinges.size(); ++h) {
    if (!crease[h]) parent[Find(&parent, hinges[h].faces[0])] = Find(&parent, hinges[h].faces[1]);
  }
  std::vector<int> size(num_faces, 0);
  for (int f = 0; f < num_faces; ++f) ++size[Find(&parent, f)];
  int sheet = -1, flap = -1;
  for (int f = 0; f < num_faces; ++f) {
    if (parent[f] != f) continue;
    if (sheet < 0 || size[f] > size[sheet]) {
      flap = sheet;
      sheet = f;
    } else if (flap < 0 || size[f] > size[flap]) {
      flap = f;
    }
  }
  if (flap < 0 || size[flap] < min_flap_faces) return 0;
  // Per vertex: held by a flap face, by any other face.
  std::vector<std::uint8_t> in_flap(num_vertices, 0), elsewhere(num_vertices, 0);
  for (int f = 0; f < num_faces; ++f) {
    const bool is_flap = Find(&parent, f) == flap;
    for (int c = 0; c < 3; ++c) (is_flap ? in_flap : elsewhere)[mesh.faces(c, f)] = 1;
  }
  // The plane: the crease's vertices between flap and sheet, and the
  // sheet's vertices one edge from them.
  std::vector<std::uint8_t> on_plane(num_vertices, 0);
  for (size_t h = 0; h < hinges.size(); ++h) {
    if (!crease[h]) continue;
    const int a = Find(&parent, hinges[h].faces[0]), b = Find(&parent, hinges[h].faces[1]);
    if (!((a == flap && b == sheet) || (a == sheet && b == flap))) continue;
    on_plane[hinges[h].vertices[0]] = on_plane[hinges[h].vertices[1]] = 1;
  }
  std::vector<std::uint8_t> near = on_plane;
  for (int f = 0; f < num_faces; ++f) {
    if (Find(&parent, f) != sheet) continue;
    bool touches = false;
    for (int c = 0; c < 3; ++c) touches = touches || on_plane[mesh.faces(c, f)];
    if (!touches) continue;
    for (int c = 0; c < 3; ++c) near[mesh.faces(c, f)] = 1;
  }
  std::vector<int> points;
  for (int v = 0; v < num_vertices; ++v) {
    if (near[v]) points.push_back(v);
  }
  if (points.size() < 3) return 0;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (int v : points) centre += vertices.col(v);
  centre /= static_cast<double>(points.size());
  Eigen::Matrix3Xd spread(3, points.size());
  for (size_t i = 0; i < points.size(); ++i) spread.col(i) = vertices.col(points[i]) - centre;
  const Eigen::JacobiSVD<Eigen::Matrix3Xd> svd(spread, Eigen::ComputeFullU);
  const Eigen::Vector3d s = svd.singularValues();
  // A line (the crease alone, the sheet beside it flat on it) has no plane.
  if (!(s[1] > 1e-6 * s[0])) return 0;
  const Eigen::Vector3d normal = svd.matrixU().col(2);
  int count = 0;
  for (int v = 0; v < num_vertices; ++v) {
    if (!in_flap[v] || elsewhere[v]) continue;
    mirrored->col(v) -= 2.0 * normal.dot(vertices.col(v) - centre) * normal;
    ++count;
  }
  return count;
}

}  // namespace polyfit
