// Coarser meshings of a surface, by edge collapse.
#ifndef POLYFIT_MESH_DECIMATION_H_
#define POLYFIT_MESH_DECIMATION_H_

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// The mesh with edges collapsed until edge_ratio (in (0, 1]) of its edges
// are left, through CGAL's Surface_mesh_simplification with Lindstrom and
// Turk's cost and placement: each collapse puts the new vertex where it
// best keeps the volume and the boundary, so the vertices stay on the
// surface (vertex clustering, by contrast, averages them into its
// concave side). Texture coordinates are dropped. Throws
// std::invalid_argument for a ratio out of range or a mesh that is not an
// oriented manifold.
TriangleMesh DecimateMesh(const TriangleMesh& mesh, double edge_ratio);

}  // namespace polyfit

#endif  // POLYFIT_MESH_DECIMATION_H_
