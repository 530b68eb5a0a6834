#include "polyfit/pipeline/batch_fit.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "polyfit/mesh/mesh_io.h"
#include "polyfit/mesh/primitives.h"
#include "polyfit/model/polyfit_model.h"
#include "polyfit/util/scoped_temp_dir.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;

class BatchFitTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(dir_ / "in");
    WriteObj((dir_ / "in" / "sphere.obj").string(), MakeIcosphere(4));
    WritePly((dir_ / "in" / "torus.ply").string(), MakeBumpyTorus(80, 30));
    std::ofstream(dir_ / "in" / "broken.off") << "OFF\n3 1 0\n0 0 0\n1 0 0\n";
    options_.output_dir = (dir_ / "out").string();
    options_.fit.clustering.num_patches = 40;
    options_.fit.evaluation_samples = 2000;
  }
  std::string Out(const std::string& name) const { return (dir_ / "out" / name).string(); }
  std::vector<std::string> ReportLines() const {
    std::ifstream in(Out("report.csv"));
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
  }
  ScopedTempDir temp_{"polyfit_batch"};
  const fs::path& dir_ = temp_.path();
  BatchFitOptions options_;
};

TEST_F(BatchFitTest, FitsEveryInputReportsFailuresAndResumes) {
  int calls = 0;
  const BatchFitSummary first =
      FitMeshFiles(options_, {(dir_ / "in").string()}, [&calls](int done, int total, const BatchFitItemSummary&) {
        ++calls;
        EXPECT_EQ(total, 3);
        EXPECT_EQ(done, calls);
      });
  EXPECT_EQ(calls, 3);
  EXPECT_EQ(first.num_fitted, 2);
  EXPECT_EQ(first.num_failed, 1);
  for (const BatchFitItemSummary& item : first.items) {
    if (item.name == "broken") {
      EXPECT_EQ(item.status, BatchItemStatus::kFailed);
      EXPECT_NE(item.error.find("broken.off"), std::string::npos) << item.error;
      EXPECT_FALSE(fs::exists(Out("broken.pfm")));
      EXPECT_FALSE(fs::exists(Out("broken.recon.ply")));
    } else {
      EXPECT_EQ(item.status, BatchItemStatus::kFitted);
      EXPECT_EQ(item.summary.clustering.num_patches, 40);
      EXPECT_GT(item.summary.chamfer, 0.0);
      // The written model and reconstruction read back.
      const PolyFitModel model = LoadPolyFitModel(Out(item.name + ".pfm"));
      EXPECT_EQ(model.num_patches(), 40);
      const TriangleMesh recon = ReadTriangleMesh(Out(item.name + ".recon.ply"));
      EXPECT_EQ(recon.num_faces(), item.summary.fitted_faces);
    }
  }
  std::vector<std::string> lines = ReportLines();
  ASSERT_EQ(lines.size(), 4u);  // header + 3
  EXPECT_EQ(lines[0].rfind("name,input,status,", 0), 0u);
  EXPECT_TRUE(fs::exists(Out("report.json")));

  // Again: the fitted inputs are skipped with their earlier numbers.
  const BatchFitSummary second = FitMeshFiles(options_, {(dir_ / "in").string()});
  EXPECT_EQ(second.num_skipped, 2);
  EXPECT_EQ(second.num_failed, 1);
  for (size_t i = 0; i < second.items.size(); ++i) {
    if (second.items[i].status != BatchItemStatus::kSkipped) continue;
    EXPECT_DOUBLE_EQ(second.items[i].summary.chamfer, first.items[i].summary.chamfer);
    EXPECT_EQ(second.items[i].summary.clustering.num_patches, 40);
  }
  EXPECT_EQ(ReportLines().size(), 4u);

  options_.force = true;
  const BatchFitSummary third = FitMeshFiles(options_, {(dir_ / "in" / "*.obj").string()});
  EXPECT_EQ(third.num_fitted, 1);
  EXPECT_EQ(third.items[0].name, "sphere");
}

TEST_F(BatchFitTest, InputsThatMatchNothingAreNamed) {
  try {
    FitMeshFiles(options_, {(dir_ / "in" / "*.stl").string()});
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("*.stl"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ExpandMeshInputs({(dir_ / "nowhere.obj").string()}), std::invalid_argument);
}

TEST_F(BatchFitTest, SharedStemsKeepTheirExtension) {
  WriteObj((dir_ / "in" / "torus.obj").string(), MakeBumpyTorus(40, 16));
  const BatchFitSummary summary =
      FitMeshFiles(options_, {(dir_ / "in" / "torus.obj").string(), (dir_ / "in" / "torus.ply").string()});
  ASSERT_EQ(summary.items.size(), 2u);
  EXPECT_EQ(summary.items[0].name, "torus_obj");
  EXPECT_EQ(summary.items[1].name, "torus_ply");
  EXPECT_TRUE(fs::exists(Out("torus_obj.pfm")));
}

#ifdef POLYFIT_SHARED_DATA_DIR
TEST_F(BatchFitTest, MakeHumanGarmentsInDecimetres) {
  const fs::path garment = fs::path(POLYFIT_SHARED_DATA_DIR) / "drape/garments/makehuman_cc0/skirthelper.obj";
  if (!fs::exists(garment)) GTEST_SKIP() << "shared data absent: " << garment;
  // The paper's rule in metres (0.008 m^2 per patch) is 0.8 dm^2 here.
  options_.fit.clustering.num_patches = 0;
  options_.fit.clustering.auto_area_per_patch = 0.8;
  const BatchFitSummary summary = FitMeshFiles(options_, {garment.string()});
  ASSERT_EQ(summary.num_fitted, 1) << summary.items[0].error;
  const MeshFitSummary& s = summary.items[0].summary;
  EXPECT_GE(s.clustering.num_patches, 100);
  EXPECT_LE(s.clustering.num_patches, 400);
  // A reconstruction close to the garment: Chamfer near its sampling floor.
  EXPECT_LT(s.surface_chamfer, 0.1 * s.chamfer_floor);
}
#endif

}  // namespace
}  // namespace polyfit
