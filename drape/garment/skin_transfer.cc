#include "drape/garment/skin_transfer.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "polyfit/eval/surface_distance.h"
#include "polyfit/mesh/barycentric.h"
#include "polyfit/mesh/cotangent_laplacian.h"
#include "polyfit/mesh/edge_split.h"
#include "polyfit/mesh/mesh_topology.h"
#include "polyfit/mesh/unique_edges.h"

namespace polyfit {

double SkinDiffusionTime(double length) { return length * length / 8.0; }

int SkinSmoothingSteps(const TriangleMesh& garment, const SkinTransferOptions& options) {
  if (options.smoothing_iterations > 0) return options.smoothing_iterations;
  if (!(options.smoothing_length > 0.0)) return 0;
  const Eigen::Matrix2Xi edges = UniqueEdges(garment);
  if (edges.cols() == 0) return 0;
  double mean_edge = 0.0;
  for (Eigen::Index e = 0; e < edges.cols(); ++e) {
    mean_edge += (garment.vertices.col(edges(0, e)) - garment.vertices.col(edges(1, e))).norm();
  }
  mean_edge /= static_cast<double>(edges.cols());
  if (!(mean_edge > 0.0)) return 0;
  const double steps = std::pow(options.smoothing_length / mean_edge, 2);
  return static_cast<int>(std::lround(std::min(steps, 1e5)));
}

namespace {

// Implicit Euler steps: within 0.2% of the exact diffusion of a step
// (docs/drape.md); one step's kernel is exponential, with heavy tails.
constexpr int kHeatSubsteps = 8;

// The former smoothing: Jacobi steps toward the umbrella mean.
void SmoothOverEdges(const TriangleMesh& garment, const std::vector<double>& rate, int steps, Eigen::MatrixXd* dense) {
  const AdjacencyList neighbours = VertexVertexAdjacency(garment);
  const int n = garment.num_vertices();
  Eigen::MatrixXd next(dense->rows(), n);
  for (int it = 0; it < steps; ++it) {
    for (int v = 0; v < n; ++v) {
      if (neighbours.degree(v) == 0) {
        next.col(v) = dense->col(v);
        continue;
      }
      Eigen::VectorXd mean = Eigen::VectorXd::Zero(dense->rows());
      for (const int* u = neighbours.begin(v); u != neighbours.end(v); ++u) mean += dense->col(*u);
      const double step = 0.5 * rate[v];
      next.col(v) = (1.0 - step) * dense->col(v) + step * mean / static_cast<double>(neighbours.degree(v));
    }
    dense->swap(next);
  }
}

}  // namespace

namespace {

// The weights transferred on a copy split to resample_edge_length, read at
// the garment's own vertices (the copy's first).
SkinWeights TransferOnSplitCopy(const SkinnedBody& body, const TriangleMesh& garment,
                                const SkinTransferOptions& options) {
  SkinTransferOptions fine = options;
  fine.resample_edge_length = 0.0;
  const SkinWeights all = TransferSkinWeights(body, SplitLongEdges(garment, options.resample_edge_length), fine);
  const int n = garment.num_vertices();
  SkinWeights out;
  out.joint.assign(all.joint.begin(), all.joint.begin() + all.offsets[n]);
  out.value.assign(all.value.begin(), all.value.begin() + all.offsets[n]);
  out.offsets.assign(all.offsets.begin(), all.offsets.begin() + n + 1);
  return out;
}

}  // namespace

SkinWeights TransferSkinWeights(const SkinnedBody& body, const TriangleMesh& garment,
                                const SkinTransferOptions& options) {
  const int num_joints = body.skeleton.num_joints();
  const int n = garment.num_vertices();
  if (n == 0) throw std::invalid_argument("TransferSkinWeights: the garment has no vertex");
  if (!garment.vertices.allFinite())
    throw std::invalid_argument("TransferSkinWeights: the garment has non-finite vertices");
  if (!(options.resample_edge_length >= 0.0))
    throw std::invalid_argument("TransferSkinWeights: resample_edge_length must be >= 0");
  if (options.resample_edge_length > 0.0) return TransferOnSplitCopy(body, garment, options);
  // Dense #joints by #V: the rigs have tens of joints.
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(num_joints, n);
  std::vector<double> rate(n, 1.0);
  const SurfaceDistance surface(body.mesh);
  for (int v = 0; v < n; ++v) {
    int face = -1;
    const Eigen::Vector3d p = surface.ClosestPoint(garment.vertices.col(v), &face);
    const double distance = (p - garment.vertices.col(v)).norm();
    // Anchored vertices are held; tight ones diffuse slowly.
    if (distance < options.anchor_distance) {
      rate[v] = 0.0;
    } else if (options.loose_distance > 0.0) {
      rate[v] = std::min(1.0, distance / options.loose_distance);
    }
    const Eigen::Vector3i corners = body.mesh.faces.col(face);
    const Eigen::Vector3d a = body.mesh.vertices.col(corners[0]), b = body.mesh.vertices.col(corners[1]),
                          c = body.mesh.vertices.col(corners[2]);
    const Eigen::Vector3d bary = BarycentricOnTriangle(a, b, c, p);
    for (int k = 0; k < 3; ++k) {
      const int bv = corners[k];
      for (int i = body.weight_offsets[bv]; i < body.weight_offsets[bv + 1]; ++i) {
        dense(body.weight_joint[i], v) += bary[k] * body.weight_value[i];
      }
    }
  }
  if (options.smoothing_iterations > 0 || options.smoothing == SkinSmoothing::kEdgeSteps) {
    SmoothOverEdges(garment, rate, SkinSmoothingSteps(garment, options), &dense);
  } else if (options.smoothing_length > 0.0) {
    // Joints as columns: #V by #joints.
    const Eigen::MatrixXd diffused =
        DiffuseHeat(garment, dense.transpose(), SkinDiffusionTime(options.smoothing_length), rate, kHeatSubsteps);
    dense = diffused.transpose();
  }
  SkinWeights out;
  for (int v = 0; v < n; ++v) {
    double total = 0.0;
    for (int j = 0; j < num_joints; ++j) {
      if (dense(j, v) >= options.min_weight) total += dense(j, v);
    }
    if (!(total > 0.0)) {  // every weight tiny: keep the largest
      Eigen::Index best = 0;
      dense.col(v).maxCoeff(&best);
      out.joint.push_back(static_cast<int>(best));
      out.value.push_back(1.0);
    } else {
      for (int j = 0; j < num_joints; ++j) {
        if (dense(j, v) < options.min_weight) continue;
        out.joint.push_back(j);
        out.value.push_back(dense(j, v) / total);
      }
    }
    out.offsets.push_back(static_cast<int>(out.joint.size()));
  }
  return out;
}

Eigen::Matrix3Xd SkinPoints(const SkinWeights& weights, const Eigen::Matrix3Xd& rest,
                            const std::vector<Eigen::Isometry3d>& transforms) {
  if (weights.num_vertices() != rest.cols())
    throw std::invalid_argument("SkinPoints: one weight row per point is needed");
  Eigen::Matrix3Xd posed(3, rest.cols());
  std::vector<Eigen::Matrix<double, 3, 4>> maps;
  JointMaps(transforms, &maps);
  for (int v = 0; v < weights.num_vertices(); ++v) {
    const Eigen::Matrix<double, 3, 4> blended = weights.Blend(v, maps);
    posed.col(v) = blended.leftCols<3>() * rest.col(v) + blended.col(3);
  }
  return posed;
}

SkinWeights SingleJointWeights(int num_vertices, int joint) {
  SkinWeights weights;
  for (int v = 0; v < num_vertices; ++v) {
    weights.joint.push_back(joint);
    weights.value.push_back(1.0);
    weights.offsets.push_back(v + 1);
  }
  return weights;
}

}  // namespace polyfit
