// Skinning weights for a garment, transferred from the body it is fitted
// to: each garment vertex takes the weights at its closest point on the
// body surface (the closest face's three vertices, blended barycentrically),
// then the weights are spread over the garment over a set length
// whatever the meshing, so that loose
// parts (a skirt between the legs) do not tear along the body's seams;
// each vertex diffuses in proportion to its distance from the body (up to
// loose_distance), so tight parts keep following the skin under them.
#ifndef POLYFIT_DRAPE_GARMENT_SKIN_TRANSFER_H_
#define POLYFIT_DRAPE_GARMENT_SKIN_TRANSFER_H_

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "drape/body/makehuman_body.h"
#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// Sparse per-vertex weights, rows summing to 1: vertex v's joints are
// joint[offsets[v] .. offsets[v+1]).
struct SkinWeights {
  std::vector<int> offsets{0};
  std::vector<int> joint;
  std::vector<double> value;

  int num_vertices() const { return static_cast<int>(offsets.size()) - 1; }
  // The blended map sum_j w_vj T_j as a 3 by 4 block [linear |
  // translation], from each joint's map in that form (JointMaps, once per
  // pose: an Isometry3d holds 4 by 4), one short axpy a weight.
  Eigen::Matrix<double, 3, 4> Blend(int v, const std::vector<Eigen::Matrix<double, 3, 4>>& maps) const {
    Eigen::Matrix<double, 3, 4> blended = Eigen::Matrix<double, 3, 4>::Zero();
    for (int k = offsets[v]; k < offsets[v + 1]; ++k) blended += value[k] * maps[joint[k]];
    return blended;
  }
};

// Each transform's 3 by 4 block [linear | translation], into *maps
// (resized; a buffer kept across poses allocates once).
inline void JointMaps(const std::vector<Eigen::Isometry3d>& transforms,
                      std::vector<Eigen::Matrix<double, 3, 4>>* maps) {
  maps->resize(transforms.size());
  for (size_t j = 0; j < transforms.size(); ++j) (*maps)[j] = transforms[j].affine();
}

// Every vertex bound to one joint with weight 1 (a rigid garment, tests).
SkinWeights SingleJointWeights(int num_vertices, int joint);

// How the transferred weights are spread over the garment.
enum class SkinSmoothing {
  // Heat diffusion over the garment's surface (cotangent Laplacian, lumped
  // areas) for the time SkinDiffusionTime(smoothing_length): the same
  // spread whatever the meshing, uniform or not.
  kSurface,
  // Jacobi steps over the edges (each vertex half-way to its neighbours'
  // mean), (smoothing_length / h)^2 of them for a garment of mean edge
  // length h. A fixed count reaches a distance in proportion to h; counted
  // from the mean edge, long edges still reach further than short ones.
  kEdgeSteps,
};

struct SkinTransferOptions {
  SkinSmoothing smoothing = SkinSmoothing::kEdgeSteps;
  // How far the weights diffuse over the garment (m). With a fixed count
  // of steps, a coarser meshing got weights mixed from further away and
  // more of it was skinned into the body (the suit decimated to 972
  // vertices: 24.6% of its vertices inside with no network, against 14.3%
  // as given; docs/drape.md). 0.3 m is 84 steps on the male casual suit
  // as fitted to the body (h 3.3 cm). 0: no smoothing.
  double smoothing_length = 0.3;
  // When positive, this many Jacobi steps over the edges, whatever the
  // meshing and method (the smoothing before 2026-11-24 was 100 of them).
  int smoothing_iterations = 0;
  // Vertices closer to the body than this (m) keep the body's weights
  // (they move with the skin under them; the smoothing flows around them).
  // 0: every vertex is smoothed.
  double anchor_distance = 0.0;
  // When positive, a vertex's smoothing step is scaled by min(1, d / this),
  // d its distance to the body: loose parts diffuse fully, tight ones
  // little: a vertex spreads over about smoothing_length sqrt(min(1, d /
  // this)). 0: every vertex takes full steps. (Measured on the walk: see
  // docs/drape.md; the shipped OneFit model uses 0.15 with 0.3 m of heat
  // diffusion on a split copy: the tight suit spreads over centimetres,
  // a skirt's hem over 0.3 m.)
  double loose_distance = 0.02;
  // Weights below this are dropped (then rows renormalised).
  double min_weight = 1e-3;
  // When positive, the weights are transferred and smoothed on a copy of
  // the garment whose edges are split until none is longer than this (m;
  // SplitLongEdges), then read at the garment's own vertices: the smoothing
  // then runs on about the same mesh whatever the garment's meshing. (On
  // the suit decimated by edge collapse, whose edges range from a few
  // millimetres to 15 cm, the smoothed weights differ from the given
  // suit's at the same places by 0.16 in L1 on average, against 0.02 with
  // no smoothing: docs/drape.md.) 0: the garment's own mesh.
  double resample_edge_length = 0.0;

  bool operator==(const SkinTransferOptions& o) const {
    return smoothing == o.smoothing && smoothing_length == o.smoothing_length &&
           smoothing_iterations == o.smoothing_iterations && anchor_distance == o.anchor_distance &&
           loose_distance == o.loose_distance && min_weight == o.min_weight &&
           resample_edge_length == o.resample_edge_length;
  }
  bool operator!=(const SkinTransferOptions& o) const { return !(*this == o); }
};

// The diffusion time (m^2) that spreads weights over `length` (m):
// length^2 / 8, the time (length / h)^2 Jacobi steps take on a regular
// mesh of edge h.
double SkinDiffusionTime(double length);

// The Jacobi steps that options give a garment under kEdgeSteps
// (smoothing_iterations, or from smoothing_length and the garment's mean
// edge length; at most 1e5).
int SkinSmoothingSteps(const TriangleMesh& garment, const SkinTransferOptions& options);

// garment: in the body's rest pose (3 by #V vertices, triangles).
SkinWeights TransferSkinWeights(const SkinnedBody& body, const TriangleMesh& garment,
                                const SkinTransferOptions& options = {});

// The garment posed by linear blend skinning: 3 by #V.
Eigen::Matrix3Xd SkinPoints(const SkinWeights& weights, const Eigen::Matrix3Xd& rest,
                            const std::vector<Eigen::Isometry3d>& transforms);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_GARMENT_SKIN_TRANSFER_H_
