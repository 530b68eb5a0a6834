// Wavefront OBJ meshes, read by PolyFit rather than assimp: assimp 5.2's
// OBJ importer buffers 16 MB per file and looks for material files, which
// made it slow to fuzz (12 files a second); ours reads geometry only.
#ifndef POLYFIT_MESH_OBJ_READER_H_
#define POLYFIT_MESH_OBJ_READER_H_

#include <string>

#include "polyfit/mesh/polygon_soup.h"

namespace polyfit {

// v, vt and f lines (corners a, a/b, a/b/c, a//c; negative indices count
// back from the last one defined), vertices in file order; every other
// line (vn, o, g, s, usemtl, mtllib, l, p, comments) is skipped, and so
// are materials. Texture coordinates are kept when every face has them.
// A file of no faces gives a soup of no triangles. Throws MeshIoError
// naming the file and line: a bad number, a vertex without three finite
// coordinates, an index of 0 or out of range, a face of fewer than three
// corners.
PolygonSoup ReadObj(const std::string& path);

}  // namespace polyfit

#endif  // POLYFIT_MESH_OBJ_READER_H_
