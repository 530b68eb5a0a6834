#include "polyfit/pipeline/fit_mesh.h"

#include <cmath>

#include <gtest/gtest.h>

#include "polyfit/mesh/primitives.h"
#include "polyfit/mesh/subdivision.h"

namespace polyfit {
namespace {

// Largest | |x| - 1 | over the columns.
double MaxSphereError(const Eigen::Matrix3Xd& x) { return (x.colwise().norm().array() - 1.0).abs().maxCoeff(); }

TEST(FitMeshTest, SphereIsReconstructedWithinTolerance) {
  const TriangleMesh sphere = MakeIcosphere(5);  // 20480 faces, vertices on the unit sphere
  MeshFitOptions options;
  options.clustering.num_patches = 100;
  PolyFitModel model;
  TriangleMesh reconstruction;
  const MeshFitSummary summary = FitMesh(options, sphere, &model, &reconstruction);
  EXPECT_EQ(summary.clustering.num_patches, 100);
  EXPECT_EQ(summary.subdivision.levels, 0);
  EXPECT_EQ(reconstruction.faces, sphere.faces);
  // A 4-jet over a patch of radius ~0.2 rad: the first missing term of
  // z = 1 - sqrt(1 - r^2) is r^6 / 16 ~ 4e-6 (measured max 4.6e-6).
  EXPECT_LT(MaxSphereError(reconstruction.vertices), 2e-5);
  EXPECT_LT(summary.height_rmse, 5e-6);
  EXPECT_LT(summary.normal_error_deg, 0.5);
  EXPECT_EQ(summary.jet_fit.num_not_height_field, 0);
  // The reconstruction is as good as the mesh: its Chamfer is the sampling
  // floor, and the sampling-free variant is tiny.
  EXPECT_NEAR(summary.chamfer, summary.chamfer_floor, 0.05 * summary.chamfer_floor);
  EXPECT_LT(summary.surface_chamfer, 1e-6);
}

TEST(FitMeshTest, ParaboloidIsReconstructedWithinTolerance) {
  TriangleMesh paraboloid = MakeGrid(120, 120, 2.0);
  for (int v = 0; v < paraboloid.num_vertices(); ++v) {
    const double x = paraboloid.vertices(0, v), y = paraboloid.vertices(1, v);
    paraboloid.vertices(2, v) = 0.5 * (x * x + y * y);
  }
  MeshFitOptions options;
  options.clustering.num_patches = 64;
  TriangleMesh reconstruction;
  FitMesh(options, paraboloid, nullptr, &reconstruction);
  double max_error = 0.0;
  for (int v = 0; v < reconstruction.num_vertices(); ++v) {
    const Eigen::Vector3d p = reconstruction.vertices.col(v);
    max_error = std::max(max_error, std::abs(p.z() - 0.5 * (p.x() * p.x() + p.y() * p.y())));
  }
  EXPECT_LT(max_error, 1e-5);  // measured 1.4e-6
}

TEST(FitMeshTest, SeamModesTradeGapsForWatertightness) {
  const TriangleMesh sphere = MakeIcosphere(4);
  MeshFitOptions options;
  options.clustering.num_patches = 60;
  options.evaluate = false;
  PolyFitModel model;
  FitMesh(options, sphere, &model, nullptr);

  ReconstructionOptions owner;
  owner.seam_mode = SeamMode::kOwner;
  ReconstructionSummary owner_summary;
  const Eigen::Matrix3Xd by_owner = ReconstructVertices(model, owner, &owner_summary);
  ReconstructionOptions average;
  ReconstructionSummary average_summary;
  const Eigen::Matrix3Xd averaged = ReconstructVertices(model, average, &average_summary);
  ReconstructionOptions smoothed;
  smoothed.boundary_smoothing_iterations = 3;
  const Eigen::Matrix3Xd smooth = ReconstructVertices(model, smoothed);

  EXPECT_GT(owner_summary.num_boundary_vertices, 0);
  EXPECT_GT(owner_summary.max_seam_gap, 0.0);
  EXPECT_EQ(owner_summary.max_seam_gap, average_summary.max_seam_gap);
  // Every mode stays on the sphere to within the fit's accuracy; averaging
  // the patches' points is no worse than trusting the owner.
  EXPECT_LT(MaxSphereError(by_owner), 2e-4);
  EXPECT_LE(MaxSphereError(averaged), MaxSphereError(by_owner) + 1e-12);
  // Laplacian smoothing pulls curved boundaries inwards (measured 4.5e-3
  // after 3 iterations): on smooth surfaces averaging alone is better.
  EXPECT_LT(MaxSphereError(smooth), 1e-2);
  EXPECT_GT(MaxSphereError(smooth), MaxSphereError(averaged));
  // Interior vertices are untouched by the seam modes.
  for (int v = 0; v < model.num_vertices(); ++v) {
    if (!model.is_boundary(v)) {
      EXPECT_EQ(by_owner.col(v), averaged.col(v));
      EXPECT_EQ(averaged.col(v), smooth.col(v));
    }
  }
}

TEST(FitMeshTest, CoarseMeshesAreSubdividedUntilPatchesHavePoints) {
  const TriangleMesh coarse = MakeIcosphere(2);  // 162 vertices, 320 faces
  MeshFitOptions options;
  options.clustering.num_patches = 20;
  options.min_vertices_per_patch = 40;  // 800 vertices: two levels (642, then 2562)
  options.evaluate = false;
  const MeshFitSummary summary = FitMesh(options, coarse, nullptr, nullptr);
  EXPECT_EQ(summary.subdivision.levels, 2);
  EXPECT_EQ(summary.fitted_faces, 320 * 16);
  EXPECT_EQ(summary.fitted_vertices, 2562);
  EXPECT_EQ(summary.jet_fit.num_reduced_order, 0);
}

TEST(FitMeshTest, LoopSubdivisionNeedsAManifoldAndFallsBack) {
  SubdivisionOptions loop;
  loop.scheme = SubdivisionScheme::kLoop;
  SubdivisionSummary summary;
  const TriangleMesh sphere = MakeIcosphere(1);
  const TriangleMesh smooth = SubdivideMesh(sphere, loop, &summary);
  EXPECT_EQ(summary.scheme_used, SubdivisionScheme::kLoop);
  EXPECT_EQ(smooth.num_faces(), 4 * sphere.num_faces());
  // Loop moves the vertices inside the polyhedron's circumsphere.
  EXPECT_LT(smooth.vertices.colwise().norm().maxCoeff(), 1.0);

  // Three triangles on one edge: not a manifold.
  TriangleMesh fan;
  fan.vertices.resize(3, 5);
  fan.vertices << 0, 1, 0, 0, 0,  //
      0, 0, 1, -1, 0,             //
      0, 0, 0, 0, 1;
  fan.faces.resize(3, 3);
  fan.faces << 0, 0, 0,  //
      1, 3, 4,           //
      2, 1, 1;
  const TriangleMesh split = SubdivideMesh(fan, loop, &summary);
  EXPECT_EQ(summary.scheme_used, SubdivisionScheme::kMidpoint);
  EXPECT_FALSE(summary.fallback_reason.empty());
  EXPECT_EQ(split.num_faces(), 12);
}

TEST(FitMeshTest, MidpointSubdivisionKeepsTheSurfaceAndTextureCoordinates) {
  const TriangleMesh grid = MakeGrid(3, 2);
  const TriangleMesh fine = SubdivideMidpoint(grid);
  EXPECT_EQ(fine.num_faces(), 4 * grid.num_faces());
  EXPECT_NEAR(SurfaceArea(fine), SurfaceArea(grid), 1e-12);
  ASSERT_TRUE(fine.has_texcoords());
  for (int f = 0; f < fine.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(fine.corner_texcoords(0, 3 * f + c), fine.vertices(0, fine.faces(c, f)) + 0.5, 1e-12);
    }
  }
}

// A cap of a sphere of radius 2 sampled by a coarse grid (vertices on the
// sphere, 0.25 apart): jets fitted to the flat faces sit inside the sphere
// by about the chords' sag; fitted to the faces' Phong tessellation they
// follow the sphere the vertices sample.
TEST(FitMeshTest, CurvedFacesFitTheSurfaceTheVerticesSample) {
  TriangleMesh cap = MakeGrid(4, 4, 1.0);
  for (int v = 0; v < cap.num_vertices(); ++v) {
    cap.vertices(2, v) = std::sqrt(4.0 - cap.vertices.col(v).head<2>().squaredNorm());
  }
  auto max_error = [&](bool curved, double half_width) {
    PolyFitModel model;
    model.face_patch.assign(cap.num_faces(), 0);
    BuildPatchMemberships(cap, model.face_patch, &model);
    JetFitOptions options;
    options.order = 4;
    FitPatchJets(options, cap, &model, 4, curved);
    const JetPatch& patch = model.patches[0];
    double error = 0.0;
    for (double x = -half_width; x <= half_width; x += 0.05) {
      for (double y = -half_width; y <= half_width; y += 0.05) {
        const Eigen::Vector3d on_sphere(x, y, std::sqrt(4.0 - x * x - y * y));
        const Eigen::Vector3d point_in_patch = patch.frame.PointToPatch(on_sphere);
        error = std::max(error, std::abs(point_in_patch.z() - patch.Height(point_in_patch.x(), point_in_patch.y())));
      }
    }
    return error;
  };
  // Measured: 7.3e-3 flat, 1.1e-4 curved over the inner half; 8.0e-3 and
  // 1.7e-3 out to the boundary, where the normals are one-sided fits.
  const double flat_inner = max_error(false, 0.25), curved_inner = max_error(true, 0.25);
  EXPECT_GT(flat_inner, 5e-3);
  EXPECT_LT(curved_inner, 0.03 * flat_inner);
  EXPECT_LT(max_error(true, 0.45), 0.3 * max_error(false, 0.45));
}

TEST(FitMeshTest, InvalidInputThrows) {
  MeshFitOptions options;
  TriangleMesh bad = MakeIcosphere(1);
  bad.vertices(0, 3) = std::nan("");
  EXPECT_THROW(FitMesh(options, bad, nullptr, nullptr), std::invalid_argument);
  TriangleMesh flat_line = MakeIcosphere(1);
  flat_line.vertices.row(1).setZero();
  flat_line.vertices.row(2).setZero();  // every face collapses onto the x axis
  EXPECT_THROW(FitMesh(options, flat_line, nullptr, nullptr), std::invalid_argument);
  options.jet_fit.order = 12;
  EXPECT_THROW(FitMesh(options, MakeIcosphere(1), nullptr, nullptr), std::invalid_argument);
}

}  // namespace
}  // namespace polyfit
