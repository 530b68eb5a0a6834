#include "polyfit/mesh/mesh_topology.h"

#include <algorithm>
#include <cstdint>

namespace polyfit {
namespace {

// Builds CSR lists from (element, neighbour) pairs.
AdjacencyList FromPairs(int num_elements, std::vector<std::pair<int, int>>& pairs) {
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  AdjacencyList list;
  list.offsets.assign(num_elements + 1, 0);
  for (const auto& [a, b] : pairs) ++list.offsets[a + 1];
  for (int i = 0; i < num_elements; ++i) list.offsets[i + 1] += list.offsets[i];
  list.indices.resize(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) list.indices[k] = pairs[k].second;
  return list;
}

}  // namespace

std::vector<std::pair<std::uint64_t, int>> SortedEdgeCorners(const TriangleMesh& mesh) {
  std::vector<std::pair<std::uint64_t, int>> edges;
  edges.reserve(3 * static_cast<size_t>(mesh.num_faces()));
  for (int f = 0; f < mesh.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      std::uint32_t a = mesh.faces(c, f), b = mesh.faces((c + 1) % 3, f);
      if (a > b) std::swap(a, b);
      edges.emplace_back((std::uint64_t{a} << 32) | b, 3 * f + c);
    }
  }
  std::sort(edges.begin(), edges.end());
  return edges;
}

std::vector<MeshHinge> InteriorHinges(const TriangleMesh& mesh) {
  const std::vector<std::pair<std::uint64_t, int>> edges = SortedEdgeCorners(mesh);
  std::vector<MeshHinge> hinges;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j].first == edges[i].first) ++j;
    if (j - i == 2) {
      const int first = edges[i].second, second = edges[i + 1].second;
      const int f = first / 3, c = first % 3, g = second / 3, d = second % 3;
      MeshHinge hinge;
      hinge.vertices = {mesh.faces(c, f), mesh.faces((c + 1) % 3, f), mesh.faces((c + 2) % 3, f),
                        mesh.faces((d + 2) % 3, g)};
      hinge.faces = {f, g};
      hinges.push_back(hinge);
    }
    i = j;
  }
  return hinges;
}

AdjacencyList FaceFaceAdjacency(const TriangleMesh& mesh) {
  const int num_faces = mesh.num_faces();
  std::vector<std::pair<std::uint64_t, int>> edges = SortedEdgeCorners(mesh);
  for (auto& edge : edges) edge.second /= 3;  // corner -> face
  // Two passes over the runs of equal edges: count, then fill.
  AdjacencyList list;
  list.offsets.assign(num_faces + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<int> fill;
    if (pass == 1) {
      for (int f = 0; f < num_faces; ++f) list.offsets[f + 1] += list.offsets[f];
      list.indices.resize(list.offsets.back());
      fill.assign(list.offsets.begin(), list.offsets.end() - 1);
    }
    for (size_t i = 0; i < edges.size();) {
      size_t j = i;
      while (j < edges.size() && edges[j].first == edges[i].first) ++j;
      for (size_t p = i; p < j; ++p) {
        for (size_t q = i; q < j; ++q) {
          if (p == q || edges[p].second == edges[q].second) continue;
          if (pass == 0) {
            ++list.offsets[edges[p].second + 1];
          } else {
            list.indices[fill[edges[p].second]++] = edges[q].second;
          }
        }
      }
      i = j;
    }
  }
  // Sorted lists; two faces sharing two edges (a fold) list each other
  // twice, which no user of the list minds.
  for (int f = 0; f < num_faces; ++f) {
    int* begin = list.indices.data() + list.offsets[f];
    int* end = list.indices.data() + list.offsets[f + 1];
    std::sort(begin, end);
  }
  return list;
}

AdjacencyList VertexFaceAdjacency(const TriangleMesh& mesh) {
  AdjacencyList list;
  list.offsets.assign(mesh.num_vertices() + 1, 0);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) ++list.offsets[mesh.faces(c, f) + 1];
  }
  for (int v = 0; v < mesh.num_vertices(); ++v) list.offsets[v + 1] += list.offsets[v];
  list.indices.resize(list.offsets.back());
  std::vector<int> fill(list.offsets.begin(), list.offsets.end() - 1);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) list.indices[fill[mesh.faces(c, f)]++] = f;
  }
  return list;
}

AdjacencyList VertexVertexAdjacency(const TriangleMesh& mesh) {
  std::vector<std::pair<int, int>> pairs;
  pairs.reserve(6 * static_cast<size_t>(mesh.num_faces()));
  for (int f = 0; f < mesh.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int a = mesh.faces(c, f), b = mesh.faces((c + 1) % 3, f);
      pairs.emplace_back(a, b);
      pairs.emplace_back(b, a);
    }
  }
  return FromPairs(mesh.num_vertices(), pairs);
}

int ConnectedComponents(const AdjacencyList& graph, std::vector<int>* labels) {
  const int n = graph.size();
  labels->assign(n, -1);
  std::vector<int> stack;
  int count = 0;
  for (int start = 0; start < n; ++start) {
    if ((*labels)[start] >= 0) continue;
    (*labels)[start] = count;
    stack.push_back(start);
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      for (const int* j = graph.begin(i); j != graph.end(i); ++j) {
        if ((*labels)[*j] < 0) {
          (*labels)[*j] = count;
          stack.push_back(*j);
        }
      }
    }
    ++count;
  }
  return count;
}

}  // namespace polyfit
