// The undirected edges of a mesh, each once.
#ifndef POLYFIT_MESH_UNIQUE_EDGES_H_
#define POLYFIT_MESH_UNIQUE_EDGES_H_

#include <Eigen/Core>

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// 2 by #E: column e is (i, j) with i < j, sorted by (i, j). Edges whose two
// ends are the same vertex (degenerate faces) are left out.
Eigen::Matrix2Xi UniqueEdges(const Eigen::Matrix3Xi& faces);
inline Eigen::Matrix2Xi UniqueEdges(const TriangleMesh& mesh) { return UniqueEdges(mesh.faces); }

// The index of edge (i, j) (either order) in `edges` from UniqueEdges, or
// -1; O(log #E).
int FindEdge(const Eigen::Matrix2Xi& edges, int i, int j);

}  // namespace polyfit

#endif  // POLYFIT_MESH_UNIQUE_EDGES_H_
