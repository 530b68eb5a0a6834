// A mesh refined until no edge is longer than a length, by splitting the
// long edges at their midpoints: the surface is unchanged, short edges are
// left alone, so that any meshing of a surface comes out with edges of
// about that length or shorter.
#ifndef POLYFIT_MESH_EDGE_SPLIT_H_
#define POLYFIT_MESH_EDGE_SPLIT_H_

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// Splits every edge longer than max_edge_length (m, > 0) at its midpoint,
// each face into 2, 3 or 4 by how many of its edges split, in rounds until
// none is longer. The mesh's vertices come first, in their order, then the
// new ones; faces keep their orientation; texture coordinates are dropped.
// Throws std::invalid_argument for a length that is not positive or that
// would take more than 20 rounds or 4 million faces.
TriangleMesh SplitLongEdges(const TriangleMesh& mesh, double max_edge_length);

}  // namespace polyfit

#endif  // POLYFIT_MESH_EDGE_SPLIT_H_
