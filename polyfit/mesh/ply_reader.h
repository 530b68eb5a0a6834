// Polygon File Format (PLY) meshes, read by PolyFit rather than assimp:
// assimp 5.2's PLY reader crashed on malformed files that pass any header
// check (found by tests/fuzz/mesh_ply_fuzzer), and a reader of our own
// bounds every read.
#ifndef POLYFIT_MESH_PLY_READER_H_
#define POLYFIT_MESH_PLY_READER_H_

#include <string>

#include "polyfit/mesh/polygon_soup.h"

namespace polyfit {

// Whether the file is named .ply (any case) or starts with the PLY magic
// line.
bool LooksLikePly(const std::string& path);

// ASCII and binary (little- and big-endian) PLY of any element layout:
// positions from the vertex element's x, y, z; texture coordinates from
// its (u, v), (s, t) or (texture_u, texture_v), or from the face element's
// 'texcoord' list (2 per corner), which takes precedence for the faces that
// have one (the others get the vertices' or zero); polygons from the
// face element's 'vertex_indices' (or 'vertex_index') list. Other elements
// and properties are read past. Vertex order is the file's.
//
// Throws MeshIoError naming the file: an unknown format or type, no
// 'end_header', element counts that the file's size cannot hold (checked
// before allocating), a truncated element, a number that does not parse, a
// face index that is not a whole number or is out of range, a face of no
// corners.
PolygonSoup ReadPly(const std::string& path);

}  // namespace polyfit

#endif  // POLYFIT_MESH_PLY_READER_H_
