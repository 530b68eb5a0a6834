#include "sft/solver/fold_mirror.h"

#include <cmath>

#include <gtest/gtest.h>

namespace polyfit {
namespace {

// An n by n grid of unit spacing in the plane z = 2, two faces a cell.
TriangleMesh Grid(int n) {
  TriangleMesh mesh;
  mesh.vertices.resize(3, n * n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) mesh.vertices.col(i * n + j) = Eigen::Vector3d(i, j, 2.0);
  }
  mesh.faces.resize(3, 2 * (n - 1) * (n - 1));
  int f = 0;
  for (int i = 0; i + 1 < n; ++i) {
    for (int j = 0; j + 1 < n; ++j) {
      const int a = i * n + j, b = (i + 1) * n + j, c = (i + 1) * n + j + 1, d = i * n + j + 1;
      mesh.faces.col(f++) = Eigen::Vector3i(a, b, c);
      mesh.faces.col(f++) = Eigen::Vector3i(a, c, d);
    }
  }
  return mesh;
}

// The part x > x0 turned by `angle` about the line x = x0, z = 2.
Eigen::Matrix3Xd Folded(const TriangleMesh& mesh, double x0, double angle) {
  Eigen::Matrix3Xd v = mesh.vertices;
  for (int i = 0; i < v.cols(); ++i) {
    const double u = v(0, i) - x0;
    if (u <= 0.0) continue;
    v(0, i) = x0 + u * std::cos(angle);
    v(2, i) = 2.0 + u * std::sin(angle);
  }
  return v;
}

// Hinges whose edge lies on the line x = x0.
std::vector<std::uint8_t> CreaseAt(const TriangleMesh& mesh, const std::vector<MeshHinge>& hinges, double x0) {
  std::vector<std::uint8_t> crease(hinges.size(), 0);
  for (size_t h = 0; h < hinges.size(); ++h) {
    crease[h] = mesh.vertices(0, hinges[h].vertices[0]) == x0 && mesh.vertices(0, hinges[h].vertices[1]) == x0;
  }
  return crease;
}

// A flap folded toward the camera by 50 degrees becomes the same flap
// folded 50 degrees the other way; the sheet and the crease stay.
TEST(FoldMirrorTest, TheFlapTurnsToTheOtherSideOfTheSheet) {
  const TriangleMesh mesh = Grid(8);
  const std::vector<MeshHinge> hinges = InteriorHinges(mesh);
  const double angle = 50.0 * M_PI / 180.0;
  Eigen::Matrix3Xd mirrored;
  const int count = MirrorFoldFlap(mesh, hinges, CreaseAt(mesh, hinges, 5.0), Folded(mesh, 5.0, angle), &mirrored);
  EXPECT_EQ(count, 2 * 8);  // the columns x = 6 and 7
  EXPECT_LT((mirrored - Folded(mesh, 5.0, -angle)).cwiseAbs().maxCoeff(), 1e-9);
}

// No crease, a crease that does not cut the surface through, a flap
// smaller than asked for: nothing mirrored. A flat sheet's flap mirrored
// is where it was.
TEST(FoldMirrorTest, NothingMirroredWithoutAFlapOrAPlane) {
  const TriangleMesh mesh = Grid(8);
  const std::vector<MeshHinge> hinges = InteriorHinges(mesh);
  const Eigen::Matrix3Xd folded = Folded(mesh, 5.0, 0.6);
  Eigen::Matrix3Xd mirrored;
  EXPECT_EQ(MirrorFoldFlap(mesh, hinges, std::vector<std::uint8_t>(hinges.size(), 0), folded, &mirrored), 0);
  EXPECT_EQ(mirrored, folded);
  std::vector<std::uint8_t> partial = CreaseAt(mesh, hinges, 5.0);
  for (size_t h = 0; h < hinges.size(); ++h) {
    if (mesh.vertices(1, hinges[h].vertices[0]) > 4.0 || mesh.vertices(1, hinges[h].vertices[1]) > 4.0) partial[h] = 0;
  }
  EXPECT_EQ(MirrorFoldFlap(mesh, hinges, partial, folded, &mirrored), 0);
  EXPECT_EQ(MirrorFoldFlap(mesh, hinges, CreaseAt(mesh, hinges, 6.0), Folded(mesh, 6.0, 0.6), &mirrored, 15), 0);
  EXPECT_EQ(MirrorFoldFlap(mesh, hinges, CreaseAt(mesh, hinges, 6.0), Folded(mesh, 6.0, 0.6), &mirrored, 14), 8);
  EXPECT_EQ(MirrorFoldFlap(mesh, hinges, CreaseAt(mesh, hinges, 5.0), mesh.vertices, &mirrored), 16);
  EXPECT_LT((mirrored - mesh.vertices).cwiseAbs().maxCoeff(), 1e-12);
}

// A ridge along x = 3 that dies out inside the sheet (y = 1..5), pulled
// toward the camera at the origin: turned inside out, it lies as far
// behind the sheet's plane z = 2, every vertex on its own ray; the rest
// stays.
TEST(FoldMirrorTest, ACreaseInsideTheSheetTurnsInsideOutAlongTheRays) {
  const TriangleMesh mesh = Grid(8);
  const std::vector<MeshHinge> hinges = InteriorHinges(mesh);
  std::vector<std::uint8_t> crease = CreaseAt(mesh, hinges, 3.0);
  for (size_t h = 0; h < hinges.size(); ++h) {
    for (int k : {0, 1}) crease[h] = crease[h] && mesh.vertices(1, hinges[h].vertices[k]) >= 1.0;
    for (int k : {0, 1}) crease[h] = crease[h] && mesh.vertices(1, hinges[h].vertices[k]) <= 5.0;
  }
  Eigen::Matrix3Xd ridge = mesh.vertices;
  for (int v = 0; v < ridge.cols(); ++v) {
    const double y = mesh.vertices(1, v);
    if (mesh.vertices(0, v) == 3.0 && y >= 1.0 && y <= 5.0) ridge.col(v) *= 1.0 - 0.05 * (1.0 + (y == 3.0));
  }
  EXPECT_EQ(MirrorFoldFlap(mesh, hinges, crease, ridge, &ridge), 0);  // no flap cut off
  Eigen::Matrix3Xd flipped;
  const int count = FlipCreaseAlongRays(mesh, hinges, crease, ridge, &flipped);
  EXPECT_GE(count, 5);  // the ridge's five and the band's vertices beside it, on the plane
  for (int v = 0; v < ridge.cols(); ++v) {
    EXPECT_NEAR(flipped(2, v) - 2.0, -(ridge(2, v) - 2.0), 1e-12) << v;
    EXPECT_NEAR(flipped(0, v) / flipped(2, v), ridge(0, v) / ridge(2, v), 1e-12) << v;
    EXPECT_NEAR(flipped(1, v) / flipped(2, v), ridge(1, v) / ridge(2, v), 1e-12) << v;
  }
  EXPECT_GT((flipped - ridge).cwiseAbs().maxCoeff(), 0.1);
  EXPECT_EQ(FlipCreaseAlongRays(mesh, hinges, crease, flipped, &flipped), count);  // and back
  EXPECT_LT((flipped - ridge).cwiseAbs().maxCoeff(), 1e-12);
}

// No crease, a band smaller than asked for, a sheet whose plane holds the
// camera (seen edge-on): nothing moved.
TEST(FoldMirrorTest, NothingTurnedWithoutABandOrSeenEdgeOn) {
  const TriangleMesh mesh = Grid(8);
  const std::vector<MeshHinge> hinges = InteriorHinges(mesh);
  const Eigen::Matrix3Xd folded = Folded(mesh, 5.0, 0.6);
  Eigen::Matrix3Xd flipped;
  EXPECT_EQ(FlipCreaseAlongRays(mesh, hinges, std::vector<std::uint8_t>(hinges.size(), 0), folded, &flipped), 0);
  EXPECT_EQ(flipped, folded);
  const std::vector<std::uint8_t> crease = CreaseAt(mesh, hinges, 5.0);  // 7 hinges, 14 faces
  Eigen::Matrix3Xd far = folded;
  far.row(2).array() += 8.0;  // seen within 60 degrees of straight on
  EXPECT_EQ(FlipCreaseAlongRays(mesh, hinges, crease, far, &flipped, 15), 0);
  EXPECT_GT(FlipCreaseAlongRays(mesh, hinges, crease, far, &flipped, 14), 0);
  Eigen::Matrix3Xd edge_on = mesh.vertices;
  edge_on.row(2).setZero();  // the plane z = 0 holds the camera
  EXPECT_EQ(FlipCreaseAlongRays(mesh, hinges, crease, edge_on, &flipped), 0);
  EXPECT_EQ(flipped, edge_on);
}

}  // namespace
}  // namespace polyfit
