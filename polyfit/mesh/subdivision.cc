// CGAL-heavy: the subdivision methods (with Surface_mesh, as in
// decimation.cc).
#include "polyfit/mesh/subdivision.h"

#include <algorithm>
#include <cstdint>
#include <vector>

#include <CGAL/Subdivision_method_3/subdivision_methods_3.h>

#include "polyfit/mesh/cgal_surface_mesh.h"
#include "polyfit/mesh/mesh_topology.h"

namespace polyfit {
namespace {

// Loop subdivision, or false with the reason when the mesh is not a
// manifold CGAL accepts.
bool SubdivideLoop(const TriangleMesh& mesh, int levels, TriangleMesh* out, std::string* reason) {
  CgalSurfaceMesh sm;
  if (!ToCgalSurfaceMesh(mesh, &sm)) {
    *reason = "not an oriented manifold mesh";
    return false;
  }
  CGAL::Subdivision_method_3::Loop_subdivision(sm, CGAL::parameters::number_of_iterations(levels));
  *out = FromCgalSurfaceMesh(sm);
  return true;
}

}  // namespace

TriangleMesh SubdivideMidpoint(const TriangleMesh& mesh) {
  const int num_vertices = mesh.num_vertices();
  const int num_faces = mesh.num_faces();
  // Edge (a < b) -> new vertex, via the sorted edge list.
  const std::vector<std::pair<std::uint64_t, int>> edges = SortedEdgeCorners(mesh);
  std::vector<int> edge_vertex(3 * static_cast<size_t>(num_faces));
  std::vector<std::uint64_t> unique_edges;
  for (size_t i = 0; i < edges.size(); ++i) {
    if (i == 0 || edges[i].first != edges[i - 1].first) unique_edges.push_back(edges[i].first);
    edge_vertex[edges[i].second] = num_vertices + static_cast<int>(unique_edges.size()) - 1;
  }
  TriangleMesh out;
  out.vertices.resize(3, num_vertices + static_cast<Eigen::Index>(unique_edges.size()));
  out.vertices.leftCols(num_vertices) = mesh.vertices;
  for (size_t e = 0; e < unique_edges.size(); ++e) {
    const int a = static_cast<int>(unique_edges[e] >> 32), b = static_cast<int>(unique_edges[e] & 0xffffffffu);
    out.vertices.col(num_vertices + e) = 0.5 * (mesh.vertices.col(a) + mesh.vertices.col(b));
  }
  out.faces.resize(3, 4 * static_cast<Eigen::Index>(num_faces));
  const bool uv = mesh.has_texcoords();
  if (uv) out.corner_texcoords.resize(2, 12 * static_cast<Eigen::Index>(num_faces));
  for (int f = 0; f < num_faces; ++f) {
    const int v0 = mesh.faces(0, f), v1 = mesh.faces(1, f), v2 = mesh.faces(2, f);
    const int m01 = edge_vertex[3 * f], m12 = edge_vertex[3 * f + 1], m20 = edge_vertex[3 * f + 2];
    out.faces.col(4 * f) << v0, m01, m20;
    out.faces.col(4 * f + 1) << m01, v1, m12;
    out.faces.col(4 * f + 2) << m20, m12, v2;
    out.faces.col(4 * f + 3) << m01, m12, m20;
    if (uv) {
      const Eigen::Vector2d t0 = mesh.corner_texcoords.col(3 * f), t1 = mesh.corner_texcoords.col(3 * f + 1),
                            t2 = mesh.corner_texcoords.col(3 * f + 2);
      const Eigen::Vector2d t01 = 0.5 * (t0 + t1), t12 = 0.5 * (t1 + t2), t20 = 0.5 * (t2 + t0);
      const Eigen::Vector2d corners[12] = {t0, t01, t20, t01, t1, t12, t20, t12, t2, t01, t12, t20};
      for (int k = 0; k < 12; ++k) out.corner_texcoords.col(12 * f + k) = corners[k];
    }
  }
  return out;
}

TriangleMesh SubdivideMesh(const TriangleMesh& mesh, const SubdivisionOptions& options, SubdivisionSummary* summary) {
  SubdivisionSummary local;
  local.levels = std::max(0, options.levels);
  local.scheme_used = options.scheme;
  TriangleMesh out = mesh;
  if (local.levels > 0 && options.scheme == SubdivisionScheme::kLoop) {
    TriangleMesh loop;
    if (SubdivideLoop(mesh, local.levels, &loop, &local.fallback_reason)) {
      out = std::move(loop);
    } else {
      local.scheme_used = SubdivisionScheme::kMidpoint;
    }
  }
  if (local.scheme_used == SubdivisionScheme::kMidpoint) {
    for (int level = 0; level < local.levels; ++level) out = SubdivideMidpoint(out);
  }
  if (summary != nullptr) *summary = local;
  return out;
}

}  // namespace polyfit
