// polysft: shape from template on a scene directory, and the scene
// generator.
//
//   polysft --scene DIR --out DIR [--config FILE] [--overlays]
//   polysft generate --out DIR [--motion bend|wave|rigid|mixed] [--frames N] ...
//   polysft demo [--dir DIR]      generate the default scene, then solve it
//
// Defaults live in PolySftOptions and SheetSceneOptions; this file maps
// flags onto them and makes one library call.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sft/scene/scene.h"
#include "sft/solver/polysft.h"
#include "sft/synthetic/sheet_scene.h"

namespace {

// Config keys, as in metrics.json's "settings" and the option names.
void ApplyConfig(const std::string& path, polyfit::PolySftOptions* o) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot be opened");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": not valid JSON: " + e.what());
  }
  for (const auto& [key, value] : j.items()) {
    try {
      if (key == "jet_order") o->deformation.jet_order = value.get<int>();
      else if (key == "uv_displacement") {
        const std::string mode = value.get<std::string>();
        if (mode != "compact" && mode != "per_vertex") throw std::runtime_error("compact or per_vertex");
        o->deformation.uv_displacement =
            mode == "compact" ? polyfit::UvDisplacement::kCompactField : polyfit::UvDisplacement::kPerVertex;
      } else if (key == "uv_order") o->deformation.uv_order = value.get<int>();
      else if (key == "texture_space") o->deformation.texture_space = value.get<bool>();
      else if (key == "window_size") o->window_size = value.get<int>();
      else if (key == "pyramid_levels") o->pyramid_levels = value.get<int>();
      else if (key == "max_image_width") o->max_image_width = value.get<int>();
      else if (key == "max_iterations_per_level") o->max_iterations_per_level = value.get<int>();
      else if (key == "patience") o->patience = value.get<int>();
      else if (key == "improvement_tolerance") o->improvement_tolerance = value.get<double>();
      else if (key == "photometric_weight") o->photometric_weight = value.get<double>();
      else if (key == "silhouette_weight") o->silhouette_weight = value.get<double>();
      else if (key == "inextensibility_weight") o->inextensibility_weight = value.get<double>();
      else if (key == "temporal_weight") o->temporal_weight = value.get<double>();
      else if (key == "sigma") o->rasterizer.sigma = value.get<double>();
      else if (key == "gamma") o->rasterizer.gamma = value.get<double>();
      else if (key == "robust_loss") {
        const std::string loss = value.get<std::string>();
        if (loss == "none") o->robust_loss = polyfit::RobustLoss::kNone;
        else if (loss == "huber") o->robust_loss = polyfit::RobustLoss::kHuber;
        else if (loss == "cauchy") o->robust_loss = polyfit::RobustLoss::kCauchy;
        else throw std::runtime_error("none, huber or cauchy");
      } else if (key == "robust_scale") o->robust_scale = value.get<double>();
      else if (key == "max_frames") o->max_frames = value.get<int>();
      else if (key == "num_threads") o->num_threads = value.get<int>();
      else throw std::runtime_error("unknown key");
    } catch (const std::exception& e) {
      throw std::runtime_error(path + ": key '" + key + "': " + e.what());
    }
  }
}

// The reconstruction's edges drawn over each frame.
void WriteOverlays(const std::string& out_dir, const polyfit::SftScene& scene,
                   const polyfit::PolySftSummary& summary) {
  namespace fs = std::filesystem;
  fs::create_directories(fs::path(out_dir) / "overlays");
  for (size_t t = 0; t < summary.frames.size(); ++t) {
    const polyfit::SftFrameSummary& f = summary.frames[t];
    cv::Mat image = cv::imread(scene.frame_paths[f.index - scene.first_frame], cv::IMREAD_COLOR);
    if (image.empty()) continue;
    auto project = [&](int v) {
      const Eigen::Vector2d p = scene.camera.Project(f.vertices.col(v));
      return cv::Point2d(p.x(), p.y());
    };
    for (int k = 0; k < scene.template_mesh.num_faces(); ++k) {
      for (int c = 0; c < 3; ++c) {
        cv::line(image, project(scene.template_mesh.faces(c, k)), project(scene.template_mesh.faces((c + 1) % 3, k)),
                 cv::Scalar(40, 255, 40), 1, cv::LINE_AA);
      }
    }
    char name[32];
    std::snprintf(name, sizeof(name), "%06d.png", f.index);
    cv::imwrite((fs::path(out_dir) / "overlays" / name).string(), image);
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"PolySfT: shape from template with patch-wise polynomial jets"};
  std::string scene_dir, out_dir, config;
  bool overlays = false;
  int threads = 0, max_frames = 0;
  app.add_option("--scene", scene_dir, "Scene directory (../shared/docs/sft-scene-format.md)");
  app.add_option("--out", out_dir, "Output directory");
  app.add_option("--config", config, "JSON file of solver settings (keys as in metrics.json 'settings')");
  app.add_flag("--overlays", overlays, "Write the reconstruction drawn over each frame (PNG)");
  app.add_option("--threads", threads, "Threads (0: all)");
  app.add_option("--max-frames", max_frames, "Solve only the first N frames (0: all)");

  polyfit::SheetSceneOptions generate_options;
  std::string generate_out, motion = "mixed";
  CLI::App* generate = app.add_subcommand("generate", "Write a synthetic sheet scene with exact ground truth");
  generate->add_option("--out", generate_out, "Scene directory to write")->required();
  generate->add_option("--motion", motion, "bend, wave, rigid, mixed or roll")->capture_default_str();
  generate->add_option("--frames", generate_options.frame_count, "Frames")->capture_default_str();
  generate->add_option("--width", generate_options.width, "Image width")->capture_default_str();
  generate->add_option("--height", generate_options.height, "Image height")->capture_default_str();
  generate->add_option("--focal", generate_options.focal_length, "Focal length (pixels)")->capture_default_str();
  generate->add_option("--wavelength", generate_options.wavelength, "Wave length (m), motion wave")
      ->capture_default_str();
  generate->add_option("--amplitude", generate_options.wave_amplitude, "Wave amplitude (m)")->capture_default_str();
  generate->add_option("--grid-x", generate_options.grid_x, "Template cells across")->capture_default_str();
  generate->add_option("--grid-y", generate_options.grid_y, "Template cells down")->capture_default_str();
  generate->add_option("--noise", generate_options.noise_sigma, "Pixel noise sigma")->capture_default_str();
  generate->add_option("--seed", generate_options.seed, "Random seed")->capture_default_str();
  bool no_masks = false;
  generate->add_flag("--no-masks", no_masks, "Write no masks");

  std::string demo_dir = "build/demo";
  CLI::App* demo = app.add_subcommand(
      "demo", "Generate the default scene (a sheet bending and moving, 30 frames, 320x240) and solve it");
  demo->add_option("--dir", demo_dir, "Where to write the scene (DIR/scene) and the result (DIR/result)")
      ->capture_default_str();

  CLI11_PARSE(app, argc, argv);
  try {
    if (demo->parsed()) {
      scene_dir = demo_dir + "/scene";
      out_dir = demo_dir + "/result";
      polyfit::GenerateSheetScene(polyfit::SheetSceneOptions(), scene_dir);
      std::printf("generated %s\n", scene_dir.c_str());
    }
    if (generate->parsed()) {
      generate_options.motion = polyfit::ParseSheetMotion(motion);
      generate_options.write_masks = !no_masks;
      polyfit::GenerateSheetScene(generate_options, generate_out);
      std::printf("wrote %s (%d frames, %dx%d, %s)\n", generate_out.c_str(), generate_options.frame_count,
                  generate_options.width, generate_options.height, motion.c_str());
      return 0;
    }
    if (scene_dir.empty() || out_dir.empty()) {
      std::cerr << "polysft: --scene and --out are required (or use 'polysft generate')\n";
      return 2;
    }
    polyfit::PolySftOptions options;
    if (!config.empty()) ApplyConfig(config, &options);
    if (threads > 0) options.num_threads = threads;
    if (max_frames > 0) options.max_frames = max_frames;
    options.rasterizer.num_threads = options.num_threads;
    const polyfit::SftScene scene = polyfit::LoadScene(scene_dir);
    std::printf("scene %s: %d frames %dx%d, template %d vertices / %d faces%s%s\n", scene_dir.c_str(),
                scene.frame_count, scene.camera.width, scene.camera.height, scene.template_mesh.num_vertices(),
                scene.template_mesh.num_faces(), scene.has_masks() ? ", masks" : "",
                scene.has_ground_truth() ? ", ground truth" : "");
    const polyfit::PolySftSummary summary =
        polyfit::SolvePolySft(options, scene, [](const polyfit::SftFrameSummary& f) {
          std::printf("frame %4d  %6.3f s  cost %.3e  %2d it", f.index, f.time_s, f.cost, f.iterations);
          if (std::isfinite(f.e3d)) std::printf("  e3D %.4f  e_n %5.2f deg  RMSE %6.2f mm", f.e3d, f.normal_error_deg, f.rmse_mm);
          if (std::isfinite(f.chamfer_1e4)) std::printf("  Chamfer x1e4 %.4f", f.chamfer_1e4);
          std::printf("\n");
          std::fflush(stdout);
        });
    polyfit::WriteSftOutputs(out_dir, scene, options, summary);
    if (overlays) WriteOverlays(out_dir, scene, summary);
    for (const std::string& w : summary.warnings) std::printf("warning: %s\n", w.c_str());
    std::printf("%zu frames in %.2f s (%.3f s per frame)", summary.frames.size(), summary.total_time_s,
                summary.mean_time_per_frame_s);
    if (std::isfinite(summary.mean_e3d)) {
      std::printf("; mean e3D %.4f, e_n %.2f deg, RMSE %.2f mm (template held still: e3D %.4f, RMSE %.1f mm)",
                  summary.mean_e3d, summary.mean_normal_error_deg, summary.mean_rmse_mm, summary.template_e3d,
                  summary.template_rmse_mm);
    }
    if (std::isfinite(summary.mean_chamfer_1e4)) std::printf("; mean Chamfer x1e4 %.4f", summary.mean_chamfer_1e4);
    std::printf("\nwrote %s/metrics.json, trace.csv, meshes/\n", out_dir.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "polysft: " << e.what() << "\n";
    return 2;
  }
}
