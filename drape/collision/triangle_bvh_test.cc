#include "drape/collision/triangle_bvh.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "polyfit/mesh/primitives.h"

namespace polyfit {
namespace {

// Brute force over the faces in `subset` (all when empty).
double NearestSquaredDistance(const Eigen::Vector3d& p, const Eigen::Matrix3Xd& v, const Eigen::Matrix3Xi& f,
                              const std::vector<int>& subset = {}) {
  double best = std::numeric_limits<double>::infinity();
  auto consider = [&](int k) {
    const Eigen::Vector3d q = ClosestPointOnTriangle(p, v.col(f(0, k)), v.col(f(1, k)), v.col(f(2, k)));
    best = std::min(best, (q - p).squaredNorm());
  };
  if (subset.empty()) {
    for (int k = 0; k < f.cols(); ++k) consider(k);
  } else {
    for (int k : subset) consider(k);
  }
  return best;
}

// The closest point against a dense barycentric sampling of the triangle:
// on the triangle, and no sample closer.
TEST(ClosestPointOnTriangleTest, NoSampleIsCloserInAnyRegion) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0.2), c(0.3, 0.9, -0.1);
  const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d p = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 2.0;
    const Eigen::Vector3d q = ClosestPointOnTriangle(p, a, b, c);
    // On the triangle's plane, with barycentrics in [0, 1].
    EXPECT_NEAR((q - a).dot(n), 0.0, 1e-12);
    const double d = (q - p).norm();
    constexpr int kSteps = 60;
    for (int s = 0; s <= kSteps; ++s) {
      for (int t = 0; s + t <= kSteps; ++t) {
        const Eigen::Vector3d x = a + (b - a) * (double(s) / kSteps) + (c - a) * (double(t) / kSteps);
        EXPECT_GE((x - p).norm(), d - 1e-12);
      }
    }
  }
  // Degenerate: collinear corners give the closest point of the segment,
  // coincident ones the corner.
  const Eigen::Vector3d p(0.5, 1.0, 0.0);
  EXPECT_NEAR(
      (ClosestPointOnTriangle(p, a, Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(2, 0, 0)) - Eigen::Vector3d(0.5, 0, 0))
          .norm(),
      0.0, 1e-12);
  EXPECT_NEAR((ClosestPointOnTriangle(p, a, a, a) - a).norm(), 0.0, 0.0);
}

TEST(TriangleBvhTest, MatchesBruteForceBeforeAndAfterARefit) {
  const TriangleMesh sphere = MakeIcosphere(3);
  TriangleBvh bvh(sphere.vertices, sphere.faces);
  EXPECT_EQ(bvh.num_faces(), sphere.num_faces());
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1.6, 1.6);
  // A non-rigid pose: each vertex turned about z by an angle growing with
  // its height, and the upper half stretched, so the rest grouping's boxes
  // grow and overlap.
  Eigen::Matrix3Xd posed = sphere.vertices;
  for (int v = 0; v < posed.cols(); ++v) {
    const double z = posed(2, v);
    posed.col(v) = Eigen::AngleAxisd(1.5 * z, Eigen::Vector3d::UnitZ()) * posed.col(v);
    if (z > 0.0) posed(0, v) *= 1.0 + z;
  }
  const Eigen::Matrix3Xd* poses[2] = {&sphere.vertices, &posed};
  for (const Eigen::Matrix3Xd* vertices : poses) {
    if (vertices == &posed) bvh.Refit(posed);
    for (int i = 0; i < 500; ++i) {
      const Eigen::Vector3d p(unit(rng), unit(rng), unit(rng));
      Eigen::Vector3d q;
      int face = -1;
      ASSERT_TRUE(bvh.ClosestPoint(p, *vertices, &q, &face));
      ASSERT_GE(face, 0);
      ASSERT_LT(face, sphere.num_faces());
      const double expected = NearestSquaredDistance(p, *vertices, sphere.faces);
      EXPECT_NEAR((q - p).squaredNorm(), expected, 1e-14);
      // The point lies on the face reported.
      const Eigen::Vector3d on_face =
          ClosestPointOnTriangle(p, vertices->col(sphere.faces(0, face)), vertices->col(sphere.faces(1, face)),
                                 vertices->col(sphere.faces(2, face)));
      EXPECT_NEAR((on_face - q).norm(), 0.0, 1e-14);
      // A hint, near or far or invalid, changes nothing but the time.
      for (int hint : {face, static_cast<int>(rng() % sphere.num_faces()), -1, sphere.num_faces() + 3}) {
        Eigen::Vector3d hinted;
        int hinted_face = -1;
        ASSERT_TRUE(bvh.ClosestPoint(p, *vertices, &hinted, &hinted_face, hint));
        EXPECT_EQ(hinted_face, face);
        EXPECT_EQ((hinted - q).norm(), 0.0);
      }
    }
  }
}

TEST(TriangleBvhTest, HoldsOnlyItsSubsetOfFaces) {
  const TriangleMesh sphere = MakeIcosphere(2);
  std::vector<int> upper;
  for (int f = 0; f < sphere.num_faces(); ++f) {
    if (sphere.vertices(2, sphere.faces(0, f)) > 0.2) upper.push_back(f);
  }
  const TriangleBvh bvh(sphere.vertices, sphere.faces, upper);
  int outside = 0;
  while (std::find(upper.begin(), upper.end(), outside) != upper.end()) ++outside;
  EXPECT_EQ(bvh.num_faces(), static_cast<int>(upper.size()));
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> unit(-1.5, 1.5);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(unit(rng), unit(rng), unit(rng));
    Eigen::Vector3d q;
    int face = -1;
    ASSERT_TRUE(bvh.ClosestPoint(p, sphere.vertices, &q, &face));
    EXPECT_NE(std::find(upper.begin(), upper.end(), face), upper.end());
    // A hint outside the subset is ignored.
    int hinted_face = -1;
    ASSERT_TRUE(bvh.ClosestPoint(p, sphere.vertices, &q, &hinted_face, outside));
    EXPECT_EQ(hinted_face, face);
    EXPECT_NEAR((q - p).squaredNorm(), NearestSquaredDistance(p, sphere.vertices, sphere.faces, upper), 1e-14);
  }
}

TEST(TriangleBvhTest, EmptyAndBadInput) {
  const TriangleMesh sphere = MakeIcosphere(1);
  const TriangleBvh empty(sphere.vertices, Eigen::Matrix3Xi(3, 0));
  Eigen::Vector3d q;
  int face = -1;
  EXPECT_FALSE(empty.ClosestPoint(Eigen::Vector3d::Zero(), sphere.vertices, &q, &face));
  EXPECT_FALSE(TriangleBvh().ClosestPoint(Eigen::Vector3d::Zero(), sphere.vertices, &q, &face));
  Eigen::Matrix3Xi bad = sphere.faces;
  bad(1, 3) = static_cast<int>(sphere.vertices.cols());
  EXPECT_THROW(TriangleBvh(sphere.vertices, bad), std::invalid_argument);
  EXPECT_THROW(TriangleBvh(sphere.vertices, sphere.faces, {0, sphere.num_faces()}), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
