#include "polyfit/mesh/ordered_io.h"

#include <stdexcept>
#include <vector>

#include "polyfit/mesh/obj_reader.h"
#include "polyfit/mesh/ply_reader.h"

namespace polyfit {
namespace {

[[noreturn]] void Fail(const std::string& path, const std::string& reason) {
  throw std::runtime_error(path + ": " + reason);
}

}  // namespace

TriangleMesh ReadObjTemplate(const std::string& path) {
  const PolygonSoup soup = ReadObj(path);
  if (soup.triangles.empty()) Fail(path, "holds no faces");
  TriangleMesh mesh;
  mesh.vertices.resize(3, static_cast<Eigen::Index>(soup.positions.size()));
  for (size_t i = 0; i < soup.positions.size(); ++i)
    mesh.vertices.col(static_cast<Eigen::Index>(i)) = soup.positions[i];
  mesh.faces.resize(3, static_cast<Eigen::Index>(soup.triangles.size()));
  for (size_t f = 0; f < soup.triangles.size(); ++f) mesh.faces.col(static_cast<Eigen::Index>(f)) = soup.triangles[f];
  if (!soup.corner_texcoords.empty()) {
    mesh.corner_texcoords.resize(2, static_cast<Eigen::Index>(soup.corner_texcoords.size()));
    for (size_t i = 0; i < soup.corner_texcoords.size(); ++i) {
      mesh.corner_texcoords.col(static_cast<Eigen::Index>(i)) = soup.corner_texcoords[i];
    }
  }
  return mesh;
}

Eigen::Matrix3Xd ReadPlyVertices(const std::string& path) {
  const PolygonSoup soup = ReadPly(path);  // names a missing file
  Eigen::Matrix3Xd points(3, static_cast<Eigen::Index>(soup.positions.size()));
  for (size_t v = 0; v < soup.positions.size(); ++v) {
    if (!soup.positions[v].allFinite()) Fail(path, "vertex " + std::to_string(v) + " is not finite");
    points.col(static_cast<Eigen::Index>(v)) = soup.positions[v];
  }
  return points;
}

}  // namespace polyfit
