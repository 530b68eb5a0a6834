// TriangleMesh to and from CGAL's Surface_mesh. Internal to the CGAL-heavy
// translation units of polyfit/mesh (subdivision.cc, decimation.cc): it
// includes CGAL, which the library does not export.
#ifndef POLYFIT_MESH_CGAL_SURFACE_MESH_H_
#define POLYFIT_MESH_CGAL_SURFACE_MESH_H_

#include <cstddef>
#include <vector>

#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

using CgalKernel = CGAL::Simple_cartesian<double>;
using CgalSurfaceMesh = CGAL::Surface_mesh<CgalKernel::Point_3>;

// False (and *out untouched) when the triangles are not an oriented
// manifold that CGAL accepts, or there are none.
inline bool ToCgalSurfaceMesh(const TriangleMesh& mesh, CgalSurfaceMesh* out) {
  namespace PMP = CGAL::Polygon_mesh_processing;
  std::vector<CgalKernel::Point_3> points;
  points.reserve(mesh.num_vertices());
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    points.emplace_back(mesh.vertices(0, v), mesh.vertices(1, v), mesh.vertices(2, v));
  }
  std::vector<std::vector<std::size_t>> polygons(mesh.num_faces());
  for (int f = 0; f < mesh.num_faces(); ++f) {
    polygons[f] = {static_cast<std::size_t>(mesh.faces(0, f)), static_cast<std::size_t>(mesh.faces(1, f)),
                   static_cast<std::size_t>(mesh.faces(2, f))};
  }
  if (polygons.empty() || !PMP::is_polygon_soup_a_polygon_mesh(polygons)) return false;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, *out);
  return true;
}

// Its live vertices and triangles, in order (removed elements skipped);
// no texture coordinates.
inline TriangleMesh FromCgalSurfaceMesh(const CgalSurfaceMesh& sm) {
  TriangleMesh out;
  out.vertices.resize(3, sm.number_of_vertices());
  std::vector<int> index(sm.num_vertices(), -1);
  int next = 0;
  for (auto v : sm.vertices()) {
    const auto& p = sm.point(v);
    out.vertices.col(next) = Eigen::Vector3d(p.x(), p.y(), p.z());
    index[v.idx()] = next++;
  }
  out.faces.resize(3, sm.number_of_faces());
  int f = 0;
  for (auto face : sm.faces()) {
    int c = 0;
    for (auto v : CGAL::vertices_around_face(sm.halfedge(face), sm)) {
      if (c < 3) out.faces(c, f) = index[v.idx()];
      ++c;
    }
    ++f;
  }
  out.corner_texcoords.resize(2, 0);
  return out;
}

}  // namespace polyfit

#endif  // POLYFIT_MESH_CGAL_SURFACE_MESH_H_
