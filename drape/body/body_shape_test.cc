#include "drape/body/body_shape.h"

#include <filesystem>

#include <gtest/gtest.h>

namespace polyfit {
namespace {

TEST(BodyShapeTest, ParsesAndValidates) {
  const BodyShape shape = BodyShape::Parse("gender=0.2,weight=0.9");
  EXPECT_DOUBLE_EQ(shape.gender, 0.2);
  EXPECT_DOUBLE_EQ(shape.weight, 0.9);
  EXPECT_DOUBLE_EQ(shape.muscle, 0.5);
  EXPECT_FALSE(shape.IsNeutral());
  EXPECT_TRUE(BodyShape{}.IsNeutral());
  EXPECT_THROW(BodyShape::Parse("gender=2"), std::invalid_argument);
  EXPECT_THROW(BodyShape::Parse("age=0.3"), std::invalid_argument);
  EXPECT_THROW(BodyShape::Parse("weight=heavy"), std::invalid_argument);
  EXPECT_THROW(BodyShape::Parse("weight"), std::invalid_argument);
  EXPECT_EQ(BodyShape::Parse(BodyShape{}.ToString()).ToString(), BodyShape{}.ToString());
}

#ifdef POLYFIT_SHARED_DATA_DIR
class MakeHumanShapeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    body_dir_ = std::filesystem::path(POLYFIT_SHARED_DATA_DIR) / "drape" / "body";
    if (!std::filesystem::exists(body_dir_ / "targets_macro_young")) GTEST_SKIP() << "needs " << body_dir_;
  }
  double Height(const BodyShape& shape) const {
    SkinnedBody body = LoadMakeHumanBody(body_dir_.string());
    ApplyBodyShape(body_dir_.string(), shape, &body);
    return body.mesh.vertices.row(1).maxCoeff() - body.mesh.vertices.row(1).minCoeff();
  }
  std::filesystem::path body_dir_;
};

TEST_F(MakeHumanShapeTest, NeutralIsTheBaseMeshAndParametersMoveIt) {
  SkinnedBody base = LoadMakeHumanBody(body_dir_.string());
  SkinnedBody neutral = base;
  ApplyBodyShape(body_dir_.string(), BodyShape{}, &neutral);
  EXPECT_EQ((neutral.base_vertices - base.base_vertices).cwiseAbs().maxCoeff(), 0.0);
  // Measured on hm08: 1.666 m neutral, 1.594 m female, 1.739 m male.
  const double h = Height(BodyShape{});
  EXPECT_NEAR(h, 1.666, 0.005);
  EXPECT_LT(Height(BodyShape::Parse("gender=0")), h - 0.04);
  EXPECT_GT(Height(BodyShape::Parse("gender=1")), h + 0.04);
  EXPECT_GT(Height(BodyShape::Parse("height=1")), h + 0.05);
  EXPECT_LT(Height(BodyShape::Parse("height=0")), h - 0.05);
  // Heavier: the waist widens. Joints follow the mesh.
  SkinnedBody heavy = base;
  ApplyBodyShape(body_dir_.string(), BodyShape::Parse("weight=1"), &heavy);
  EXPECT_GT(SurfaceArea(heavy.mesh), 1.03 * SurfaceArea(base.mesh));
  SkinnedBody tall = base;
  ApplyBodyShape(body_dir_.string(), BodyShape::Parse("height=1"), &tall);
  const int head = tall.skeleton.Find("Head");
  EXPECT_GT(tall.skeleton.rest_heads(1, head), base.skeleton.rest_heads(1, head) + 0.03);
}

TEST_F(MakeHumanShapeTest, MissingTargetsAreNamed) {
  SkinnedBody body = LoadMakeHumanBody(body_dir_.string());
  try {
    ApplyBodyShape("/nonexistent", BodyShape::Parse("weight=1"), &body);
    FAIL() << "expected BodyError";
  } catch (const BodyError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent"), std::string::npos);
  }
}
#endif

}  // namespace
}  // namespace polyfit
