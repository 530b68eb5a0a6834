#include "drape/collision/signed_distance.h"

#include <cmath>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

#include "polyfit/mesh/primitives.h"

namespace polyfit {
namespace {

TEST(BodySignedDistanceTest, SphereInsideAndOutside) {
  const TriangleMesh sphere = MakeIcosphere(4);  // unit sphere, edges ~0.08
  const BodySignedDistance exact(sphere);
  const NearestVertexDistance approximate(sphere);
  std::mt19937 rng(3);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> radius(0.3, 1.7);
  int checked = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d direction = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
    const double r = radius(rng);
    const Eigen::Vector3d p = r * direction;
    const SignedDistanceResult e = exact.Query(p);
    // The polyhedron lies within 0.003 inside the sphere.
    EXPECT_NEAR(e.distance, r - 1.0, 4e-3) << "r " << r;
    EXPECT_NEAR(e.normal.norm(), 1.0, 1e-9);
    if (std::abs(r - 1.0) > 0.01) {
      EXPECT_EQ(e.distance < 0.0, r < 1.0);
      // Nearest vertex plus normal: right sign, distance within an edge's
      // length near the surface.
      const SignedDistanceResult a = approximate.Query(p);
      EXPECT_EQ(a.distance < 0.0, r < 1.0);
      if (std::abs(r - 1.0) < 0.1) {
        EXPECT_NEAR(a.distance, r - 1.0, 0.01);
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 1900);
}

TEST(BodySignedDistanceTest, SignIsRightOnEdgesAndVertices) {
  // Points straight out from vertices and edge midpoints, just inside and
  // outside: the closest features are vertices and edges, where a face
  // normal alone can give the wrong sign.
  const TriangleMesh sphere = MakeIcosphere(2);
  const BodySignedDistance exact(sphere);
  for (int v = 0; v < sphere.num_vertices(); ++v) {
    const Eigen::Vector3d x = sphere.vertices.col(v);
    EXPECT_GT(exact.Query(1.01 * x).distance, 0.0);
    EXPECT_LT(exact.Query(0.99 * x).distance, 0.0);
  }
  for (int f = 0; f < sphere.num_faces(); ++f) {
    const Eigen::Vector3d mid =
        0.5 * (sphere.vertices.col(sphere.faces(0, f)) + sphere.vertices.col(sphere.faces(1, f)));
    EXPECT_GT(exact.Query(1.01 * mid).distance, 0.0);
    EXPECT_LT(exact.Query(0.99 * mid).distance, 0.0);
  }
}

TEST(BodySignedDistanceTest, FollowsANewPose) {
  TriangleMesh sphere = MakeIcosphere(3);
  BodySignedDistance exact(sphere);
  NearestVertexDistance approximate(sphere);
  Eigen::Matrix3Xd moved = sphere.vertices;
  moved.row(0).array() += 5.0;
  exact.SetVertices(moved);
  approximate.SetVertices(moved);
  EXPECT_NEAR(exact.Query(Eigen::Vector3d(5, 0, 0)).distance, -1.0, 0.01);
  EXPECT_LT(approximate.Query(Eigen::Vector3d(5.5, 0, 0)).distance, 0.0);
  const Eigen::VectorXd many = exact.SignedDistances(moved * 1.0, 2);
  EXPECT_LT(many.cwiseAbs().maxCoeff(), 1e-12);  // the vertices themselves
  EXPECT_THROW(approximate.SetVertices(moved.leftCols(5)), std::invalid_argument);
  // A point with a NaN: no vertex, a NaN distance, no crash.
  const SignedDistanceResult lost = approximate.Query(Eigen::Vector3d(std::nan(""), 0, 0));
  EXPECT_EQ(lost.face, -1);
  EXPECT_TRUE(std::isnan(lost.distance));
}

TEST(BodySignedDistanceTest, HintsChangeNoAnswer) {
  // Hints, near, far or none, give the same answers as queries from
  // scratch; NearestVertexDistance refitted to a pose answers as one built
  // at it.
  const TriangleMesh sphere = MakeIcosphere(4);
  const BodySignedDistance exact(sphere);
  NearestVertexDistance approximate(sphere);
  Eigen::Matrix3Xd moved = sphere.vertices;
  moved.row(2) *= 1.3;  // a pose: the tree refitted, not rebuilt
  approximate.SetVertices(moved);
  std::mt19937 rng(5);
  std::normal_distribution<double> gauss;
  Eigen::Matrix3Xd points(3, 500);
  for (int i = 0; i < points.cols(); ++i) {
    // A walk over the surface, as a garment's consecutive vertices.
    const double angle = 0.02 * i;
    points.col(i) = (1.0 + 0.05 * gauss(rng)) * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0.1 * gauss(rng));
  }
  const Eigen::VectorXd all = exact.SignedDistances(points, 2);
  int face = -1;
  const NearestVertexDistance built(TriangleMesh{moved, sphere.faces, {}});  // at the pose from the start
  int hint = -1;
  for (int i = 0; i < points.cols(); ++i) {
    const SignedDistanceResult e = exact.Query(points.col(i), face);
    EXPECT_EQ(all[i], e.distance) << i;
    face = e.face;
    const SignedDistanceResult fresh = built.Query(points.col(i));
    const SignedDistanceResult hinted = approximate.Query(points.col(i), hint);
    EXPECT_EQ(hinted.face, fresh.face) << i;
    EXPECT_EQ(hinted.distance, fresh.distance) << i;
    EXPECT_EQ(approximate.Query(points.col(i), (hinted.face + 97) % sphere.num_vertices()).face, fresh.face);
    hint = hinted.face;
  }
}

}  // namespace
}  // namespace polyfit
