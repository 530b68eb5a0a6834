// polysft: shape from template on a scene directory, and the scene
// generator.
//
//   polysft --scene DIR --out DIR [--config FILE] [--overlays]
//   polysft generate --out DIR [--motion bend|wave|rigid|mixed|roll|crease|wave_packet|hanging|flag|fall|table]
//                    [--frames N] ...
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

#include "polyfit/util/atomic_file.h"
#include "polyfit/util/output_folder.h"
#include "polyfit/util/status.h"
#include "sft/scene/scene.h"
#include "sft/solver/polysft.h"
#include "sft/solver/polysft_settings.h"
#include "sft/synthetic/sheet_scene.h"

namespace {

// A colour per patch of the atlas (BGR): green for the first, then hues
// a golden angle apart, so that neighbouring indices differ.
cv::Scalar PatchColor(int patch) {
  const double hue = std::fmod(120.0 + 137.508 * patch, 360.0);
  cv::Mat3b hsv(1, 1, cv::Vec3b(static_cast<uchar>(hue / 2.0), 220, 255)), bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b c = bgr(0, 0);
  return cv::Scalar(c[0], c[1], c[2]);
}

// The reconstruction's edges drawn over each frame, coloured by the patch
// of the atlas they lie on; edges between two patches white.
void WriteOverlays(const std::string& out_dir, const polyfit::SftScene& scene, const polyfit::PolySftSummary& summary) {
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
    const auto patch_of = [&f](int v) { return f.vertex_patches.empty() ? 0 : f.vertex_patches[v]; };
    for (int k = 0; k < scene.template_mesh.num_faces(); ++k) {
      for (int c = 0; c < 3; ++c) {
        const int a = scene.template_mesh.faces(c, k), b = scene.template_mesh.faces((c + 1) % 3, k);
        const cv::Scalar color = patch_of(a) == patch_of(b) ? PatchColor(patch_of(a)) : cv::Scalar(255, 255, 255);
        cv::line(image, project(a), project(b), color, 1, cv::LINE_AA);
      }
    }
    char name[32];
    std::snprintf(name, sizeof(name), "%06d.png", f.index);
    std::vector<uchar> png;
    cv::imencode(".png", image, png);
    polyfit::WriteFileAtomically((fs::path(out_dir) / "overlays" / name).string(), [&](std::ostream& out) {
      out.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
    });
  }
}

// What the command line asks for.
struct SolveFlags {
  std::string scene_dir, out_dir, config;
  bool overlays = false;
  int threads = 0, max_frames = 0;
};
struct GenerateFlags {
  polyfit::SheetSceneOptions options;
  std::string out, motion = "mixed";
  bool no_masks = false, real_like = false;
  CLI::App* command = nullptr;
};

void AddSolveFlags(CLI::App* app, SolveFlags* f) {
  app->add_option("--scene", f->scene_dir, "Scene directory (../shared/docs/sft-scene-format.md)");
  app->add_option("--out", f->out_dir, "Output directory");
  app->add_option("--config", f->config,
                  "JSON file of solver settings (keys as in metrics.json 'settings'), or a metrics.json");
  app->add_flag("--overlays", f->overlays, "Write the reconstruction drawn over each frame (PNG)");
  app->add_option("--threads", f->threads, "Threads (0: all)");
  app->add_option("--max-frames", f->max_frames, "Solve only the first N frames (0: all)");
}

CLI::App* AddGenerateCommand(CLI::App* app, GenerateFlags* f) {
  polyfit::SheetSceneOptions& o = f->options;
  CLI::App* generate = app->add_subcommand("generate", "Write a synthetic sheet scene with exact ground truth");
  generate->add_option("--out", f->out, "Scene directory to write")->required();
  generate
      ->add_option(
          "--motion", f->motion,
          "bend, wave, rigid, mixed, roll, crease, wave_packet, or simulated cloth: hanging, flag, fall, table")
      ->capture_default_str();
  generate->add_option("--frames", o.frame_count, "Frames")->capture_default_str();
  generate->add_option("--width", o.width, "Image width")->capture_default_str();
  generate->add_option("--height", o.height, "Image height")->capture_default_str();
  generate->add_option("--focal", o.focal_length, "Focal length (pixels)")->capture_default_str();
  generate->add_option("--wavelength", o.wavelength, "Wave length (m), motion wave")->capture_default_str();
  generate->add_option("--amplitude", o.wave_amplitude, "Wave amplitude (m)")->capture_default_str();
  generate
      ->add_option("--yaw", o.yaw_amplitude,
                   "Motions rigid and mixed: peak turn about the vertical (rad; 1.5708: edge-on)")
      ->capture_default_str();
  generate
      ->add_option("--sideways", o.sideways_amplitude, "Motions rigid and mixed: sideways travel (m; 0.3: out of view)")
      ->capture_default_str();
  generate->add_option("--grid-x", o.grid_x, "Template cells across")->capture_default_str();
  generate->add_option("--grid-y", o.grid_y, "Template cells down")->capture_default_str();
  generate->add_option("--noise", o.noise_sigma, "Pixel noise sigma")->capture_default_str();
  generate->add_option("--seed", o.seed, "Random seed")->capture_default_str();
  generate->add_flag("--no-masks", f->no_masks, "Write no masks");
  // Simulated cloth (sft/synthetic/cloth_motion.h).
  generate->add_option("--fps", o.frame_rate, "Simulated motions: frames per second")->capture_default_str();
  generate->add_option("--wind", o.wind_scale, "Simulated motions: factor on the wind")->capture_default_str();
  generate->add_option("--substeps", o.cloth.substeps, "Simulated motions: substeps per frame")->capture_default_str();
  generate->add_option("--bending", o.cloth.bending_stiffness, "Simulated motions: bending stiffness (N m)")
      ->capture_default_str();
  // Real footage's imperfections (sft/synthetic/footage_imperfections.h).
  polyfit::FootageImperfections& r = o.imperfections;
  generate->add_option("--fy-ratio", o.focal_ratio, "Camera fy / fx")->capture_default_str();
  generate->add_option("--principal-offset-x", o.principal_offset_x, "Principal point right of centre (px)");
  generate->add_option("--principal-offset-y", o.principal_offset_y, "Principal point below centre (px)");
  generate->add_option("--mask-offset", r.mask_offset, "Masks grown (> 0) or shrunk (< 0) by this many px");
  generate->add_option("--mask-ragged", r.mask_ragged, "Mask border moved by smooth noise of up to this many px");
  generate->add_option("--mask-holes", r.mask_holes, "Holes punched into each mask");
  generate->add_option("--gain-drift", r.gain_drift, "Frame gain 1 + g sin(pi tau): exposure drifting");
  generate->add_option("--bias-drift", r.bias_drift, "Frame bias b sin(2 pi tau): white level drifting");
  generate->add_option("--shading", r.shading, "Lambertian shading strength in [0, 1]");
  generate->add_option("--blur", r.blur, "Gaussian blur sigma (px)");
  generate->add_flag("--moving-background", r.moving_background, "A textured background sliding across the frames");
  generate->add_flag("--real-like", f->real_like,
                     "All of the above at once, as real footage (docs/sft.md); options given explicitly still apply");
  f->command = generate;
  return generate;
}

// --real-like: the preset, with the options given on the command line kept.
void ApplyRealLike(GenerateFlags* f) {
  const polyfit::SheetSceneOptions given = f->options;
  f->options.MakeRealLike();
  polyfit::SheetSceneOptions& o = f->options;
  const auto keep = [&](const char* name, auto member) {
    if (f->command->count(name) > 0) o.*member = given.*member;
  };
  const auto keep_imperfection = [&](const char* name, auto member) {
    if (f->command->count(name) > 0) o.imperfections.*member = given.imperfections.*member;
  };
  keep("--fy-ratio", &polyfit::SheetSceneOptions::focal_ratio);
  keep("--principal-offset-x", &polyfit::SheetSceneOptions::principal_offset_x);
  keep("--principal-offset-y", &polyfit::SheetSceneOptions::principal_offset_y);
  keep("--noise", &polyfit::SheetSceneOptions::noise_sigma);
  keep_imperfection("--mask-offset", &polyfit::FootageImperfections::mask_offset);
  keep_imperfection("--mask-ragged", &polyfit::FootageImperfections::mask_ragged);
  keep_imperfection("--mask-holes", &polyfit::FootageImperfections::mask_holes);
  keep_imperfection("--gain-drift", &polyfit::FootageImperfections::gain_drift);
  keep_imperfection("--bias-drift", &polyfit::FootageImperfections::bias_drift);
  keep_imperfection("--shading", &polyfit::FootageImperfections::shading);
  keep_imperfection("--blur", &polyfit::FootageImperfections::blur);
}

int RunGenerate(GenerateFlags& f) {
  f.options.motion = polyfit::ParseSheetMotion(f.motion);
  f.options.write_masks = !f.no_masks;
  if (f.real_like) ApplyRealLike(&f);
  polyfit::GenerateSheetScene(f.options, f.out);
  std::printf("wrote %s (%d frames, %dx%d, %s%s)\n", f.out.c_str(), f.options.frame_count, f.options.width,
              f.options.height, f.motion.c_str(), f.options.imperfections.Any() ? ", imperfect footage" : "");
  return polyfit::kExitSuccess;
}

void PrintFrame(const polyfit::SftFrameSummary& f) {
  std::printf("frame %4d  %6.3f s  cost %.3e  %2d it", f.index, f.time_s, f.cost, f.iterations);
  if (std::isfinite(f.e3d))
    std::printf("  e3D %.4f  e_n %5.2f deg  RMSE %6.2f mm", f.e3d, f.normal_error_deg, f.rmse_mm);
  if (std::isfinite(f.chamfer_1e4)) std::printf("  Chamfer x1e4 %.4f", f.chamfer_1e4);
  std::printf("\n");
  std::fflush(stdout);
}

int RunSolve(const SolveFlags& f) {
  if (f.scene_dir.empty() || f.out_dir.empty()) {
    std::cerr << "polysft: --scene and --out are required (or use 'polysft generate')\n";
    return polyfit::kExitUsage;
  }
  polyfit::PolySftOptions options;
  if (!f.config.empty()) polyfit::ApplyPolySftSettingsFile(f.config, &options);
  if (f.threads > 0) options.num_threads = f.threads;
  if (f.max_frames > 0) options.max_frames = f.max_frames;
  options.rasterizer.num_threads = options.num_threads;
  const polyfit::SftScene scene = polyfit::LoadScene(f.scene_dir);
  std::printf("scene %s: %d frames %dx%d, template %d vertices / %d faces%s%s\n", f.scene_dir.c_str(),
              scene.frame_count, scene.camera.width, scene.camera.height, scene.template_mesh.num_vertices(),
              scene.template_mesh.num_faces(), scene.has_masks() ? ", masks" : "",
              scene.has_ground_truth() ? ", ground truth" : "");
  // Outputs are written when every frame is solved, metrics.json last.
  const std::string earlier = polyfit::CleanOutputFolder(f.out_dir, "metrics.json").Describe(f.out_dir, "metrics.json");
  if (!earlier.empty()) std::printf("%s\n", earlier.c_str());
  const polyfit::PolySftSummary summary = polyfit::SolvePolySft(options, scene, PrintFrame);
  polyfit::WriteSftOutputs(f.out_dir, scene, options, summary);
  if (f.overlays) WriteOverlays(f.out_dir, scene, summary);
  for (const std::string& w : summary.warnings) std::printf("warning: %s\n", w.c_str());
  std::printf("%s\nwrote %s/metrics.json, trace.csv, meshes/\n", summary.BriefReport().c_str(), f.out_dir.c_str());
  return summary.IsSolutionUsable() ? polyfit::kExitSuccess : polyfit::kExitSolverFailure;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"PolySfT: shape from template with patch-wise polynomial jets"};
  SolveFlags solve;
  AddSolveFlags(&app, &solve);
  GenerateFlags generate_flags;
  CLI::App* generate = AddGenerateCommand(&app, &generate_flags);
  std::string demo_dir = "build/demo";
  CLI::App* demo = app.add_subcommand(
      "demo", "Generate the default scene (a sheet bending and moving, 30 frames, 320x240) and solve it");
  demo->add_option("--dir", demo_dir, "Where to write the scene (DIR/scene) and the result (DIR/result)")
      ->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? polyfit::kExitSuccess : polyfit::kExitUsage;
  }
  return polyfit::RunReportingErrors("polysft", [&]() -> int {
    if (generate->parsed()) return RunGenerate(generate_flags);
    if (demo->parsed()) {
      solve.scene_dir = demo_dir + "/scene";
      solve.out_dir = demo_dir + "/result";
      polyfit::GenerateSheetScene(polyfit::SheetSceneOptions(), solve.scene_dir);
      std::printf("generated %s\n", solve.scene_dir.c_str());
    }
    return RunSolve(solve);
  });
}
