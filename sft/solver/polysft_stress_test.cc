// PolySfT at the extremes real footage reaches (CTest label "stress",
// docs/reliability.md): a sheet turning edge-on to the camera, a sheet that
// leaves the image entirely and comes back, a black frame (a dropped
// frame: no picture, an empty mask), and simulated cloth that falls faster
// than the pyramid reaches or folds over itself. Each must give finite vertices in
// every frame and say what happened in its warnings, with and without
// keypoint correspondences as a term (an option). How well it tracks
// again is measured, and required where relocalisation on the template's
// keypoints (on by default) finds the sheet again: after it leaves and
// comes back, and after a black frame.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "polyfit/util/scoped_temp_dir.h"
#include "sft/solver/polysft.h"
#include "sft/synthetic/sheet_scene.h"

namespace polyfit {
namespace {

SheetSceneOptions Rigid(int frames) {
  SheetSceneOptions o = SheetSceneOptions::Small(160, 12, frames);
  o.motion = SheetMotion::kRigid;
  return o;
}

PolySftSummary Solve(const std::string& dir, double feature_weight = 0.0) {
  PolySftOptions options;
  options.feature_weight = feature_weight;
  options.num_threads = 2;
  options.rasterizer.num_threads = 2;
  return SolvePolySft(options, LoadScene(dir));
}

void Report(const char* name, const PolySftSummary& summary) {
  std::printf("%s: %s\n", name, summary.BriefReport().c_str());
  for (const SftFrameSummary& f : summary.frames) {
    std::printf("  frame %d: e3D %.4f, RMSE %.2f mm, cost %.3e, %d flow and %d keypoint matches%s\n", f.index, f.e3d,
                f.rmse_mm, f.cost, f.flow_matches, f.keypoint_matches, f.relocalized ? ", relocalised" : "");
  }
  for (const std::string& w : summary.warnings) std::printf("  warning: %s\n", w.c_str());
}

void ExpectFiniteEverywhere(const PolySftSummary& summary, int frames) {
  ASSERT_EQ(static_cast<int>(summary.frames.size()), frames);
  EXPECT_NE(summary.termination_type, TerminationType::kFailure) << summary.message;
  for (const SftFrameSummary& f : summary.frames) {
    EXPECT_TRUE(f.vertices.allFinite()) << "frame " << f.index;
    EXPECT_TRUE(std::isfinite(f.cost)) << "frame " << f.index;
  }
}

TEST(PolySftStressTest, SheetTurningEdgeOn) {
  ScopedTempDir dir("polyfit_sft_edge_on");
  SheetSceneOptions o = Rigid(13);
  o.yaw_amplitude = M_PI / 2;  // edge-on at frame 6
  GenerateSheetScene(o, dir.path().string());
  const PolySftSummary summary = Solve(dir.path().string());
  Report("edge-on", summary);
  ExpectFiniteEverywhere(summary, 13);
  EXPECT_FALSE(summary.warnings.empty());
  // Flat-on again near the end (frame 11 measured 0.78 mm).
  double best_late = 1e9;
  for (int f = 10; f < 13; ++f) best_late = std::min(best_late, summary.frames[f].rmse_mm);
  EXPECT_LT(best_late, 5.0);
}

TEST(PolySftStressTest, SheetLeavingTheImageAndComingBack) {
  ScopedTempDir dir("polyfit_sft_leaves");
  SheetSceneOptions o = Rigid(17);
  o.sideways_amplitude = 0.3;  // out of view around frames 4 and 12
  o.yaw_amplitude = 0.0;
  GenerateSheetScene(o, dir.path().string());
  const PolySftSummary summary = Solve(dir.path().string());
  Report("leaving the image", summary);
  ExpectFiniteEverywhere(summary, 17);
  EXPECT_FALSE(summary.warnings.empty());
  // Lost as it leaves (12 cm per frame); placed again on its keypoints
  // (relocalize) in the frame it is lost or the one after. Measured: 0.9-17
  // mm, 4.8 on average (without relocalisation 130-300 mm off except frame
  // 8, found where it was lost: 159 mm on average).
  double sum = 0.0;
  for (const SftFrameSummary& f : summary.frames) sum += f.rmse_mm;
  EXPECT_LT(sum / summary.frames.size(), 10.0);
  EXPECT_LT(summary.frames[8].rmse_mm, 10.0);
}

// The same, bending, with the patch atlas forced to split (every patch a
// candidate, no score test, no step too small) while the sheet is still
// tracked (lost frames are never split): patches then leave the image with
// their render groups empty. Finite and defined (lost from frame 4 on, 170
// mm on average, measured).
TEST(PolySftStressTest, AnAtlasLeavingTheImageAndComingBack) {
  ScopedTempDir dir("polyfit_sft_atlas_leaves");
  SheetSceneOptions o = Rigid(61);
  o.motion = SheetMotion::kMixed;
  o.sideways_amplitude = 0.3;
  o.yaw_amplitude = 0.0;
  GenerateSheetScene(o, dir.path().string());
  PolySftOptions options;
  options.num_threads = 2;
  options.rasterizer.num_threads = 2;
  options.atlas.max_patches = 7;
  options.atlas.split_ratio = 1.0;
  options.atlas.split_significance = 1e-9;
  options.atlas.split_min_step_pixels = 0.0;
  options.atlas.min_vertices = 10;
  // Frames that reach the iteration cap are not split: the first ones
  // settle with more iterations, so that the atlas splits before the
  // sheet leaves.
  options.max_iterations_per_level = 30;
  const PolySftSummary summary = SolvePolySft(options, LoadScene(dir.path().string()));
  Report("atlas leaving the image", summary);
  ExpectFiniteEverywhere(summary, 61);
  EXPECT_FALSE(summary.splits.empty());
  EXPECT_GT(summary.frames.back().patches, 1);
}

TEST(PolySftStressTest, ABlackFrame) {
  ScopedTempDir dir("polyfit_sft_black");
  const SheetSceneOptions o = Rigid(7);
  GenerateSheetScene(o, dir.path().string());
  cv::imwrite((dir.path() / "frames" / "000003.png").string(),
              cv::Mat(o.height, o.width, CV_8UC3, cv::Scalar(0, 0, 0)));
  cv::imwrite((dir.path() / "masks" / "000003.png").string(), cv::Mat(o.height, o.width, CV_8U, cv::Scalar(0)));
  const PolySftSummary summary = Solve(dir.path().string());
  Report("black frame", summary);
  ExpectFiniteEverywhere(summary, 7);
  EXPECT_FALSE(summary.warnings.empty());
  // The frame after it is placed on its keypoints (relocalize; 0.55 mm
  // measured, where without relocalisation the frames after it drifted
  // 43-49 mm off); the last is found too.
  EXPECT_LT(summary.frames[4].rmse_mm, 5.0);
  EXPECT_LT(summary.frames.back().rmse_mm, 5.0);
}

// Simulated cloth (issue "PolySfT on cloth that moves under gravity and
// wind"): falling onto a sphere faster than the pyramid reaches (about 4
// cm per frame at frame 4), and a corner lifted past the image's edge and
// folded over the rest (layers hide each other). A defined outcome:
// finite vertices, no failure, and a warning that tracking was lost.
TEST(PolySftStressTest, ClothFallingFasterThanThePyramidReachesAndFoldingOverItself) {
  for (const SheetMotion motion : {SheetMotion::kFall, SheetMotion::kTable}) {
    ScopedTempDir dir("polyfit_sft_cloth");
    SheetSceneOptions o = SheetSceneOptions::Small(160, 12, 40);
    o.motion = motion;
    GenerateSheetScene(o, dir.path().string());
    const PolySftSummary summary = Solve(dir.path().string());
    Report(motion == SheetMotion::kFall ? "fall" : "table", summary);
    ExpectFiniteEverywhere(summary, 40);
    EXPECT_FALSE(summary.warnings.empty());
  }
}

// The same extremes with keypoint correspondences on (feature_weight):
// frames with no mask or no matches, a sheet seen edge-on, leaving the
// image, and cloth that folds over itself all give a defined outcome.
TEST(PolySftStressTest, KeypointsAtTheExtremes) {
  ScopedTempDir dir("polyfit_sft_keypoint_extremes");
  SheetSceneOptions leaving = Rigid(17);
  leaving.sideways_amplitude = 0.3;
  leaving.yaw_amplitude = 0.0;
  SheetSceneOptions edge_on = Rigid(13);
  edge_on.yaw_amplitude = M_PI / 2;
  SheetSceneOptions table = SheetSceneOptions::Small(160, 12, 40);
  table.motion = SheetMotion::kTable;
  const std::pair<const char*, SheetSceneOptions> scenes[] = {
      {"leaving the image, keypoints", leaving}, {"edge-on, keypoints", edge_on}, {"table, keypoints", table}};
  for (const auto& [name, o] : scenes) {
    const std::string path = (dir.path() / name).string();
    GenerateSheetScene(o, path);
    if (std::string(name).rfind("leaving", 0) == 0) {  // and a black frame with an empty mask
      cv::imwrite((dir.path() / name / "frames" / "000003.png").string(),
                  cv::Mat(o.height, o.width, CV_8UC3, cv::Scalar(0, 0, 0)));
      cv::imwrite((dir.path() / name / "masks" / "000003.png").string(),
                  cv::Mat(o.height, o.width, CV_8U, cv::Scalar(0)));
    }
    const PolySftSummary summary = Solve(path, 100.0);
    Report(name, summary);
    ExpectFiniteEverywhere(summary, o.frame_count);
    EXPECT_EQ(summary.terms[2].first, "features");
    if (o.motion == SheetMotion::kTable) {
      // The corner folded over shows its back, which the mirrored
      // keypoints find: e3D 0.0153 and no frame warned lost (without
      // them 0.0158, warned lost from frame 28 on).
      EXPECT_LT(summary.mean_e3d, 0.02);
    } else {
      EXPECT_FALSE(summary.warnings.empty());  // each has a frame with an empty mask
    }
  }
}

}  // namespace
}  // namespace polyfit
