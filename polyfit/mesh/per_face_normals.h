// Unit normals of a mesh's faces, (b - a) x (c - a) normalised for a face
// (a, b, c): counter-clockwise faces seen from outside point outwards.
// Degenerate faces (zero area, or non-finite corners) get a zero normal.
#ifndef POLYFIT_MESH_PER_FACE_NORMALS_H_
#define POLYFIT_MESH_PER_FACE_NORMALS_H_

#include <Eigen/Core>

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// 3 by #F.
Eigen::Matrix3Xd PerFaceNormals(const TriangleMesh& mesh);

// The same from vertices (3 by #V) and faces (3 by #F).
Eigen::Matrix3Xd PerFaceNormals(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& faces);

}  // namespace polyfit

#endif  // POLYFIT_MESH_PER_FACE_NORMALS_H_
