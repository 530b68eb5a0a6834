// Which vertices of a surface the camera sees: a hard z-buffer of its
// triangles, and each vertex against the nearest surface at its pixel.
#ifndef POLYFIT_SFT_RENDER_VERTEX_VISIBILITY_H_
#define POLYFIT_SFT_RENDER_VERTEX_VISIBILITY_H_

#include <cstdint>
#include <vector>

#include "sft/render/soft_rasterizer.h"

namespace polyfit {

// Per vertex (#V): 1 where another part of the surface lies in front of
// it, nearer to the camera by more than `tolerance` (metres) at each of
// the four pixel centres around where it projects; 0 where it is seen,
// and where it falls outside the width by height image. The
// z-buffer holds each triangle's depth at the pixel centres it covers
// (perspective-correct: 1/z interpolated on screen). `mesh`: pixels,
// depths and faces (ProjectVertices). occluders (optional, #V): per
// hidden vertex, the face nearest the camera at the pixel centre at or
// before it (its floor), -1 where the vertex is seen.
std::vector<std::uint8_t> OccludedVertices(const ScreenMesh& mesh, int width, int height, double tolerance,
                                           std::vector<int>* occluders = nullptr);

}  // namespace polyfit

#endif  // POLYFIT_SFT_RENDER_VERTEX_VISIBILITY_H_
