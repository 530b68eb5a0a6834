// Reading meshes with their vertices in file order, for data that refers to
// vertices by index (shape-from-template ground truth, garment bindings,
// skinning weights): no welding or reordering as in ReadTriangleMesh.
// Polygons are fan-triangulated.
#ifndef POLYFIT_MESH_ORDERED_IO_H_
#define POLYFIT_MESH_ORDERED_IO_H_

#include <string>

#include <Eigen/Core>

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// An OBJ's vertices and faces as ReadObj (obj_reader.h) reads them, in
// file order, polygons triangulated. Throws std::runtime_error (MeshIoError)
// naming the file and line on anything malformed, and when there are no
// faces.
TriangleMesh ReadObjTemplate(const std::string& path);

// Per-vertex ground truth or point clouds: the x, y, z of a PLY's vertex
// element (ASCII or binary little/big endian; float or double; other
// properties skipped; faces, if any, checked and dropped), in file order.
// 3 by N. Read by ReadPly. Throws std::runtime_error
// naming the file.
Eigen::Matrix3Xd ReadPlyVertices(const std::string& path);

}  // namespace polyfit

#endif  // POLYFIT_MESH_ORDERED_IO_H_
