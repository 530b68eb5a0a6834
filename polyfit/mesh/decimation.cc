// CGAL-heavy: Surface_mesh and its simplification, in this unit only.
#include "polyfit/mesh/decimation.h"

#include <stdexcept>
#include <vector>

#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_ratio_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_placement.h>

namespace polyfit {

TriangleMesh DecimateMesh(const TriangleMesh& mesh, double edge_ratio) {
  namespace PMP = CGAL::Polygon_mesh_processing;
  namespace SMS = CGAL::Surface_mesh_simplification;
  using Kernel = CGAL::Simple_cartesian<double>;
  using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
  if (!(edge_ratio > 0.0 && edge_ratio <= 1.0))
    throw std::invalid_argument("DecimateMesh: edge_ratio must be in (0, 1]");
  std::vector<Kernel::Point_3> points;
  points.reserve(mesh.num_vertices());
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    points.emplace_back(mesh.vertices(0, v), mesh.vertices(1, v), mesh.vertices(2, v));
  }
  std::vector<std::vector<std::size_t>> polygons(mesh.num_faces());
  for (int f = 0; f < mesh.num_faces(); ++f) {
    polygons[f] = {static_cast<std::size_t>(mesh.faces(0, f)), static_cast<std::size_t>(mesh.faces(1, f)),
                   static_cast<std::size_t>(mesh.faces(2, f))};
  }
  if (mesh.num_faces() == 0 || !PMP::is_polygon_soup_a_polygon_mesh(polygons)) {
    throw std::invalid_argument("DecimateMesh: not an oriented manifold triangle mesh");
  }
  SurfaceMesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, sm);
  const SMS::Count_ratio_stop_predicate<SurfaceMesh> stop(edge_ratio);
  SMS::edge_collapse(sm, stop,
                     CGAL::parameters::get_cost(SMS::LindstromTurk_cost<SurfaceMesh>())
                         .get_placement(SMS::LindstromTurk_placement<SurfaceMesh>()));
  sm.collect_garbage();
  TriangleMesh out;
  out.vertices.resize(3, sm.number_of_vertices());
  for (auto v : sm.vertices()) {
    const auto& p = sm.point(v);
    out.vertices.col(v.idx()) = Eigen::Vector3d(p.x(), p.y(), p.z());
  }
  out.faces.resize(3, sm.number_of_faces());
  for (auto face : sm.faces()) {
    int c = 0;
    for (auto v : CGAL::vertices_around_face(sm.halfedge(face), sm))
      out.faces(c++, face.idx()) = static_cast<int>(v.idx());
  }
  out.corner_texcoords.resize(2, 0);
  return out;
}

}  // namespace polyfit
