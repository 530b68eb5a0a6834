// The scene format's metrics (../shared/docs/sft-scene-format.md): e_3D,
// e_n, RMSE against per-vertex ground truth, Chamfer against a point cloud.
#ifndef POLYFIT_SFT_SCENE_SFT_METRICS_H_
#define POLYFIT_SFT_SCENE_SFT_METRICS_H_

#include <cstdint>

#include <Eigen/Core>

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// || s R V + t - G ||_F / || G ||_F after the similarity (Umeyama, with
// scale) that best maps V onto G. V, G: 3 by N.
double ComputeE3D(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xd& ground_truth);

// Mean over vertices of the angle in degrees between the area-weighted
// vertex normals of the mesh with `vertices` and with `ground_truth` (same
// faces), no alignment.
double ComputeNormalErrorDeg(const Eigen::Matrix3Xi& faces, const Eigen::Matrix3Xd& vertices,
                             const Eigen::Matrix3Xd& ground_truth);

// sqrt(mean ||v_i - g_i||^2) in millimetres (inputs in metres), no alignment.
double ComputeRmseMm(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xd& ground_truth);

// The reconstructed surface sampled uniformly with as many points as the
// cloud, then mean squared nearest distances both ways, summed, times 1e4.
double ComputePointChamfer1e4(const TriangleMesh& reconstruction, const Eigen::Matrix3Xd& cloud,
                              std::uint64_t seed = 1);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SCENE_SFT_METRICS_H_
