// CGAL-heavy: Surface_mesh and its simplification, in this unit only.
#include "polyfit/mesh/decimation.h"

#include <stdexcept>

#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_ratio_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_placement.h>

#include "polyfit/mesh/cgal_surface_mesh.h"

namespace polyfit {

TriangleMesh DecimateMesh(const TriangleMesh& mesh, double edge_ratio) {
  namespace SMS = CGAL::Surface_mesh_simplification;
  if (!(edge_ratio > 0.0 && edge_ratio <= 1.0)) {
    throw std::invalid_argument("DecimateMesh: edge_ratio must be in (0, 1]");
  }
  CgalSurfaceMesh sm;
  if (!ToCgalSurfaceMesh(mesh, &sm))
    throw std::invalid_argument("DecimateMesh: not an oriented manifold triangle mesh");
  const SMS::Count_ratio_stop_predicate<CgalSurfaceMesh> stop(edge_ratio);
  SMS::edge_collapse(sm, stop,
                     CGAL::parameters::get_cost(SMS::LindstromTurk_cost<CgalSurfaceMesh>())
                         .get_placement(SMS::LindstromTurk_placement<CgalSurfaceMesh>()));
  return FromCgalSurfaceMesh(sm);
}

}  // namespace polyfit
