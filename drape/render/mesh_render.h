// A small z-buffer renderer for looking at drapes: orthographic views of a
// posed body (grey) and garment (coloured), flat Lambert shading, both
// sides of the garment lit. Views: front (looking down -Z) and side
// (looking down -X), side by side.
#ifndef POLYFIT_DRAPE_RENDER_MESH_RENDER_H_
#define POLYFIT_DRAPE_RENDER_MESH_RENDER_H_

#include <string>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

struct RenderOptions {
  int view_height = 480;  // pixels; each view is as wide as the scene needs
  double margin = 0.08;   // of the scene's height, around it
};

// 8-bit BGR image of the two views.
cv::Mat RenderBodyAndGarment(const TriangleMesh& body, const TriangleMesh& garment, const RenderOptions& options = {});

// Writes the image (PNG by extension) atomically; throws std::runtime_error naming the path.
void WriteImage(const std::string& path, const cv::Mat& image);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_RENDER_MESH_RENDER_H_
