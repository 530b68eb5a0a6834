#include "sft/scene/scene.h"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "polyfit/mesh/mesh_io.h"
#include "polyfit/mesh/primitives.h"
#include "polyfit/util/scoped_temp_dir.h"
#include "sft/scene/sft_metrics.h"
#include "sft/synthetic/sheet_scene.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;

class SceneTest : public ::testing::Test {
 protected:
  void SetUp() override { GenerateSheetScene(SheetSceneOptions::Small(64, 6, 3), dir_.path().string()); }
  std::string Error() const {
    try {
      LoadScene(dir_.path().string());
    } catch (const SceneError& e) {
      return e.what();
    }
    return "(no error)";
  }
  void EditJson(const std::function<void(nlohmann::json&)>& edit) {
    const fs::path path = dir_.path() / "scene.json";
    nlohmann::json j = nlohmann::json::parse(std::ifstream(path));
    edit(j);
    std::ofstream(path) << j.dump();
  }
  ScopedTempDir dir_{"polyfit_scene"};
};

TEST_F(SceneTest, LoadsTheGeneratedScene) {
  const SftScene scene = LoadScene(dir_.path().string());
  EXPECT_EQ(scene.frame_count, 3);
  EXPECT_EQ(scene.template_mesh.num_vertices(), 7 * 5);
  EXPECT_EQ(scene.template_mesh.num_faces(), 6 * 4 * 2);
  EXPECT_TRUE(scene.template_mesh.has_texcoords());
  EXPECT_TRUE(scene.has_masks());
  EXPECT_EQ(scene.ground_truth_kind, GroundTruthKind::kVertices);
  const SftFrame frame = LoadFrame(scene, 2);
  EXPECT_EQ(frame.image.type(), CV_32FC3);
  EXPECT_EQ(frame.mask.type(), CV_32F);
  ASSERT_EQ(frame.ground_truth.cols(), scene.template_mesh.num_vertices());
  // Frame 0's ground truth is the template, in the OBJ's vertex order.
  EXPECT_LT((LoadFrame(scene, 0).ground_truth - scene.template_mesh.vertices).cwiseAbs().maxCoeff(), 1e-6);
}

TEST_F(SceneTest, MissingKeyIsNamed) {
  EditJson([](nlohmann::json& j) { j["camera"].erase("fx"); });
  EXPECT_NE(Error().find("'fx'"), std::string::npos) << Error();
}

TEST_F(SceneTest, FilePatternsAreFormattedHereNotByPrintf) {
  // Found by tests/fuzz/scene_fuzzer: "%s" went to snprintf.
  for (const char* pattern : {"frames/%s.png", "frames/%06d_%d.png", "frames/all.png", "frames/%99d.png"}) {
    EditJson([&](nlohmann::json& j) { j["frames"] = pattern; });
    EXPECT_NE(Error().find("'frames' must be a pattern with one integer conversion"), std::string::npos) << Error();
  }
  // Widths, zero padding and %% as printf would give them.
  EditJson([](nlohmann::json& j) {
    j["frames"] = "frames/%06d.png";
    j["masks"] = "masks/%6d%%.png";
  });
  EXPECT_NE(Error().find("masks/     0%.png: missing"), std::string::npos) << Error();
}

TEST_F(SceneTest, IntegersOutOfRangeAreNamed) {
  EditJson([](nlohmann::json& j) { j["first_frame"] = 1e300; });
  EXPECT_NE(Error().find("'first_frame' must be a whole number"), std::string::npos) << Error();
  EditJson([](nlohmann::json& j) {
    j["first_frame"] = 0;
    j["frame_count"] = 2.5;
  });
  EXPECT_NE(Error().find("'frame_count' must be a whole number"), std::string::npos) << Error();
  EditJson([](nlohmann::json& j) {
    j["frame_count"] = 3;
    j["first_frame"] = 2147483000;
  });
  EXPECT_NE(Error().find("'first_frame' must be in [0, 1e8]"), std::string::npos) << Error();
}

// Our optional physics keys: read when given, absent otherwise, and a
// malformed one named.
TEST_F(SceneTest, ReadsTheOptionalFrameRateAndGravity) {
  SftScene scene = LoadScene(dir_.path().string());
  EXPECT_EQ(scene.frame_rate, 0.0);
  EXPECT_FALSE(scene.has_gravity);
  EditJson([](nlohmann::json& j) {
    j["frame_rate"] = 24.0;
    j["gravity"] = {0.0, 6.3, 7.5};
  });
  scene = LoadScene(dir_.path().string());
  EXPECT_EQ(scene.frame_rate, 24.0);
  ASSERT_TRUE(scene.has_gravity);
  EXPECT_EQ(scene.gravity, Eigen::Vector3d(0.0, 6.3, 7.5));
  EditJson([](nlohmann::json& j) { j["frame_rate"] = -1; });
  EXPECT_NE(Error().find("'frame_rate' must be a positive number"), std::string::npos) << Error();
  EditJson([](nlohmann::json& j) {
    j["frame_rate"] = 30;
    j["gravity"] = {0.0, 9.81};
  });
  EXPECT_NE(Error().find("'gravity' must be three finite numbers"), std::string::npos) << Error();
  EditJson([](nlohmann::json& j) { j["gravity"] = "down"; });
  EXPECT_NE(Error().find("'gravity' must be three finite numbers"), std::string::npos) << Error();
}

TEST_F(SceneTest, MissingFrameIsNamed) {
  fs::remove(dir_.path() / "frames" / "000001.png");
  EXPECT_NE(Error().find("000001.png: missing"), std::string::npos) << Error();
}

TEST_F(SceneTest, WrongSizedFrameIsNamed) {
  cv::imwrite((dir_.path() / "frames" / "000002.png").string(), cv::Mat(10, 10, CV_8UC3, cv::Scalar(0)));
  EXPECT_NE(Error().find("000002.png: 10x10, but the camera is 64x48"), std::string::npos) << Error();
}

TEST_F(SceneTest, GroundTruthWithTheWrongVertexCountIsNamed) {
  TriangleMesh small = MakeIcosphere(0);
  WritePly((dir_.path() / "gt" / "000000.ply").string(), small);
  EXPECT_NE(Error().find("000000.ply: 12 vertices, the template has 35"), std::string::npos) << Error();
}

TEST_F(SceneTest, MissingTemplateAndBadJsonAreNamed) {
  fs::remove(dir_.path() / "template.obj");
  EXPECT_NE(Error().find("template.obj"), std::string::npos) << Error();
  std::ofstream(dir_.path() / "scene.json") << "{ not json";
  EXPECT_NE(Error().find("scene.json: not valid JSON"), std::string::npos) << Error();
}

TEST(SftMetricsTest, E3DIgnoresSimilarityAndRmseDoesNot) {
  const TriangleMesh sphere = MakeIcosphere(2, 0.1);
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Matrix3Xd moved = ((1.7 * rotation * sphere.vertices).colwise() + Eigen::Vector3d(0.1, 0, 0.5));
  EXPECT_LT(ComputeE3D(sphere.vertices, moved), 1e-12);
  Eigen::Matrix3Xd shifted = sphere.vertices;
  shifted.row(0).array() += 0.002;  // 2 mm everywhere
  EXPECT_NEAR(ComputeRmseMm(shifted, sphere.vertices), 2.0, 1e-9);
  EXPECT_NEAR(ComputeNormalErrorDeg(sphere.faces, shifted, sphere.vertices), 0.0, 1e-5);
  // A sphere flattened along z: its normals tilt (by up to ~70 degrees).
  Eigen::Matrix3Xd flattened = sphere.vertices;
  flattened.row(2) *= 0.2;
  const double error = ComputeNormalErrorDeg(sphere.faces, flattened, sphere.vertices);
  EXPECT_GT(error, 5.0);
  EXPECT_LT(error, 60.0);
}

}  // namespace
}  // namespace polyfit
