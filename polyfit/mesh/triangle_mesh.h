// A triangle mesh: shared vertex positions, faces, optional per-corner
// texture coordinates. Faces index the welded vertices, so the mesh is
// connected across texture seams.
#ifndef POLYFIT_MESH_TRIANGLE_MESH_H_
#define POLYFIT_MESH_TRIANGLE_MESH_H_

#include <string>
#include <vector>

#include <Eigen/Core>

namespace polyfit {

struct TriangleMesh {
  // 3 by #V.
  Eigen::Matrix3Xd vertices;
  // 3 by #F, counter-clockwise seen from the outside.
  Eigen::Matrix3Xi faces;
  // 2 by 3 #F (column 3 f + c is corner c of face f), or empty.
  Eigen::Matrix2Xd corner_texcoords;

  int num_vertices() const { return static_cast<int>(vertices.cols()); }
  int num_faces() const { return static_cast<int>(faces.cols()); }
  bool has_texcoords() const { return corner_texcoords.cols() == 3 * faces.cols() && faces.cols() > 0; }

  // Empty when the mesh is usable (at least one face, finite coordinates,
  // indices in range, texture coordinates sized to the faces), else the
  // first problem found, naming the element.
  std::string Validate() const;
};

// #F areas.
Eigen::VectorXd FaceAreas(const TriangleMesh& mesh);
// Sum of the face areas.
double SurfaceArea(const TriangleMesh& mesh);
// #V areas: a third of the area of each incident face (a lumped mass).
Eigen::VectorXd VertexAreas(const TriangleMesh& mesh);
// Length of the bounding box diagonal (0 for an empty mesh).
double BoundingBoxDiagonal(const Eigen::Matrix3Xd& points);

}  // namespace polyfit

#endif  // POLYFIT_MESH_TRIANGLE_MESH_H_
