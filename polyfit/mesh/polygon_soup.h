// One mesh of a file as its reader returns it, before ReadTriangleMesh
// welds coincident vertices and drops what welding makes degenerate.
#ifndef POLYFIT_MESH_POLYGON_SOUP_H_
#define POLYFIT_MESH_POLYGON_SOUP_H_

#include <vector>

#include <Eigen/Core>

namespace polyfit {

struct PolygonSoup {
  // #P positions, in file order.
  std::vector<Eigen::Vector3d> positions;
  // Triangles indexing positions, oriented as their polygons.
  std::vector<Eigen::Vector3i> triangles;
  // Texture coordinates per triangle corner (3 per triangle), or empty.
  std::vector<Eigen::Vector2d> corner_texcoords;
  // Faces of one or two corners (points, lines): not surfaces, skipped.
  int num_points_and_lines = 0;
};

// Appends the polygon `corners` (indices into soup->positions, which must
// be in range) as triangles, with `texcoords` (one per corner) when not
// null. A convex polygon becomes a fan around its first corner; a concave
// one (the letters of CGAL's mpi.off) is ear-clipped in the plane of its
// Newell normal, so no triangle covers what is outside it. Polygons of more
// than kMaxEarClippedCorners corners, and those with no ear left (self-
// intersecting), are fanned. Points and lines are counted.
void AppendPolygon(const std::vector<int>& corners, const std::vector<Eigen::Vector2d>* texcoords, PolygonSoup* soup);

// Ear clipping is quadratic to cubic in the corner count.
constexpr int kMaxEarClippedCorners = 512;

}  // namespace polyfit

#endif  // POLYFIT_MESH_POLYGON_SOUP_H_
