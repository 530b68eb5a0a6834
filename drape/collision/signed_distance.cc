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
  // Pseudonormals: per face, per vertex (angle-weighted), per face edge
  // (the sum of the faces on the edge; column 3 f + c for the edge from
  // corner c to c + 1).
  Eigen::Matrix3Xd face_normals, vertex_normals, edge_normals;
  std::vector<std::pair<std::uint64_t, int>> edges;  // SortedEdgeCorners

  void Rebuild() {
    const int nf = body.num_faces(), nv = body.num_vertices();
    if (trees.empty()) {
      for (const std::vector<int>& faces : piece_faces) trees.emplace_back(body.vertices, body.faces, faces);
    } else {
      for (TriangleBvh& tree : trees) tree.Refit(body.vertices);
    }
    face_normals.resize(3, nf);
    vertex_normals = Eigen::Matrix3Xd::Zero(3, nv);
    for (int f = 0; f < nf; ++f) {
      const Eigen::Vector3d x[3] = {body.vertices.col(body.faces(0, f)), body.vertices.col(body.faces(1, f)),
                                    body.vertices.col(body.faces(2, f))};
      const Eigen::Vector3d n = (x[1] - x[0]).cross(x[2] - x[0]);
      face_normals.col(f) = n.norm() > 0.0 ? Eigen::Vector3d(n.normalized()) : Eigen::Vector3d::Zero();
      for (int c = 0; c < 3; ++c) {
        const Eigen::Vector3d a = x[(c + 1) % 3] - x[c], b = x[(c + 2) % 3] - x[c];
        const double angle = std::atan2(a.cross(b).norm(), a.dot(b));
        vertex_normals.col(body.faces(c, f)) += angle * face_normals.col(f);
      }
    }
    edge_normals = Eigen::Matrix3Xd::Zero(3, 3 * nf);
    for (size_t i = 0; i < edges.size();) {
      size_t j = i;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      while (j < edges.size() && edges[j].first == edges[i].first) sum += face_normals.col(edges[j++].second / 3);
      for (size_t k = i; k < j; ++k) edge_normals.col(edges[k].second) = sum;
      i = j;
    }
  }
};

BodySignedDistance::BodySignedDistance(const TriangleMesh& body) : impl_(std::make_unique<Impl>()) {
  if (const std::string problem = body.Validate(); !problem.empty()) {
    throw std::invalid_argument("BodySignedDistance: " + problem);
  }
  impl_->body = body;
  impl_->edges = SortedEdgeCorners(body);
  std::vector<int> labels;
  const int pieces = ConnectedComponents(FaceFaceAdjacency(body), &labels);
  impl_->piece_faces.assign(pieces, {});
  for (int f = 0; f < body.num_faces(); ++f) impl_->piece_faces[labels[f]].push_back(f);
  impl_->Rebuild();
}

BodySignedDistance::~BodySignedDistance() = default;
BodySignedDistance::BodySignedDistance(BodySignedDistance&&) noexcept = default;

void BodySignedDistance::SetVertices(const Eigen::Matrix3Xd& vertices) {
  if (vertices.cols() != impl_->body.vertices.cols() || !vertices.allFinite()) {
    throw std::invalid_argument("BodySignedDistance::SetVertices: wrong size or non-finite vertices");
  }
  impl_->body.vertices = vertices;
  impl_->Rebuild();
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
    pseudo = m.edge_normals.col(3 * r.face + (last_zero + 1) % 3);
  } else {
    pseudo = m.vertex_normals.col(m.body.faces(nonzero, r.face));
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

NearestVertexDistance::NearestVertexDistance(const TriangleMesh& body) : body_(body) { SetVertices(body.vertices); }

void NearestVertexDistance::SetVertices(const Eigen::Matrix3Xd& vertices) {
  body_.vertices = vertices;
  normals_ = VertexNormals(body_);
  tree_ = std::make_unique<KdTree3>(body_.vertices);
}

SignedDistanceResult NearestVertexDistance::Query(const Eigen::Vector3d& p) const {
  double d2;
  const int v = tree_->Nearest(p, &d2);
  SignedDistanceResult r;
  r.closest = body_.vertices.col(v);
  r.normal = normals_.col(v);
  r.distance = (p - r.closest).dot(r.normal);
  return r;
}

}  // namespace polyfit
