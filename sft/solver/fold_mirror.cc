#include "sft/solver/fold_mirror.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/SVD>

namespace polyfit {

namespace {

int Find(std::vector<int>* parent, int x) {
  while ((*parent)[x] != x) x = (*parent)[x] = (*parent)[(*parent)[x]];
  return x;
}

// The indices of the set entries of `flags`, in order.
std::vector<int> Flagged(const std::vector<std::uint8_t>& flags) {
  std::vector<int> indices;
  for (size_t i = 0; i < flags.size(); ++i) {
    if (flags[i]) indices.push_back(static_cast<int>(i));
  }
  return indices;
}

// The least-squares plane through `vertices`' columns `points`: false
// where there are fewer than three or they lie on a line.
bool FitPlane(const Eigen::Matrix3Xd& vertices, const std::vector<int>& points, Eigen::Vector3d* centre,
              Eigen::Vector3d* normal) {
  if (points.size() < 3) return false;
  *centre = Eigen::Vector3d::Zero();
  for (int v : points) *centre += vertices.col(v);
  *centre /= static_cast<double>(points.size());
  Eigen::Matrix3Xd spread(3, points.size());
  for (size_t i = 0; i < points.size(); ++i) spread.col(i) = vertices.col(points[i]) - *centre;
  const Eigen::JacobiSVD<Eigen::Matrix3Xd> svd(spread, Eigen::ComputeFullU);
  const Eigen::Vector3d s = svd.singularValues();
  // A line (the crease alone, the sheet beside it flat on it) has no plane.
  if (!(s[1] > 1e-6 * s[0])) return false;
  *normal = svd.matrixU().col(2);
  return true;
}

// #V flags: the vertices of the largest set of faces on crease hinges
// joined where the hinges meet; empty where it has fewer than min_faces.
std::vector<std::uint8_t> CreaseBand(const TriangleMesh& mesh, const std::vector<MeshHinge>& hinges,
                                     const std::vector<std::uint8_t>& crease, int num_vertices, int min_faces) {
  const int num_faces = static_cast<int>(mesh.faces.cols());
  std::vector<int> parent(num_faces);
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<std::uint8_t> on_crease(num_faces, 0);
  std::vector<int> face_at(num_vertices, -1);  // a crease face at each crease vertex
  for (size_t h = 0; h < hinges.size(); ++h) {
    if (!crease[h]) continue;
    const int f = hinges[h].faces[0];
    on_crease[f] = on_crease[hinges[h].faces[1]] = 1;
    parent[Find(&parent, hinges[h].faces[1])] = Find(&parent, f);
    for (int v : {hinges[h].vertices[0], hinges[h].vertices[1]}) {
      if (face_at[v] >= 0) parent[Find(&parent, face_at[v])] = Find(&parent, f);
      face_at[v] = f;
    }
  }
  std::vector<int> size(num_faces, 0);
  for (int f = 0; f < num_faces; ++f) {
    if (on_crease[f]) ++size[Find(&parent, f)];
  }
  int band = -1;
  for (int f = 0; f < num_faces; ++f) {
    if (on_crease[f] && parent[f] == f && (band < 0 || size[f] > size[band])) band = f;
  }
  if (band < 0 || size[band] < min_faces) return {};
  std::vector<std::uint8_t> inside(num_vertices, 0);
  for (int f = 0; f < num_faces; ++f) {
    if (!on_crease[f] || Find(&parent, f) != band) continue;
    for (int c = 0; c < 3; ++c) inside[mesh.faces(c, f)] = 1;
  }
  return inside;
}

// The vertices one edge outside `inside` (#V flags): those of a face that
// has vertices on both sides.
std::vector<int> OneEdgeOutside(const TriangleMesh& mesh, const std::vector<std::uint8_t>& inside) {
  std::vector<std::uint8_t> ring(inside.size(), 0);
  for (int f = 0; f < mesh.faces.cols(); ++f) {
    bool touches = false;
    for (int c = 0; c < 3; ++c) touches = touches || inside[mesh.faces(c, f)];
    if (!touches) continue;
    for (int c = 0; c < 3; ++c) ring[mesh.faces(c, f)] |= !inside[mesh.faces(c, f)];
  }
  return Flagged(ring);
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
  Eigen::Vector3d centre, normal;
  if (!FitPlane(vertices, Flagged(near), &centre, &normal)) return 0;
  int count = 0;
  for (int v = 0; v < num_vertices; ++v) {
    if (!in_flap[v] || elsewhere[v]) continue;
    mirrored->col(v) -= 2.0 * normal.dot(vertices.col(v) - centre) * normal;
    ++count;
  }
  return count;
}

int FlipCreaseAlongRays(const TriangleMesh& mesh, const std::vector<MeshHinge>& hinges,
                        const std::vector<std::uint8_t>& crease, const Eigen::Matrix3Xd& vertices,
                        Eigen::Matrix3Xd* flipped, int min_faces) {
  *flipped = vertices;
  if (crease.size() != hinges.size() || mesh.faces.cols() == 0) return 0;
  const std::vector<std::uint8_t> inside =
      CreaseBand(mesh, hinges, crease, static_cast<int>(vertices.cols()), min_faces);
  if (inside.empty()) return 0;
  Eigen::Vector3d centre, normal;
  if (!FitPlane(vertices, OneEdgeOutside(mesh, inside), &centre, &normal)) return 0;
  // X' = t X on the ray, n.(X' - c) = -n.(X - c): t = (2 n.c - n.X) / n.X.
  const double offset = normal.dot(centre);
  std::vector<double> scale(vertices.cols(), 1.0);
  for (int v = 0; v < vertices.cols(); ++v) {
    if (!inside[v]) continue;
    const double along = normal.dot(vertices.col(v));
    scale[v] = (2.0 * offset - along) / along;
    // Edge-on, or sent behind the camera.
    if (!(std::abs(along) > 0.1 * vertices.col(v).norm()) || !(scale[v] > 0.1)) return 0;
  }
  int count = 0;
  for (int v = 0; v < vertices.cols(); ++v) {
    if (!inside[v]) continue;
    flipped->col(v) *= scale[v];
    ++count;
  }
  return count;
}

}  // namespace polyfit
