// Centroids of a mesh's faces, (a + b + c) / 3.
#ifndef POLYFIT_MESH_FACE_CENTROIDS_H_
#define POLYFIT_MESH_FACE_CENTROIDS_H_

#include <Eigen/Core>

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// 3 by #F.
Eigen::Matrix3Xd FaceCentroids(const TriangleMesh& mesh);

}  // namespace polyfit

#endif  // POLYFIT_MESH_FACE_CENTROIDS_H_
