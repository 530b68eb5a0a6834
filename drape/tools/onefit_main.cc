// onefit: the reference drape (OneFit's losses minimised per frame).
//
//   onefit simulate --body DIR --garment G --motion CLIP.bvh --out DIR
//                   [--shape gender=0.2,weight=0.8] [--frames N] [--first-frame F]
//                   [--lead-in N] [--render-every K] [--threads T] ...
//
// Without --body, the procedural capsule body is used (then --garment must
// be a mesh file in its rest pose). Defaults live in DrapeSimulationOptions;
// this file maps flags onto them and makes one library call.
#include <cstdio>
#include <iostream>
#include <string>

#include <CLI/CLI.hpp>

#include "drape/simulate/drape_simulation.h"

namespace {

// The flags of `onefit simulate`, onto the options (defaults stay in them):
// one line per flag, hence the length.
struct SimulateFlags {
  polyfit::DrapeSimulationOptions options;
  std::string shape;
  bool no_slide = false;
  bool cholesky = false;
};

CLI::App* AddSimulateCommand(CLI::App* app, SimulateFlags* f) {
  polyfit::DrapeSimulationOptions& options = f->options;
  std::string& shape = f->shape;
  bool& no_slide = f->no_slide;
  bool& cholesky = f->cholesky;
  CLI::App* simulate = app->add_subcommand("simulate", "drape a garment through a motion clip, frame by frame");
  simulate->add_option("--body", options.body_dir,
                       "MakeHuman body folder (../shared/data/drape/body); none: procedural body");
  simulate->add_option("--garment", options.garment_path, ".mhclo garment, or a mesh in the body's rest pose (m)")
      ->required();
  simulate->add_option("--motion", options.motion_path, "BVH clip")->required();
  simulate->add_option("--out", options.out_dir, "output folder")->required();
  simulate->add_option("--shape", shape,
                       "macro shape: gender,muscle,weight,height,proportions in [0, 1], e.g. gender=0.2,weight=0.8");
  simulate->add_option("--bvh-scale", options.bvh_units_to_metres, "metres per BVH unit")->capture_default_str();
  simulate->add_option("--fps", options.solver.physics.fps, "frame rate to resample the clip to")
      ->capture_default_str();
  simulate->add_option("--first-frame", options.first_frame, "first clip frame (at --fps)")->capture_default_str();
  simulate->add_option("--frames", options.num_frames, "frames to simulate (-1: to the end)")->capture_default_str();
  simulate->add_option("--lead-in", options.lead_in_frames, "frames blending the rest pose into the first")
      ->capture_default_str();
  simulate->add_option("--render-every", options.render_every, "PNG every K frames (0: none)")->capture_default_str();
  simulate->add_option("--render-height", options.render_height, "PNG height in pixels")->capture_default_str();
  simulate
      ->add_option("--project", options.project_offset,
                   "move vertices left inside the body onto it plus this offset (m) in the outputs; < 0: off")
      ->capture_default_str();
  simulate->add_flag("!--no-meshes", options.write_meshes, "do not write a PLY per frame");
  simulate->add_option("--vertices-per-patch", options.solver.patching.vertices_per_patch, "garment vertices per patch")
      ->capture_default_str();
  simulate
      ->add_option("--max-fit-error", options.solver.patching.max_fit_error,
                   "split patches whose jet misses a vertex by more (m)")
      ->capture_default_str();
  simulate->add_flag("--no-slide", no_slide, "keep every vertex at its rest (u, v) on its patch");
  simulate
      ->add_option("--slide-agreement", options.solver.slide.agreement,
                   "stiffness holding a vertex's points on its patches together")
      ->capture_default_str();
  simulate->add_option("--jet-order", options.solver.patching.jet_order, "jet order n")->capture_default_str();
  simulate->add_option("--max-iterations", options.solver.solve.max_iterations, "LM iterations per pass")
      ->capture_default_str();
  simulate
      ->add_option("--max-refine-iterations", options.solver.solve.max_refine_iterations,
                   "LM iterations per later pass")
      ->capture_default_str();
  simulate->add_flag("--cholesky", cholesky,
                     "sparse Cholesky steps at any size (default: CG from 1500 garment vertices)");
  simulate->add_option("--trace", options.solver.solve.trace, "Ceres reports on stderr: 1 per solve, 2 per iteration")
      ->capture_default_str();
  simulate
      ->add_option("--trust-region", options.solver.solve.initial_trust_region_radius,
                   "Levenberg-Marquardt's first trust region")
      ->capture_default_str();
  simulate->add_option("--max-passes", options.solver.solve.max_passes, "collision passes per frame")
      ->capture_default_str();
  simulate->add_option("--k-b", options.solver.physics.weights.boundary, "patch boundary weight")
      ->capture_default_str();
  simulate->add_option("--k-mi", options.solver.physics.weights.inextensibility, "inextensibility weight")
      ->capture_default_str();
  simulate->add_option("--k-g", options.solver.physics.weights.gravity, "gravity weight")->capture_default_str();
  simulate->add_option("--k-c", options.solver.physics.weights.collision, "collision weight")->capture_default_str();
  simulate->add_option("--k-i", options.solver.physics.weights.inertia, "inertia weight")->capture_default_str();
  simulate->add_option("--eps", options.solver.physics.weights.collision_margin, "collision margin (m)")
      ->capture_default_str();
  simulate->add_option("--collision-stiffness", options.solver.physics.collision_stiffness, "kappa (N/m)")
      ->capture_default_str();
  simulate
      ->add_option("--skin-smoothing", options.skin.smoothing_iterations,
                   "smoothing steps of the transferred skinning weights")
      ->capture_default_str();
  simulate
      ->add_option("--skin-anchor", options.skin.anchor_distance,
                   "garment vertices closer to the body keep its weights (m)")
      ->capture_default_str();
  simulate
      ->add_option("--skin-loose", options.skin.loose_distance,
                   "smoothing steps scaled by distance to the body over this (m)")
      ->capture_default_str();
  simulate->add_option("--threads", options.solver.num_threads, "threads")->capture_default_str();
  return simulate;
}

int RunSimulate(SimulateFlags& f) {
  polyfit::DrapeSimulationOptions& options = f.options;
  if (!f.shape.empty()) options.shape = polyfit::BodyShape::Parse(f.shape);
  options.solver.slide.enabled = !f.no_slide;
  if (f.cholesky) options.solver.solve.linear_solver = polyfit::DrapeLinearSolver::kSparseCholesky;
  const polyfit::DrapeSimulationSummary summary = polyfit::RunDrapeSimulation(options);
  for (const std::string& warning : summary.warnings) std::cerr << "warning: " << warning << '\n';
  std::printf("%s\n", summary.BriefReport().c_str());
  std::printf("wrote %s (meshes/, renders/, frames.csv, metrics.json)\n", options.out_dir.c_str());
  return summary.termination_type == polyfit::TerminationType::kFailure ? polyfit::kExitSolverFailure
                                                                        : polyfit::kExitSuccess;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"onefit: garment draping on patch-wise jets"};
  app.require_subcommand(1);
  SimulateFlags simulate;
  AddSimulateCommand(&app, &simulate);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? polyfit::kExitSuccess : polyfit::kExitUsage;
  }
  return polyfit::RunReportingErrors("onefit", [&]() -> int { return RunSimulate(simulate); });
}
