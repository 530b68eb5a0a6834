// Adjacency of a triangle mesh in compressed (CSR) form.
#ifndef POLYFIT_MESH_MESH_TOPOLOGY_H_
#define POLYFIT_MESH_MESH_TOPOLOGY_H_

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// Neighbours of element i: indices[offsets[i] .. offsets[i + 1]).
struct AdjacencyList {
  std::vector<int> offsets;  // #elements + 1
  std::vector<int> indices;

  int size() const { return static_cast<int>(offsets.size()) - 1; }
  int degree(int i) const { return offsets[i + 1] - offsets[i]; }
  const int* begin(int i) const { return indices.data() + offsets[i]; }
  const int* end(int i) const { return indices.data() + offsets[i + 1]; }
};

// Every face's edges as (key, corner) pairs, sorted by key: the key is
// (min vertex << 32) | max vertex, the corner 3 f + c for the edge from
// corner c to corner c + 1 of face f. Equal edges are consecutive.
std::vector<std::pair<std::uint64_t, int>> SortedEdgeCorners(const TriangleMesh& mesh);

// Two faces sharing an edge: (i, j, k) and (j, i, l), the edge i -> j as it
// runs in the first (the lower index).
struct MeshHinge {
  std::array<int, 4> vertices;  // i, j, k, l
  std::array<int, 2> faces;
};
// The hinges of the edges with exactly two faces, ordered by the edge's
// (min, max) vertices.
std::vector<MeshHinge> InteriorHinges(const TriangleMesh& mesh);

// Faces sharing an edge with each face (all of them at non-manifold edges).
AdjacencyList FaceFaceAdjacency(const TriangleMesh& mesh);
// Faces incident to each vertex.
AdjacencyList VertexFaceAdjacency(const TriangleMesh& mesh);
// Vertices sharing an edge with each vertex.
AdjacencyList VertexVertexAdjacency(const TriangleMesh& mesh);

// Labels the connected components of a graph (0, 1, ... in order of their
// smallest element); returns the number of components.
int ConnectedComponents(const AdjacencyList& graph, std::vector<int>* labels);

}  // namespace polyfit

#endif  // POLYFIT_MESH_MESH_TOPOLOGY_H_
