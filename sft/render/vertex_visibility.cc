#include "sft/render/vertex_visibility.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace polyfit {

std::vector<std::uint8_t> OccludedVertices(const ScreenMesh& mesh, int width, int height, double tolerance,
                                           std::vector<int>* occluders) {
  const int n = static_cast<int>(mesh.pixels.cols());
  std::vector<std::uint8_t> occluded(n, 0);
  if (occluders) occluders->assign(n, -1);
  if (width <= 0 || height <= 0 || n == 0) return occluded;
  // Inverse depth, the largest (nearest) per pixel, over the pixels the
  // mesh's box covers in the image (each triangle and vertex lies in it).
  const int left = std::max(0, static_cast<int>(std::floor(mesh.pixels.row(0).minCoeff())));
  const int top = std::max(0, static_cast<int>(std::floor(mesh.pixels.row(1).minCoeff())));
  const int right = std::min(width - 1, static_cast<int>(std::ceil(mesh.pixels.row(0).maxCoeff())));
  const int bottom = std::min(height - 1, static_cast<int>(std::ceil(mesh.pixels.row(1).maxCoeff())));
  if (right < left || bottom < top) return occluded;
  const int box_width = right - left + 1;
  std::vector<double> nearest(static_cast<size_t>(box_width) * (bottom - top + 1), 0.0);
  std::vector<int> nearest_face(occluders ? nearest.size() : 0, -1);
  auto index = [&](int x, int y) { return static_cast<size_t>(y - top) * box_width + (x - left); };
  auto at = [&](int x, int y) -> double& { return nearest[index(x, y)]; };
  for (int f = 0; f < mesh.faces.cols(); ++f) {
    const int i0 = mesh.faces(0, f), i1 = mesh.faces(1, f), i2 = mesh.faces(2, f);
    const Eigen::Vector2d a = mesh.pixels.col(i0), b = mesh.pixels.col(i1), c = mesh.pixels.col(i2);
    const double area = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    if (!(std::abs(area) > 1e-12)) continue;
    const double inv[3] = {1.0 / mesh.depths[i0], 1.0 / mesh.depths[i1], 1.0 / mesh.depths[i2]};
    // Pixel (x, y) has its centre at (x, y), as ProjectVertices' pixels.
    const int x0 = std::max(left, static_cast<int>(std::ceil(std::min({a.x(), b.x(), c.x()}))));
    const int x1 = std::min(right, static_cast<int>(std::floor(std::max({a.x(), b.x(), c.x()}))));
    const int y0 = std::max(top, static_cast<int>(std::ceil(std::min({a.y(), b.y(), c.y()}))));
    const int y1 = std::min(bottom, static_cast<int>(std::floor(std::max({a.y(), b.y(), c.y()}))));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const Eigen::Vector2d p(x, y);
        const double w1 = ((p - a).x() * (c - a).y() - (p - a).y() * (c - a).x()) / area;
        const double w2 = ((b - a).x() * (p - a).y() - (b - a).y() * (p - a).x()) / area;
        const double w0 = 1.0 - w1 - w2;
        if (w0 < 0.0 || w1 < 0.0 || w2 < 0.0) continue;
        double& z = at(x, y);
        const double here = w0 * inv[0] + w1 * inv[1] + w2 * inv[2];
        if (here > z) {
          z = here;
          if (occluders) nearest_face[index(x, y)] = f;
        }
      }
    }
  }
  // Against the four pixel centres around the vertex, each nearer by more
  // than the tolerance: at a single one, a slanted sheet's own surface half
  // a pixel away could be nearer.
  for (int v = 0; v < n; ++v) {
    const double px = mesh.pixels(0, v), py = mesh.pixels(1, v);
    if (!(px >= 0.0 && py >= 0.0 && px <= width - 1 && py <= height - 1)) continue;
    const int x0 = static_cast<int>(std::floor(px)), y0 = static_cast<int>(std::floor(py));
    bool hidden = true;
    for (int k = 0; k < 4 && hidden; ++k) {
      // Beyond the box no triangle reaches: nothing is nearer there.
      const int x = std::min(x0 + k % 2, width - 1), y = std::min(y0 + k / 2, height - 1);
      const double z = x <= right && y <= bottom ? at(x, y) : 0.0;
      hidden = z > 0.0 && mesh.depths[v] > 1.0 / z + tolerance;
    }
    occluded[v] = hidden;
    if (hidden && occluders) (*occluders)[v] = nearest_face[index(std::min(x0, width - 1), std::min(y0, height - 1))];
  }
  return occluded;
}

}  // namespace polyfit
