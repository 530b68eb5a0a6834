#include "polyfit/model/polyfit_model.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "polyfit/mesh/primitives.h"
#include "polyfit/model/orient_patches.h"
#include "polyfit/model/reconstruction.h"
#include "polyfit/pipeline/fit_mesh.h"
#include "polyfit/util/scoped_temp_dir.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;

class PolyFitModelTest : public ::testing::Test {
 protected:
  void SetUp() override {
    MeshFitOptions options;
    options.clustering.num_patches = 100;
    options.jet_fit.refine_orientation = true;  // non-trivial iterations and flags
    options.evaluate = false;
    FitMesh(options, MakeBumpyTorus(60, 24), &model_, nullptr);
  }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  std::string LoadError(const std::string& path) const {
    try {
      LoadPolyFitModel(path);
    } catch (const ModelIoError& e) {
      return e.what();
    }
    return "(no error)";
  }
  ScopedTempDir temp_{"polyfit_model"};
  const fs::path& dir_ = temp_.path();
  PolyFitModel model_;
};

TEST_F(PolyFitModelTest, RoundTripIsExact) {
  SavePolyFitModel(Path("m.pfm"), model_);
  const PolyFitModel back = LoadPolyFitModel(Path("m.pfm"));
  ASSERT_EQ(back.num_patches(), model_.num_patches());
  for (int p = 0; p < model_.num_patches(); ++p) {
    const JetPatch &a = model_.patches[p], &b = back.patches[p];
    EXPECT_EQ(a.order, b.order);
    EXPECT_EQ(a.flags, b.flags);
    EXPECT_EQ(a.num_points, b.num_points);
    EXPECT_EQ(a.refinement_iterations, b.refinement_iterations);
    EXPECT_EQ(a.rms_residual, b.rms_residual);
    EXPECT_EQ(a.frame.scale, b.frame.scale);
    EXPECT_EQ(a.frame.rotation, b.frame.rotation);
    EXPECT_EQ(a.frame.translation, b.frame.translation);
    EXPECT_EQ(a.coefficients, b.coefficients);
  }
  EXPECT_EQ(back.faces, model_.faces);
  EXPECT_EQ(back.face_patch, model_.face_patch);
  EXPECT_EQ(back.membership_offsets, model_.membership_offsets);
  EXPECT_EQ(back.membership_patch, model_.membership_patch);
  EXPECT_EQ(back.membership_uv, model_.membership_uv);
  // The loaded model rebuilds the same surface.
  const ReconstructionOptions options;
  EXPECT_EQ(ReconstructVertices(back, options), ReconstructVertices(model_, options));
}

TEST_F(PolyFitModelTest, BoundaryPointsAndAdjacencyAgree) {
  const auto points = model_.BoundaryPoints();
  const auto adjacency = model_.PatchAdjacency();
  ASSERT_FALSE(points.empty());
  double max_gap = 0.0, sum_gap = 0.0;
  for (const PatchBoundaryPoint& p : points) {
    EXPECT_LT(p.patch_a, p.patch_b);
    EXPECT_TRUE(std::binary_search(adjacency[p.patch_a].begin(), adjacency[p.patch_a].end(), p.patch_b));
    // Both parameterisations land near the same vertex.
    const Eigen::Vector3d a = model_.patches[p.patch_a].PointInWorld(p.uv_a.x(), p.uv_a.y());
    const Eigen::Vector3d b = model_.patches[p.patch_b].PointInWorld(p.uv_b.x(), p.uv_b.y());
    max_gap = std::max(max_gap, (a - b).norm());
    sum_gap += (a - b).norm();
  }
  // The torus is 2.7 across, its tube 0.7; measured: mean 2.0e-3, max 8.1e-3.
  EXPECT_LT(sum_gap / points.size(), 3e-3);
  EXPECT_LT(max_gap, 1.5e-2);
  // On a closed torus every patch has neighbours.
  for (const auto& list : adjacency) EXPECT_GE(list.size(), 3u);
}

TEST_F(PolyFitModelTest, TruncatedFileIsNamed) {
  SavePolyFitModel(Path("m.pfm"), model_);
  fs::resize_file(Path("m.pfm"), fs::file_size(Path("m.pfm")) - 10);
  const std::string error = LoadError(Path("m.pfm"));
  EXPECT_NE(error.find("m.pfm"), std::string::npos) << error;
  EXPECT_NE(error.find("truncated"), std::string::npos) << error;
}

TEST_F(PolyFitModelTest, WrongMagicAndVersionAreNamed) {
  std::ofstream(Path("x.pfm")) << "not a model";
  EXPECT_NE(LoadError(Path("x.pfm")).find("not a PolyFit model"), std::string::npos);
  SavePolyFitModel(Path("v.pfm"), model_);
  {
    std::fstream f(Path("v.pfm"), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(8);
    const std::uint32_t version = 99;
    f.write(reinterpret_cast<const char*>(&version), sizeof(version));
  }
  EXPECT_NE(LoadError(Path("v.pfm")).find("version 99"), std::string::npos);
  EXPECT_NE(LoadError(Path("absent.pfm")).find("cannot be opened"), std::string::npos);
}

TEST_F(PolyFitModelTest, CorruptSizesAreRejectedBeforeAllocating) {
  SavePolyFitModel(Path("c.pfm"), model_);
  {
    std::fstream f(Path("c.pfm"), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(12);  // the vertex count
    const std::uint32_t huge = 0xFFFFFFF0u;
    f.write(reinterpret_cast<const char*>(&huge), sizeof(huge));
  }
  EXPECT_NE(LoadError(Path("c.pfm")).find("expected"), std::string::npos);
}

TEST_F(PolyFitModelTest, InvalidModelIsNotSaved) {
  PolyFitModel broken = model_;
  broken.membership_patch[0] = 12345;
  EXPECT_THROW(SavePolyFitModel(Path("b.pfm"), broken), ModelIoError);
  EXPECT_FALSE(fs::exists(Path("b.pfm")));
}

// Frames turned about their normals keep the surface: the jet re-expressed
// in the turned (u, v) gives the same points.
TEST(AlignPatchFramesTest, TurningAPatchKeepsItsSurface) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (int order = 1; order <= kMaxJetOrder; ++order) {
    JetPatch patch;
    patch.order = order;
    for (int k = 0; k < NumJetCoefficients(order); ++k) patch.coefficients[k] = 0.3 * uniform(rng);
    patch.frame.scale = 0.7;
    patch.frame.rotation = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
    patch.frame.translation = Eigen::Vector3d(0.2, -0.4, 1.5);
    JetPatch turned = patch;
    const double theta = 2.0 * uniform(rng);
    TurnPatchAboutNormal(theta, &turned);
    EXPECT_TRUE(turned.frame.rotation.col(2).isApprox(patch.frame.rotation.col(2), 1e-15));
    for (int i = 0; i < 20; ++i) {
      const double u = uniform(rng), v = uniform(rng);
      const double u_turned = std::cos(theta) * u + std::sin(theta) * v;
      const double v_turned = -std::sin(theta) * u + std::cos(theta) * v;
      EXPECT_LT((turned.PointInWorld(u_turned, v_turned) - patch.PointInWorld(u, v)).norm(), 1e-12) << order;
      EXPECT_LT((turned.NormalInWorld(u_turned, v_turned) - patch.NormalInWorld(u, v)).norm(), 1e-12) << order;
    }
  }
}

TEST(AlignPatchFramesTest, AFittedModelKeepsItsPointsAndItsUAxesFollowTheDirection) {
  MeshFitOptions options;
  options.clustering.num_patches = 30;
  options.evaluate = false;
  PolyFitModel model;
  FitMesh(options, MakeBumpyTorus(48, 24), &model, nullptr);
  std::vector<Eigen::Vector3d> points;
  for (int k = 0; k < model.num_memberships(); ++k) points.push_back(model.MembershipPoint(k));
  const Eigen::Vector3d up = Eigen::Vector3d::UnitY(), forward = Eigen::Vector3d::UnitZ();
  EXPECT_GT(AlignPatchFrames(up, forward, &model), 0.1);
  for (int k = 0; k < model.num_memberships(); ++k) EXPECT_LT((model.MembershipPoint(k) - points[k]).norm(), 1e-12);
  for (const JetPatch& patch : model.patches) {
    const Eigen::Matrix3d& r = patch.frame.rotation;
    EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
    Eigen::Vector3d target = up - up.dot(r.col(2)) * r.col(2);
    if (target.norm() < std::sin(15.0 * M_PI / 180.0)) target = forward - forward.dot(r.col(2)) * r.col(2);
    EXPECT_GT(r.col(0).dot(target.normalized()), 1.0 - 1e-12);
  }
  // A second alignment finds every frame aligned already.
  EXPECT_LT(AlignPatchFrames(up, forward, &model), 1e-12);
}

}  // namespace
}  // namespace polyfit
