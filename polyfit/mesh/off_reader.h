// Object File Format (OFF) meshes, read by PolyFit rather than assimp:
// assimp 5.2's OFF reader read out of bounds on malformed files (found by
// tests/fuzz/mesh_off_fuzzer), and a reader of our own checks every line.
#ifndef POLYFIT_MESH_OFF_READER_H_
#define POLYFIT_MESH_OFF_READER_H_

#include <string>

#include "polyfit/mesh/polygon_soup.h"

namespace polyfit {

// Whether the file is named .off (any case) or its first word (comments
// skipped) is an OFF keyword: OFF with any of the prefixes ST, C, N, 4 and
// n, in that order (COFF, NOFF, STOFF, STCNOFF, ...).
bool LooksLikeOff(const std::string& path);

// ASCII OFF of three dimensions. The keyword is optional (then the first
// line holds the counts); the counts ("#V #F [#E]") may follow the keyword
// on its line; '#' starts a comment; one vertex or face per line.
// A vertex line holds x y z, then a normal (N), a colour (C) and a texture
// coordinate (ST) as its prefix declares; a face line its corner count,
// that many vertex indices, then an optional colour. Texture coordinates,
// where declared, are the last two numbers of each vertex line.
//
// Throws MeshIoError naming the file and, for a bad line, its number: an
// unknown or binary variant, counts that the file's size cannot hold
// (checked before allocating), a vertex without three finite coordinates,
// a face of no corners or with an index out of range, a truncated file.
PolygonSoup ReadOff(const std::string& path);

}  // namespace polyfit

#endif  // POLYFIT_MESH_OFF_READER_H_
