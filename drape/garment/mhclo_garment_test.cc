#include "drape/garment/mhclo_garment.h"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "drape/body/makehuman_body.h"
#include "drape/collision/signed_distance.h"
#include "polyfit/mesh/ordered_io.h"
#include "polyfit/pipeline/fit_mesh.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;
const fs::path kData = fs::path(POLYFIT_SHARED_DATA_DIR) / "drape";

TEST(MhcloGarmentTest, GarmentsFitTheBaseBody) {
  if (!fs::exists(kData / "body/makehuman/base.obj")) GTEST_SKIP() << "shared data absent: " << kData;
  const SkinnedBody body = LoadMakeHumanBody((kData / "body").string());
  const BodySignedDistance distance(body.mesh);
  int garments = 0;
  for (const auto& entry : fs::directory_iterator(kData / "garments/makehuman_cc0")) {
    if (entry.path().extension() != ".mhclo") continue;
    const ClothesBinding binding = ReadMhclo(entry.path().string());
    const TriangleMesh garment = LoadGarment(entry.path().string(), body.base_vertices, 1.0);
    EXPECT_TRUE(garment.has_texcoords());
    // The helpers were made on the base mesh itself (their recorded scale
    // distances are the base's): the binding gives back their OBJ exactly.
    // The suits were made on female or male shapes and are refitted.
    const double base_x = std::abs(body.base_vertices(0, binding.scale_vertices[0][0]) -
                                   body.base_vertices(0, binding.scale_vertices[0][1]));
    if (std::abs(0.1 * binding.scale_distances[0] - base_x) < 1e-4) {
      const TriangleMesh obj = ReadObjTemplate((entry.path().parent_path() / entry.path().stem()).string() + ".obj");
      EXPECT_LT((garment.vertices - 0.1 * obj.vertices).colwise().norm().maxCoeff(), 1e-3) << entry.path();
    }
    // Every garment sits on the body: close to its surface (the skirt hangs
    // off the legs: 5 cm on average), hardly inside.
    const Eigen::VectorXd d = distance.SignedDistances(garment.vertices, 2);
    EXPECT_LT(d.cwiseAbs().mean(), 0.08) << entry.path();
    EXPECT_LT((d.array() < -0.005).cast<double>().mean(), 0.05) << entry.path();
    ++garments;
  }
  EXPECT_EQ(garments, 6);
}

TEST(MhcloGarmentTest, GarmentSplitsIntoPatchesWithBoundaryPairs) {
  if (!fs::exists(kData / "body/makehuman/base.obj")) GTEST_SKIP() << "shared data absent: " << kData;
  const SkinnedBody body = LoadMakeHumanBody((kData / "body").string());
  const TriangleMesh skirt =
      LoadGarment((kData / "garments/makehuman_cc0/skirthelper.mhclo").string(), body.base_vertices, 1.0);
  MeshFitOptions options;  // the paper's automatic count for metres
  PolyFitModel model;
  const MeshFitSummary summary = FitMesh(options, skirt, &model, nullptr);
  EXPECT_GE(summary.clustering.num_patches, 100);
  EXPECT_FALSE(model.BoundaryPoints().empty());
  EXPECT_LT(summary.surface_chamfer, summary.chamfer_floor);
}

TEST(MhcloGarmentTest, MalformedBindingIsNamed) {
  const fs::path path = fs::temp_directory_path() / "polyfit_bad.mhclo";
  {
    std::ofstream out(path);
    out << "name bad\nobj_file bad.obj\nx_scale 1 2 1.0\ny_scale 1 2 1.0\nz_scale 1 2 1.0\nverts 0\n1 2 3 0.5 0.5\n";
  }
  try {
    ReadMhclo(path.string());
    FAIL();
  } catch (const GarmentError& e) {
    EXPECT_NE(std::string(e.what()).find("line 7: a vertex binding needs 1 or 9 numbers, not 5"), std::string::npos)
        << e.what();
  }
  fs::remove(path);
}

}  // namespace
}  // namespace polyfit
