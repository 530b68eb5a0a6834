#include "drape/garment/procedural_garment.h"

#include <filesystem>

#include <gtest/gtest.h>

#include "drape/body/makehuman_test_body.h"
#include "drape/body/procedural_body.h"
#include "drape/collision/signed_distance.h"
#include "polyfit/mesh/mesh_topology.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;

const fs::path kBodyDir = fs::path(POLYFIT_SHARED_DATA_DIR) / "drape/body";

class ProceduralGarmentTest : public ::testing::Test {
 protected:
  void SetUp() override {
    body_ = SharedMakeHumanBody(kBodyDir);
    if (body_ == nullptr) GTEST_SKIP() << "shared data absent: " << kBodyDir;
  }
  double JointY(const char* name) const { return body_->skeleton.rest_heads(1, body_->skeleton.Find(name)); }
  const SkinnedBody* body_ = nullptr;
};

int ConnectedPieces(const TriangleMesh& mesh) {
  std::vector<int> labels;
  return ConnectedComponents(FaceFaceAdjacency(mesh), &labels);
}

// Every kind is one valid piece at its offset off the skin, decimated to
// about the vertices asked for.
TEST_F(ProceduralGarmentTest, EachKindIsOnePieceAtItsOffset) {
  const BodySignedDistance distance(body_->mesh);
  for (ProceduralGarmentKind kind :
       {ProceduralGarmentKind::kTop, ProceduralGarmentKind::kBottom, ProceduralGarmentKind::kSuit}) {
    ProceduralGarmentOptions options;
    options.kind = kind;
    options.sleeve = 0.6;
    options.leg = 0.7;
    options.offset = 0.01;
    options.target_vertices = 1000;
    const TriangleMesh garment = MakeProceduralGarment(*body_, options);
    SCOPED_TRACE(options.Describe());
    EXPECT_TRUE(garment.Validate().empty());
    EXPECT_EQ(ConnectedPieces(garment), 1);
    EXPECT_GT(garment.num_vertices(), 900);
    EXPECT_LT(garment.num_vertices(), 1100);
    const Eigen::VectorXd d = distance.SignedDistances(garment.vertices);
    // Decimation keeps the vertices on the moved skin, whose curvature
    // (fingers of the skin between the legs, the armpits) moves the
    // distance a little off the offset.
    EXPECT_GT(d.minCoeff(), 0.0);
    EXPECT_NEAR(d.mean(), 0.01, 1.5e-3);
  }
}

// The cuts follow the options: a top stays above its hem, a bottom below
// its waist, a longer sleeve or leg covers more.
TEST_F(ProceduralGarmentTest, TheCutsFollowTheOptions) {
  const double hip = JointY("LeftUpLeg"), spine = JointY("Spine1");
  ProceduralGarmentOptions top;
  top.kind = ProceduralGarmentKind::kTop;
  top.hem = 0.5;
  top.offset = 0.0;
  top.target_vertices = 0;
  const TriangleMesh short_top = MakeProceduralGarment(*body_, top);
  // Arms hang below the hem; the torso does not reach under it.
  top.sleeve = 0.0;
  const TriangleMesh sleeveless = MakeProceduralGarment(*body_, top);
  EXPECT_GT(sleeveless.vertices.row(1).minCoeff(), hip + 0.5 * (spine - hip) - 1e-9);
  top.sleeve = 1.0;
  const TriangleMesh long_top = MakeProceduralGarment(*body_, top);
  EXPECT_LT(SurfaceArea(sleeveless), SurfaceArea(short_top));
  EXPECT_LT(SurfaceArea(short_top), SurfaceArea(long_top));
  // Sleeves end at the wrists: no hand is covered.
  EXPECT_GT(long_top.vertices.row(1).minCoeff(), JointY("LeftHand") - 0.03);

  ProceduralGarmentOptions bottom;
  bottom.kind = ProceduralGarmentKind::kBottom;
  bottom.waist = 0.4;
  bottom.offset = 0.0;
  bottom.target_vertices = 0;
  bottom.leg = 0.3;
  const TriangleMesh shorts = MakeProceduralGarment(*body_, bottom);
  bottom.leg = 1.0;
  const TriangleMesh trousers = MakeProceduralGarment(*body_, bottom);
  EXPECT_LT(trousers.vertices.row(1).maxCoeff(), hip + 0.4 * (spine - hip) + 1e-9);
  EXPECT_LT(SurfaceArea(shorts), SurfaceArea(trousers));
  EXPECT_GT(shorts.vertices.row(1).minCoeff(), JointY("LeftLeg"));
  EXPECT_GT(trousers.vertices.row(1).minCoeff(), JointY("LeftFoot") - 0.05);
  EXPECT_LT(trousers.vertices.row(1).minCoeff(), JointY("LeftLeg"));
}

TEST_F(ProceduralGarmentTest, DrawsAreSeededAndValid) {
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const ProceduralGarmentOptions a = DrawProceduralGarment(seed), b = DrawProceduralGarment(seed);
    EXPECT_TRUE(a.Validate().empty()) << a.Validate();
    EXPECT_EQ(a.Describe(), b.Describe());
    EXPECT_GE(a.offset, 0.003);
    EXPECT_LE(a.offset, 0.015);
  }
  EXPECT_NE(DrawProceduralGarment(1).Describe(), DrawProceduralGarment(2).Describe());
}

TEST(ProceduralGarmentErrors, InvalidOptionsAndRigsAreRefused) {
  const SkinnedBody capsules = MakeProceduralBody();
  ProceduralGarmentOptions options;
  // The capsule body's rig has no hands or feet.
  try {
    MakeProceduralGarment(capsules, options);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no joint"), std::string::npos) << e.what();
  }
  options.sleeve = 1.5;
  EXPECT_NE(options.Validate(), "");
  EXPECT_THROW(MakeProceduralGarment(capsules, options), std::invalid_argument);
  options.sleeve = 0.5;
  options.offset = -0.01;
  EXPECT_NE(options.Validate(), "");
  options.offset = 0.01;
  options.target_vertices = 50;
  EXPECT_NE(options.Validate(), "");
}

}  // namespace
}  // namespace polyfit
