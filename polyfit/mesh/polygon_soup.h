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
  // Triangles indexing positions: polygons fan-triangulated.
  std::vector<Eigen::Vector3i> triangles;
  // Texture coordinates per triangle corner (3 per triangle), or empty.
  std::vector<Eigen::Vector2d> corner_texcoords;
  // Faces of one or two corners (points, lines): not surfaces, skipped.
  int num_points_and_lines = 0;
};

// Appends the polygon `corners` (indices into soup->positions) as a fan of
// triangles around its first corner, with `texcoords` (one per corner) when
// not null. A fan is exact for convex polygons, which is what OFF and PLY
// writers emit (quads, the odd pentagon); points and lines are counted.
inline void AppendPolygon(const std::vector<int>& corners, const std::vector<Eigen::Vector2d>* texcoords,
                          PolygonSoup* soup) {
  if (corners.size() < 3) {
    ++soup->num_points_and_lines;
    return;
  }
  for (size_t k = 1; k + 1 < corners.size(); ++k) {
    soup->triangles.emplace_back(corners[0], corners[k], corners[k + 1]);
    if (texcoords != nullptr) {
      soup->corner_texcoords.push_back((*texcoords)[0]);
      soup->corner_texcoords.push_back((*texcoords)[k]);
      soup->corner_texcoords.push_back((*texcoords)[k + 1]);
    }
  }
}

}  // namespace polyfit

#endif  // POLYFIT_MESH_POLYGON_SOUP_H_
