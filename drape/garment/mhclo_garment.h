// MakeHuman garments (.mhclo + .obj): each garment vertex is bound to three
// base-mesh vertices,
//   p = w1 v1 + w2 v2 + w3 v3 + d (.) s,
// with s the per-axis scale of the current body against the one the garment
// was made on (the distance between two reference vertices along the axis,
// over the distance recorded in the file). Refitting a garment to a
// reshaped body is evaluating the binding on its vertices.
#ifndef POLYFIT_DRAPE_GARMENT_MHCLO_GARMENT_H_
#define POLYFIT_DRAPE_GARMENT_MHCLO_GARMENT_H_

#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "polyfit/mesh/triangle_mesh.h"
#include "polyfit/util/status.h"

namespace polyfit {

class GarmentError : public Error {
 public:
  explicit GarmentError(const std::string& message, ErrorKind kind = ErrorKind::kInput) : Error(kind, message) {}
};

struct ClothesBinding {
  std::string name;
  std::string obj_file;  // relative to the .mhclo
  // Per garment vertex: three base vertices, their weights, an offset (in
  // the file's units, decimetres for hm08).
  std::vector<std::array<int, 3>> references;
  std::vector<std::array<double, 3>> weights;
  std::vector<Eigen::Vector3d> offsets;
  // Per axis x, y, z: two reference vertices and their distance then.
  std::array<std::array<int, 2>, 3> scale_vertices{};
  std::array<double, 3> scale_distances{{1.0, 1.0, 1.0}};
};

// Throws GarmentError naming the file and line.
ClothesBinding ReadMhclo(const std::string& path);

// The garment's vertices (3 by #garment vertices) on a base mesh (3 by
// #base vertices, all of hm08's, helpers included) in `units_per_file_unit`
// (0.1 for metres from hm08's decimetres).
Eigen::Matrix3Xd ApplyBinding(const ClothesBinding& binding, const Eigen::Matrix3Xd& base_vertices,
                              double units_per_file_unit);

// The garment fitted to a body: its OBJ's faces (triangulated, file vertex
// order, texture coordinates kept) with the binding's vertices.
TriangleMesh LoadGarment(const std::string& mhclo_path, const Eigen::Matrix3Xd& base_vertices,
                         double units_per_file_unit);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_GARMENT_MHCLO_GARMENT_H_
