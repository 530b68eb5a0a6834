// Dense resampling of coarse meshes by 1-to-4 subdivision before clustering,
// so that every patch has enough points for its jet.
#ifndef POLYFIT_MESH_SUBDIVISION_H_
#define POLYFIT_MESH_SUBDIVISION_H_

#include <string>

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

enum class SubdivisionScheme {
  // Edge midpoints: the surface is unchanged (points stay on the input
  // triangles); works on any triangle mesh. Texture coordinates follow.
  kMidpoint,
  // Loop subdivision through CGAL (Subdivision_method_3): a smooth limit
  // surface that moves the input vertices. Needs an orientable manifold
  // mesh; others fall back to kMidpoint (reported in the summary).
  kLoop,
};

struct SubdivisionOptions {
  SubdivisionScheme scheme = SubdivisionScheme::kMidpoint;
  // Levels; each multiplies the face count by 4.
  int levels = 1;
};

struct SubdivisionSummary {
  int levels = 0;
  SubdivisionScheme scheme_used = SubdivisionScheme::kMidpoint;
  // Why kLoop was not used, when it was asked for and fell back.
  std::string fallback_reason;
};

TriangleMesh SubdivideMesh(const TriangleMesh& mesh, const SubdivisionOptions& options,
                           SubdivisionSummary* summary = nullptr);

// One midpoint level.
TriangleMesh SubdivideMidpoint(const TriangleMesh& mesh);

}  // namespace polyfit

#endif  // POLYFIT_MESH_SUBDIVISION_H_
