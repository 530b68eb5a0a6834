#include "drape/simulate/skinned_contacts.h"

#include <cmath>

#include <gtest/gtest.h>

#include "drape/body/procedural_body.h"
#include "drape/collision/signed_distance.h"
#include "polyfit/eval/mesh_metrics.h"

namespace polyfit {
namespace {

class SkinnedContactsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    body_ = MakeProceduralBody();
    // Every 7th body vertex lifted 1 cm along its normal (bound), every
    // 11th lifted 10 cm (out of reach).
    const Eigen::Matrix3Xd normals = VertexNormals(body_.mesh);
    std::vector<Eigen::Vector3d> points;
    for (int v = 0; v < body_.mesh.num_vertices(); ++v) {
      if (v % 7 == 0) points.push_back(body_.mesh.vertices.col(v) + 0.01 * normals.col(v));
      if (v % 11 == 0) points.push_back(body_.mesh.vertices.col(v) + 0.10 * normals.col(v));
    }
    garment_.resize(3, points.size());
    for (size_t i = 0; i < points.size(); ++i) garment_.col(i) = points[i];
  }

  std::vector<Eigen::Isometry3d> Identity() const {
    return std::vector<Eigen::Isometry3d>(body_.skeleton.num_joints(), Eigen::Isometry3d::Identity());
  }

  SkinnedBody body_;
  Eigen::Matrix3Xd garment_;  // 3 by #V
};

TEST_F(SkinnedContactsTest, AtRestTheContactsAreTheClosestBodyPointsWithinReach) {
  const double reach = 0.03;
  const SkinnedContacts contacts(body_, garment_, reach);
  std::vector<BodyContact> posed;
  contacts.Pose(Identity(), &posed);
  const BodySignedDistance distance(body_.mesh);
  int within = 0;
  for (int v = 0; v < garment_.cols(); ++v) within += std::abs(distance.Query(garment_.col(v)).distance) <= reach;
  ASSERT_GT(within, 20);
  ASSERT_EQ(static_cast<int>(posed.size()), within);
  const TriangleMesh& mesh = body_.mesh;
  for (const BodyContact& c : posed) {
    const SignedDistanceResult r = distance.Query(garment_.col(c.vertex));
    EXPECT_LT((c.point - r.closest).norm(), 1e-12);
    const Eigen::Vector3d a = mesh.vertices.col(mesh.faces(0, r.face)), b = mesh.vertices.col(mesh.faces(1, r.face)),
                          d = mesh.vertices.col(mesh.faces(2, r.face));
    EXPECT_LT((c.normal - (b - a).cross(d - a).normalized()).norm(), 1e-12);
    // Off its plane by no more than the distance (the face's normal is the
    // direction to the closest point only inside the face).
    EXPECT_LE(std::abs(c.normal.dot(garment_.col(c.vertex) - c.point)), std::abs(r.distance) + 1e-12);
  }
}

TEST_F(SkinnedContactsTest, ARigidMotionOfTheWholeBodyMovesThePlanesRigidly) {
  const SkinnedContacts contacts(body_, garment_, 0.03);
  std::vector<BodyContact> rest, moved;
  contacts.Pose(Identity(), &rest);
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
  motion.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  motion.translation() = Eigen::Vector3d(0.3, -0.2, 1.1);
  contacts.Pose(std::vector<Eigen::Isometry3d>(body_.skeleton.num_joints(), motion), &moved);
  ASSERT_EQ(rest.size(), moved.size());
  for (size_t i = 0; i < rest.size(); ++i) {
    EXPECT_EQ(moved[i].vertex, rest[i].vertex);
    EXPECT_LT((moved[i].point - motion * rest[i].point).norm(), 1e-12);
    EXPECT_LT((moved[i].normal - motion.linear() * rest[i].normal).norm(), 1e-12);
  }
}

TEST_F(SkinnedContactsTest, APointBoundAtABodyVertexFollowsThatVertexsSkinning) {
  const SkinnedContacts contacts(body_, garment_, 0.03);
  std::vector<BodyContact> rest, posed;
  contacts.Pose(Identity(), &rest);
  // Bend every joint by its own rotation about its own rest position.
  std::vector<Eigen::Isometry3d> pose = Identity();
  for (int j = 0; j < body_.skeleton.num_joints(); ++j) {
    const Eigen::Vector3d at = body_.skeleton.rest_heads.col(j);
    const Eigen::Matrix3d turn =
        Eigen::AngleAxisd(0.2 + 0.05 * j, Eigen::Vector3d(j % 3, 1, (j + 1) % 2).normalized()).toRotationMatrix();
    pose[j].linear() = turn;
    pose[j].translation() = at - turn * at + Eigen::Vector3d(0.0, 0.01 * j, 0.0);
  }
  contacts.Pose(pose, &posed);
  const Eigen::Matrix3Xd skinned = SkinVertices(body_, pose);
  int at_vertices = 0;
  for (size_t i = 0; i < rest.size(); ++i) {
    for (int v = 0; v < body_.mesh.num_vertices(); ++v) {
      if ((body_.mesh.vertices.col(v) - rest[i].point).norm() > 1e-12) continue;
      EXPECT_LT((posed[i].point - skinned.col(v)).norm(), 1e-9) << "contact " << i << " at body vertex " << v;
      ++at_vertices;
      break;
    }
  }
  EXPECT_GT(at_vertices, 10);
}

TEST_F(SkinnedContactsTest, APoseOfTheWrongSizeIsRefused) {
  const SkinnedContacts contacts(body_, garment_, 0.03);
  std::vector<BodyContact> posed;
  EXPECT_THROW(contacts.Pose(std::vector<Eigen::Isometry3d>(2, Eigen::Isometry3d::Identity()), &posed),
               std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
