#include "polyfit/mesh/polygon_soup.h"

#include <Eigen/Geometry>

namespace polyfit {
namespace {

double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// The polygon in the plane of its Newell normal, counter-clockwise about
// it; false when the normal vanishes (a degenerate polygon).
bool ProjectToPlane(const std::vector<int>& corners, const PolygonSoup& soup, std::vector<Eigen::Vector2d>* points) {
  const size_t n = corners.size();
  // Relative to the first corner: exact for a polygon far from the origin.
  const Eigen::Vector3d& origin = soup.positions[corners[0]];
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (size_t i = 1; i + 1 < n; ++i) {
    normal += (soup.positions[corners[i]] - origin).cross(soup.positions[corners[i + 1]] - origin);
  }
  if (!(normal.norm() > 0.0)) return false;
  normal.normalize();
  const Eigen::Vector3d u = normal.unitOrthogonal(), v = normal.cross(u);
  points->resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& p = soup.positions[corners[i]];
    (*points)[i] = Eigen::Vector2d(p.dot(u), p.dot(v));
  }
  return true;
}

bool IsConvex(const std::vector<Eigen::Vector2d>& q) {
  const size_t n = q.size();
  for (size_t i = 0; i < n; ++i) {
    if (Cross(q[(i + 1) % n] - q[i], q[(i + 2) % n] - q[(i + 1) % n]) < 0.0) return false;
  }
  return true;
}

bool InsideTriangle(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                    const Eigen::Vector2d& c) {
  return Cross(b - a, p - a) >= 0.0 && Cross(c - b, p - b) >= 0.0 && Cross(a - c, p - c) >= 0.0;
}

// Triangles as corner positions k within the polygon (counter-clockwise
// `q`): ears clipped while there are any, the rest fanned.
std::vector<Eigen::Vector3i> ClipEars(const std::vector<Eigen::Vector2d>& q) {
  std::vector<int> left(q.size());
  for (size_t k = 0; k < q.size(); ++k) left[k] = static_cast<int>(k);
  std::vector<Eigen::Vector3i> triangles;
  while (left.size() > 3) {
    const size_t m = left.size();
    bool clipped = false;
    for (size_t i = 0; i < m && !clipped; ++i) {
      const int a = left[(i + m - 1) % m], b = left[i], c = left[(i + 1) % m];
      if (Cross(q[b] - q[a], q[c] - q[b]) <= 0.0) continue;  // reflex or flat
      bool empty = true;
      for (int k : left) {
        if (k != a && k != b && k != c && InsideTriangle(q[k], q[a], q[b], q[c])) {
          empty = false;
          break;
        }
      }
      if (!empty) continue;
      triangles.emplace_back(a, b, c);
      left.erase(left.begin() + static_cast<std::ptrdiff_t>(i));
      clipped = true;
    }
    if (!clipped) break;
  }
  for (size_t k = 1; k + 1 < left.size(); ++k) triangles.emplace_back(left[0], left[k], left[k + 1]);
  return triangles;
}

}  // namespace

void AppendPolygon(const std::vector<int>& corners, const std::vector<Eigen::Vector2d>* texcoords, PolygonSoup* soup) {
  const int n = static_cast<int>(corners.size());
  if (n < 3) {
    ++soup->num_points_and_lines;
    return;
  }
  std::vector<Eigen::Vector3i> local;  // corner positions within the polygon
  std::vector<Eigen::Vector2d> q;
  if (n > 3 && n <= kMaxEarClippedCorners && ProjectToPlane(corners, *soup, &q) && !IsConvex(q)) {
    local = ClipEars(q);
  } else {
    for (int k = 1; k + 1 < n; ++k) local.emplace_back(0, k, k + 1);
  }
  for (const Eigen::Vector3i& t : local) {
    soup->triangles.emplace_back(corners[t[0]], corners[t[1]], corners[t[2]]);
    if (texcoords != nullptr) {
      for (int c = 0; c < 3; ++c) soup->corner_texcoords.push_back((*texcoords)[t[c]]);
    }
  }
}

}  // namespace polyfit
