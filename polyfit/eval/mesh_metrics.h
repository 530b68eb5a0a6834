// Mesh-to-mesh accuracy as the paper's Table 1 reports it: Chamfer distance
// between points sampled uniformly on both surfaces, in a normalisation
// taken from the reference mesh.
#ifndef POLYFIT_EVAL_MESH_METRICS_H_
#define POLYFIT_EVAL_MESH_METRICS_H_

#include <cstdint>

#include <Eigen/Core>

#include "polyfit/eval/metrics.h"
#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// 3 by count points, uniform over the surface area (faces drawn by area,
// points uniform in the triangle), reproducible for a seed.
Eigen::Matrix3Xd SampleSurfaceUniform(const TriangleMesh& mesh, int count, std::uint64_t seed);

// x -> (x - centre) * scale.
struct Normalization {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double scale = 1.0;
  Eigen::Matrix3Xd Apply(const Eigen::Matrix3Xd& points) const { return (points.colwise() - centre) * scale; }
};

// Centre at the bounding-box centre, scaled so that the farthest vertex is
// at distance 1 (the unit sphere).
Normalization UnitSphereNormalization(const Eigen::Matrix3Xd& points);

// Chamfer (mean squared nearest distances, both ways) between `count`
// uniform samples on each mesh, both mapped by the reference's unit-sphere
// normalisation.
ChamferDistance MeshChamferDistance(const TriangleMesh& reference, const TriangleMesh& candidate, int count,
                                    std::uint64_t seed);

// 3 by #V unit normals, area-weighted means of the incident face normals.
Eigen::Matrix3Xd VertexNormals(const TriangleMesh& mesh);

}  // namespace polyfit

#endif  // POLYFIT_EVAL_MESH_METRICS_H_
