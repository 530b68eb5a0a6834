#include "drape/collision/signed_distance.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <Eigen/Geometry>

#include "drape/collision/triangle_bvh.h"
#include "polyfit/eval/mesh_metrics.h"
#include "polyfit/mesh/mesh_topology.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {
struct BodySignedDistance::Impl {
  TriangleMesh body;
  // Per connected piece of the body: its faces and a tree for closest
  // points, built once and refitted per pose. A body of several closed
  // pieces (overlapping capsules) is their union: the signed distance is
  // the smallest of the pieces'.
  std::vector<std::vector<int>> piece_faces;
  std::vector<TriangleBvh> trees;
  // Pseudonormals: per face (each pose), and from them, only where a query
  // lands on a vertex or an edge, the angle-weighted vertex normal and the
  // edge's sum of its faces' normals. Per pose that leaves the refit and
  // the face normals (the angles were 80k atan2 calls per pose).
  Eigen::Matrix3Xd face_normals;
  std::vector<std::pair<std::uint64_t, int>> edges;  // SortedEdgeCorners
  // Per face corner 3 f + c (the edge from corner c to c + 1): its run of
  // `edges` (every corner on the same edge).
  std::vector<int> edge_begin, edge_end;
  // Per vertex: the corners 3 f + c at it, by increasing face.
  std::vector<int> corner_offsets, corners;

  void BuildTopology() {
    const int nf = body.num_faces(), nv = body.num_vertices();
    edges = SortedEdgeCorners(body);
    edge_begin.assign(3 * nf, 0);
    edge_end.assign(3 * nf, 0);
    for (size_t i = 0; i < edges.size();) {
      size_t j = i;
      while (j < edges.size() && edges[j].first == edges[i].first) ++j;
      for (size_t k = i; k < j; ++k) {
        edge_begin[edges[k].second] = static_cast<int>(i);
        edge_end[edges[k].second] = static_cast<int>(j);
      }
      i = j;
    }
    corner_offsets.assign(nv + 1, 0);
    for (int k = 0; k < 3 * nf; ++k) ++corner_offsets[body.faces(k % 3, k / 3) + 1];
    for (int v = 0; v < nv; ++v) corner_offsets[v + 1] += corner_offsets[v];
    corners.assign(3 * nf, 0);
    std::vector<int> fill(corner_offsets.begin(), corner_offsets.end() - 1);
    for (int k = 0; k < 3 * nf; ++k) corners[fill[body.faces(k % 3, k / 3)]++] = k;
  }

  void UpdateFaceNormals() {
    const int nf = body.num_faces();
    face_normals.resize(3, nf);
    for (int f = 0; f < nf; ++f) {
      const Eigen::Vector3d n = (body.vertices.col(body.faces(1, f)) - body.vertices.col(body.faces(0, f)))
                                    .cross(body.vertices.col(body.faces(2, f)) - body.vertices.col(body.faces(0, f)));
      face_normals.col(f) = n.norm() > 0.0 ? Eigen::Vector3d(n.normalized()) : Eigen::Vector3d::Zero();
    }
  }

  // The angle-weighted pseudonormal of vertex v (not normalised).
  Eigen::Vector3d VertexNormal(int v) const {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int i = corner_offsets[v]; i < corner_offsets[v + 1]; ++i) {
      const int f = corners[i] / 3, c = corners[i] % 3;
      const Eigen::Vector3d x = body.vertices.col(body.faces(c, f));
      const Eigen::Vector3d a = body.vertices.col(body.faces((c + 1) % 3, f)) - x;
      const Eigen::Vector3d b = body.vertices.col(body.faces((c + 2) % 3, f)) - x;
      sum += std::atan2(a.cross(b).norm(), a.dot(b)) * face_normals.col(f);
    }
    return sum;
  }

  // The sum of the normals of the faces on the edge from corner c of face
  // f to corner c + 1.
  Eigen::Vector3d EdgeNormal(int f, int c) const {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int i = edge_begin[3 * f + c]; i < edge_end[3 * f + c]; ++i) sum += face_normals.col(edges[i].second / 3);
    return sum;
  }
};

BodySignedDistance::BodySignedDistance(const TriangleMesh& body) : impl_(std::make_unique<Impl>()) {
  if (const std::string problem = body.Validate(); !problem.empty()) {
    throw std::invalid_argument("BodySignedDistance: " + problem);
  }
  impl_->body = body;
  impl_->BuildTopology();
  std::vector<int> labels;
  const int pieces = ConnectedComponents(FaceFaceAdjacency(body), &labels);
  impl_->piece_faces.assign(pieces, {});
  for (int f = 0; f < body.num_faces(); ++f) impl_->piece_faces[labels[f]].push_back(f);
  for (const std::vector<int>& faces : impl_->piece_faces) impl_->trees.emplace_back(body.vertices, body.faces, faces);
  impl_->UpdateFaceNormals();
}

BodySignedDistance::~BodySignedDistance() = default;
BodySignedDistance::BodySignedDistance(BodySignedDistance&&) noexcept = default;

void BodySignedDistance::SetVertices(const Eigen::Matrix3Xd& vertices) {
  if (vertices.cols() != impl_->body.vertices.cols() || !vertices.allFinite()) {
    throw std::invalid_argument("BodySignedDistance::SetVertices: wrong size or non-finite vertices");
  }
  impl_->body.vertices = vertices;
  for (TriangleBvh& tree : impl_->trees) tree.Refit(vertices);
  impl_->UpdateFaceNormals();
}

SignedDistanceResult BodySignedDistance::Query(const Eigen::Vector3d& p, int hint_face) const {
  const Impl& m = *impl_;
  SignedDistanceResult best;
  best.distance = std::numeric_limits<double>::infinity();
  for (size_t piece = 0; piece < m.trees.size(); ++piece) {
    SignedDistanceResult r = QueryPiece(m, piece, p, hint_face);
    if (r.distance < best.distance) best = r;
  }
  return best;
}

SignedDistanceResult BodySignedDistance::QueryPiece(const Impl& m, size_t piece, const Eigen::Vector3d& p,
                                                    int hint_face) {
  SignedDistanceResult r;
  m.trees[piece].ClosestPoint(p, m.body.vertices, &r.closest, &r.face, hint_face);
  // Which feature the closest point lies on, from its barycentrics.
  const Eigen::Vector3d a = m.body.vertices.col(m.body.faces(0, r.face));
  const Eigen::Vector3d b = m.body.vertices.col(m.body.faces(1, r.face));
  const Eigen::Vector3d c = m.body.vertices.col(m.body.faces(2, r.face));
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double area2 = n.squaredNorm();
  double w[3] = {1.0 / 3, 1.0 / 3, 1.0 / 3};
  if (area2 > 0.0) {
    w[0] = n.dot((b - r.closest).cross(c - r.closest)) / area2;
    w[1] = n.dot((c - r.closest).cross(a - r.closest)) / area2;
    w[2] = 1.0 - w[0] - w[1];
  }
  constexpr double kEps = 1e-9;
  int zeros = 0, last_zero = -1, nonzero = -1;
  for (int k = 0; k < 3; ++k) {
    if (w[k] < kEps) {
      ++zeros;
      last_zero = k;
    } else {
      nonzero = k;
    }
  }
  Eigen::Vector3d pseudo;
  if (zeros == 0) {
    pseudo = m.face_normals.col(r.face);
  } else if (zeros == 1) {
    // On the edge opposite corner last_zero: from corner last_zero + 1.
    pseudo = m.EdgeNormal(r.face, (last_zero + 1) % 3);
  } else {
    pseudo = m.VertexNormal(m.body.faces(nonzero, r.face));
  }
  r.normal = pseudo.norm() > 0.0 ? Eigen::Vector3d(pseudo.normalized()) : m.face_normals.col(r.face);
  const Eigen::Vector3d offset = p - r.closest;
  r.distance = offset.dot(pseudo) >= 0.0 ? offset.norm() : -offset.norm();
  return r;
}

Eigen::VectorXd BodySignedDistance::SignedDistances(const Eigen::Matrix3Xd& points, int num_threads) const {
  Eigen::VectorXd d(points.cols());
  ParallelFor(
      static_cast<int>(points.cols()), num_threads, [&](int, int i) { d[i] = Query(points.col(i)).distance; }, 256);
  return d;
}

NearestVertexDistance::NearestVertexDistance(const TriangleMesh& body)
    : body_(body), normals_(VertexNormals(body)), tree_(std::make_unique<RefitPointTree>(body.vertices)) {}

void NearestVertexDistance::SetVertices(const Eigen::Matrix3Xd& vertices) {
  if (vertices.cols() != body_.vertices.cols()) {
    throw std::invalid_argument("NearestVertexDistance::SetVertices: another number of vertices");
  }
  body_.vertices = vertices;
  normals_ = VertexNormals(body_);
  tree_->Refit(body_.vertices);
}

SignedDistanceResult NearestVertexDistance::Query(const Eigen::Vector3d& p, int hint) const {
  double d2;
  const int v = tree_->Nearest(p, &d2, hint);
  SignedDistanceResult r;
  r.face = v;   // the vertex: a hint for a query close by
  if (v < 0) {  // a point with a NaN: no vertex is nearest
    r.distance = std::numeric_limits<double>::quiet_NaN();
    return r;
  }
  r.closest = body_.vertices.col(v);
  r.normal = normals_.col(v);
  r.distance = (p - r.closest).dot(r.normal);
  return r;
}

}  // namespace polyfit
