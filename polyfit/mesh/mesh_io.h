// Reading meshes (OFF, PLY and OBJ with our own readers; STL, glTF/GLB and
// whatever else assimp reads through assimp) and writing PLY and OBJ.
#ifndef POLYFIT_MESH_MESH_IO_H_
#define POLYFIT_MESH_MESH_IO_H_

#include <cstdint>
#include <stdexcept>
#include <string>

#include <Eigen/Core>

#include "polyfit/mesh/triangle_mesh.h"
#include "polyfit/util/status.h"

namespace polyfit {

// Every reading or writing failure: what() names the file and the reason.
class MeshIoError : public Error {
 public:
  explicit MeshIoError(const std::string& message, ErrorKind kind = ErrorKind::kInput) : Error(kind, message) {}
};

struct MeshReadSummary {
  // Faces that collapsed to a line or point when coincident vertices were
  // welded, and were dropped.
  int num_dropped_degenerate_faces = 0;
  // Vertices no face uses, dropped.
  int num_dropped_unreferenced_vertices = 0;
  // Meshes in the file (all are concatenated).
  int num_meshes = 0;
  // OFF, PLY and OBJ faces of one or two corners (points, lines), skipped.
  int num_skipped_points_and_lines = 0;
  // Errors assimp logged without failing (it repairs some input).
  std::string loader_messages;
};

// Reads every triangle of every mesh in the file (polygons are
// triangulated, node transforms applied, points and lines ignored; the
// format is told by the extension or content for OFF and PLY, by the
// extension for OBJ, see off_reader.h, ply_reader.h and obj_reader.h, and
// by assimp for the rest) and welds
// vertices with identical positions, so texture seams do not cut the
// surface; texture coordinates, where present, are kept per corner. Throws
// MeshIoError when the file is missing or unreadable, holds no triangles,
// has non-finite coordinates or indices out of range.
TriangleMesh ReadTriangleMesh(const std::string& path, MeshReadSummary* summary = nullptr);

// Binary little-endian PLY. vertex_colors: 3 by #V RGB, or null. Written to
// a temporary file and renamed, so a failure leaves no partial file.
void WritePly(const std::string& path, const TriangleMesh& mesh,
              const Eigen::Matrix<std::uint8_t, 3, Eigen::Dynamic>* vertex_colors = nullptr);

// Wavefront OBJ with texture coordinates when the mesh has them. Written
// atomically like WritePly.
void WriteObj(const std::string& path, const TriangleMesh& mesh);

}  // namespace polyfit

#endif  // POLYFIT_MESH_MESH_IO_H_
