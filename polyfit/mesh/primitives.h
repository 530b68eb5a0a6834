// Procedural meshes for tests, benchmarks and demos.
#ifndef POLYFIT_MESH_PRIMITIVES_H_
#define POLYFIT_MESH_PRIMITIVES_H_

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// A sphere of the given radius about the origin: an icosahedron whose faces
// are split 4^levels times, vertices pushed onto the sphere. 20 * 4^levels
// faces.
TriangleMesh MakeIcosphere(int levels, double radius = 1.0);

// The square [-size/2, size/2]^2 in the z = 0 plane, nx by ny quads split
// in two, with texture coordinates in [0, 1]^2.
TriangleMesh MakeGrid(int nx, int ny, double size = 1.0);

// A torus (major radius 1, minor radius 0.35) with bumps of relative
// amplitude `bumps`, nu by nv quads split in two: 2 nu nv faces.
TriangleMesh MakeBumpyTorus(int nu, int nv, double bumps = 0.15);

// An open tube of `radius` around the y axis from y0 to y1: segments
// around, rings along, faces oriented outwards. A shirt or a skirt for
// draping tests.
TriangleMesh MakeTube(double radius, double y0, double y1, int segments, int rings);

}  // namespace polyfit

#endif  // POLYFIT_MESH_PRIMITIVES_H_
