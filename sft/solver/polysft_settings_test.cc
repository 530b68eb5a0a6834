#include "sft/solver/polysft_settings.h"

#include <fstream>

#include <gtest/gtest.h>

#include "polyfit/util/scoped_temp_dir.h"

namespace polyfit {
namespace {

TEST(PolySftSettingsTest, EverySettingRoundTrips) {
  PolySftOptions changed;
  changed.deformation.jet_order = 3;
  changed.deformation.uv_displacement = UvDisplacement::kPerVertex;
  changed.deformation.uv_order = 2;
  changed.deformation.texture_space = true;
  changed.deformation.keep_detail = false;
  changed.silhouette_reach_weight = 2.0;
  changed.recover_lost_frames = true;
  changed.feature_weight = 7.0;
  changed.feature_huber_px = 4.5;
  changed.feature_dead_zone_px = 1.5;
  changed.features_on_finest = true;
  changed.flow_weight = 30.0;
  changed.flow_on_finest = true;
  changed.flow_start = false;
  changed.keypoints_when_lost = !changed.keypoints_when_lost;
  changed.relocalize = !changed.relocalize;
  changed.window_size = 5;
  changed.coarse_levels_newest_only = false;
  changed.check_coarse_levels = true;
  changed.pyramid_levels = 2;
  changed.max_image_width = 640;
  changed.max_iterations_per_level = 9;
  changed.tracked_finest_iterations = 20;
  changed.patience = 3;
  changed.improvement_tolerance = 0.05;
  changed.iterative_min_patches = 12;
  changed.iterative_eta = 0.05;
  changed.photometric_weight = 0.5;
  changed.silhouette_weight = 2.0;
  changed.inextensibility_weight = 20.0;
  changed.inextensibility_robust_strain = 0.05;
  changed.bending_weight = 1e-4;
  changed.new_crease_bending_weight = 3e-4;
  changed.new_crease_angle_deg = 45.0;
  changed.mirror_new_creases = false;
  changed.flip_new_crease_bands = false;
  changed.new_crease_from_frame_before = false;
  changed.new_crease_span_frames = 5;
  changed.temporal_weight = 0.3;
  changed.temporal_order = 2;
  changed.gravity_prior = true;
  changed.occluded_temporal_weight = 3.0;
  changed.occluded_velocity = 0.25;
  changed.atlas.initial_patches = 4;
  changed.silhouette_band = 4.5;
  changed.relax_mask_border = false;
  changed.match_brightness = false;
  changed.predict_motion = false;
  changed.ground_truth_start = GroundTruthStart::kFrameBefore;
  changed.rasterizer.sigma = 2.5;
  changed.rasterizer.gamma = 0.2;
  changed.depth_softness = 2e-3;
  changed.finest_sigma = 0.1;
  changed.rasterizer.depth_gradient = true;
  changed.rasterizer.analytic_derivatives = false;
  changed.rasterizer.compositing = Compositing::kSoftZ;
  changed.finest_compositing = Compositing::kOver;
  changed.rasterizer.mipmap = false;
  changed.finest_mipmap = true;
  changed.rasterizer.mip_level_bias = 0.5;
  changed.robust_loss = RobustLoss::kCauchy;
  changed.robust_scale = 0.3;
  changed.max_frames = 7;
  changed.num_threads = 1;
  changed.features.mirrored = false;
  changed.atlas.max_patches = 10;
  changed.atlas.split_ratio = 1.5;
  changed.atlas.split_significance = 30.0;
  changed.atlas.split_min_step_pixels = 0.5;
  changed.atlas.children = 2;
  changed.atlas.min_vertices = 12;
  changed.atlas.min_children = 2;
  changed.atlas.seam_position_weight = 3.0;
  changed.atlas.coarse_seam_position_weight = 30.0;
  changed.atlas.seen_seam_position_weight = 0.3;
  changed.atlas.seam_normal_weight = 0.01;
  changed.atlas.seam_uv_weight = 1.0;
  changed.atlas.coarse_seam_uv_weight = 2.0;
  changed.atlas.seen_seam_uv_weight = 0.5;
  changed.atlas.seam_uv_robust = 0.05;
  changed.atlas.seen_seam_uv_robust = 0.02;
  changed.atlas.hidden_split_share = 0.3;
  changed.atlas.max_hidden_patches = 8;
  changed.atlas.min_hidden_vertices = 5;
  const nlohmann::json written = PolySftSettingsToJson(changed);
  EXPECT_EQ(written.size(), PolySftSettingKeys().size());
  PolySftOptions read;
  ApplyPolySftSettings(written, "test", &read);
  EXPECT_EQ(PolySftSettingsToJson(read), written);
  EXPECT_NE(PolySftSettingsToJson(PolySftOptions()), written);  // every value above differs from its default
  for (const std::string& key : PolySftSettingKeys()) {
    EXPECT_NE(PolySftSettingsToJson(PolySftOptions())[key], written[key]) << key;
  }
}

TEST(PolySftSettingsTest, ErrorsNameTheKey) {
  PolySftOptions options;
  const auto message = [&](const nlohmann::json& j) {
    try {
      ApplyPolySftSettings(j, "config.json", &options);
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::kInvalidArgument);
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message({{"windowsize", 3}}), "config.json: key 'windowsize': unknown key");
  EXPECT_NE(message({{"window_size", "three"}}).find("key 'window_size'"), std::string::npos);
  EXPECT_NE(message({{"robust_loss", "l1"}}).find("expected one of none, huber, cauchy, got 'l1'"), std::string::npos);
  EXPECT_NE(message(nlohmann::json::array()).find("must be a JSON object"), std::string::npos);
}

TEST(PolySftSettingsTest, AMetricsFileGivesItsSettings) {
  ScopedTempDir dir("polysft_settings");
  PolySftOptions changed;
  changed.window_size = 4;
  const std::string path = (dir.path() / "metrics.json").string();
  std::ofstream(path)
      << nlohmann::json{{"frames", nlohmann::json::array()}, {"settings", PolySftSettingsToJson(changed)}}.dump();
  PolySftOptions read;
  ApplyPolySftSettingsFile(path, &read);
  EXPECT_EQ(read.window_size, 4);
  EXPECT_THROW(ApplyPolySftSettingsFile((dir.path() / "absent.json").string(), &read), Error);
}

}  // namespace
}  // namespace polyfit
