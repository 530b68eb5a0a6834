#include "polyfit/mesh/polygon_soup.h"

#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace polyfit {
namespace {

// Soup positions from points in the plane z = 0, turned and moved so that
// the plane is a general one.
PolygonSoup SoupOf(const std::vector<Eigen::Vector2d>& points) {
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  PolygonSoup soup;
  for (const Eigen::Vector2d& p : points) {
    soup.positions.push_back(turn * Eigen::Vector3d(p.x(), p.y(), 0.0) + Eigen::Vector3d(100, -50, 20));
  }
  return soup;
}

Eigen::Vector3d PlaneNormal() {
  return Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()) * Eigen::Vector3d::UnitZ();
}

// Total area, and the least (signed) area of a triangle along `normal`.
std::pair<double, double> Areas(const PolygonSoup& soup, const Eigen::Vector3d& normal) {
  double total = 0.0, least = 1e300;
  for (const Eigen::Vector3i& t : soup.triangles) {
    const Eigen::Vector3d& a = soup.positions[t[0]];
    const double signed_area = 0.5 * (soup.positions[t[1]] - a).cross(soup.positions[t[2]] - a).dot(normal);
    total += signed_area;
    least = std::min(least, signed_area);
  }
  return {total, least};
}

TEST(PolygonSoupTest, ConvexPolygonIsAFan) {
  PolygonSoup soup = SoupOf({{0, 0}, {1, 0}, {1, 1}, {0, 1}});
  AppendPolygon({0, 1, 2, 3}, nullptr, &soup);
  ASSERT_EQ(soup.triangles.size(), 2u);
  EXPECT_EQ(soup.triangles[0], Eigen::Vector3i(0, 1, 2));
  EXPECT_EQ(soup.triangles[1], Eigen::Vector3i(0, 2, 3));
}

TEST(PolygonSoupTest, ConcavePolygonIsEarClippedInItsPlane) {
  // An L of area 3 whose fan from corner 0 would cover the missing square
  // (a fan's triangles would sum to 3 only by cancelling).
  const std::vector<Eigen::Vector2d> l = {{1, 1}, {1, 2}, {0, 2}, {0, 0}, {2, 0}, {2, 1}};
  for (bool reversed : {false, true}) {
    PolygonSoup soup = SoupOf(l);
    std::vector<int> corners = {0, 1, 2, 3, 4, 5};
    if (reversed) std::reverse(corners.begin(), corners.end());
    std::vector<Eigen::Vector2d> uv(l.rbegin(), l.rend());
    if (!reversed) uv.assign(l.begin(), l.end());
    AppendPolygon(corners, &uv, &soup);
    ASSERT_EQ(soup.triangles.size(), 4u);
    const auto [total, least] = Areas(soup, reversed ? -PlaneNormal() : PlaneNormal());
    EXPECT_NEAR(total, 3.0, 1e-9) << reversed;
    EXPECT_GT(least, 1e-9) << reversed;  // every triangle inside, oriented as the polygon
    // Texture coordinates follow their corners (here they equal the plane
    // coordinates of the corner).
    for (size_t t = 0; t < soup.triangles.size(); ++t) {
      for (int c = 0; c < 3; ++c) EXPECT_EQ(soup.corner_texcoords[3 * t + c], l[soup.triangles[t][c]]);
    }
  }
}

TEST(PolygonSoupTest, DegeneratePolygonsAreFannedAndPointsCounted) {
  PolygonSoup soup = SoupOf({{0, 0}, {1, 0}, {2, 0}, {3, 0}});
  AppendPolygon({0, 1, 2, 3}, nullptr, &soup);  // collinear: no plane
  EXPECT_EQ(soup.triangles.size(), 2u);
  AppendPolygon({0, 1}, nullptr, &soup);
  AppendPolygon({2}, nullptr, &soup);
  EXPECT_EQ(soup.num_points_and_lines, 2);
}

}  // namespace
}  // namespace polyfit
