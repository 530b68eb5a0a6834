// onefit: garment draping on patch-wise jets.
//
//   onefit simulate --body DIR --garment G --motion CLIP.bvh --out DIR
//                   [--shape gender=0.2,weight=0.8] [--frames N] [--first-frame F]
//                   [--lead-in N] [--render-every K] [--threads T] ...
//       the reference drape (OneFit's losses minimised per frame)
//   onefit train --body DIR --garments G... --motions CLIP.bvh... --out MODEL
//                [--batches N] [--batch-size B] [--threads T] [--resume] ...
//       trains OneFit's network on the same losses (self-supervised)
//   onefit drape --model MODEL --body DIR --garment G --motion CLIP.bvh --out DIR
//       the network's drape, with simulate's outputs
//   onefit eval --model MODEL --body DIR --garment G --motion CLIP.bvh --out DIR
//       the network against the reference drape: a table and a plot
//
// Without --body, the procedural capsule body is used (then --garment must
// be a mesh file in its rest pose). Defaults live in DrapeSimulationOptions;
// this file maps flags onto them and makes one library call.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "drape/network/onefit_training_run.h"
#include "drape/simulate/drape_simulation.h"
#include "drape/simulate/onefit_evaluation.h"
#ifdef POLYFIT_WITH_MPI
#include "polyfit/util/mpi_session.h"
#include "polyfit/util/output_folder.h"
#endif

namespace {

// The flags of `onefit simulate`, onto the options (defaults stay in them):
// one line per flag, hence the length.
struct SimulateFlags {
  polyfit::DrapeSimulationOptions options;
  std::string shape;
  bool no_slide = false;
  bool cholesky = false;
};

// The body, garment and clip, and what is written.
void AddSimulateClipOptions(CLI::App* simulate, SimulateFlags* f) {
  polyfit::DrapeSimulationOptions& options = f->options;
  std::string& shape = f->shape;
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
  simulate
      ->add_option("--strain-limit", options.strain_limit_passes,
                   "with --project: then this many strain-limiting passes over the edges")
      ->capture_default_str();
  simulate->add_flag("!--no-meshes", options.write_meshes, "do not write a PLY per frame");
}

// How the garment becomes patches, and its slides.
void AddSimulatePatchingOptions(CLI::App* simulate, SimulateFlags* f) {
  polyfit::DrapeSimulationOptions& options = f->options;
  bool& no_slide = f->no_slide;
  simulate->add_option("--patch-area", options.solver.patching.patch_area, "garment area per patch (m^2)")
      ->capture_default_str();
  simulate
      ->add_option("--face-subdivisions", options.solver.patching.face_subdivisions,
                   "jets fitted to a grid of this many subdivisions per face edge (0: to the vertices)")
      ->capture_default_str();
  simulate->add_option("--patch-seed", options.solver.patching.seed, "the patches' clustering seed")
      ->capture_default_str();
  simulate->add_flag("--curved-faces", options.solver.patching.curved_faces,
                     "the grid on the faces' Phong tessellation, not their planes");
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
}

// The per-frame minimisation.
void AddSimulateSolveOptions(CLI::App* simulate, SimulateFlags* f) {
  polyfit::DrapeSimulationOptions& options = f->options;
  bool& cholesky = f->cholesky;
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
}

// How garments get their skinning weights (the simulation's and the
// training's; a model records the training's).
void AddSkinFlags(CLI::App* app, polyfit::SkinTransferOptions* skin) {
  app->add_option("--skin-smoothing", skin->smoothing_length,
                  "how far the transferred skinning weights diffuse over the garment (m; 0: not at all)")
      ->capture_default_str();
  app->add_option("--skin-smoothing-method", skin->smoothing,
                  "surface: heat diffusion over the garment's surface; edges: Jacobi steps over its edges")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, polyfit::SkinSmoothing>{{"surface", polyfit::SkinSmoothing::kSurface},
                                                        {"edges", polyfit::SkinSmoothing::kEdgeSteps}},
          CLI::ignore_case))
      ->capture_default_str();
  app->add_option("--skin-smoothing-steps", skin->smoothing_iterations,
                  "that many Jacobi steps over its edges instead, whatever its meshing (0: by the length)")
      ->capture_default_str();
  app->add_option("--skin-anchor", skin->anchor_distance, "garment vertices closer to the body keep its weights (m)")
      ->capture_default_str();
  app->add_option("--skin-loose", skin->loose_distance, "smoothing steps scaled by distance to the body over this (m)")
      ->capture_default_str();
  app->add_option("--skin-resample", skin->resample_edge_length,
                  "transfer and smooth the weights on a copy of the garment with no edge longer than this (m), so "
                  "that any meshing of it gets the same weights (0: on its own mesh)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
}

// The losses' weights, collisions and skinning transfer.
void AddSimulatePhysicsOptions(CLI::App* simulate, SimulateFlags* f) {
  polyfit::DrapeSimulationOptions& options = f->options;
  simulate->add_option("--k-b", options.solver.physics.weights.boundary, "patch boundary weight")
      ->capture_default_str();
  simulate->add_option("--k-mi", options.solver.physics.weights.inextensibility, "inextensibility weight")
      ->capture_default_str();
  simulate
      ->add_option("--stretch-factor", options.solver.physics.stretch_factor,
                   "the inextensibility terms' residuals where the cloth stretches times this (1: symmetric)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  simulate->add_option("--k-g", options.solver.physics.weights.gravity, "gravity weight")->capture_default_str();
  simulate->add_option("--k-c", options.solver.physics.weights.collision, "collision weight")->capture_default_str();
  simulate->add_option("--k-i", options.solver.physics.weights.inertia, "inertia weight")->capture_default_str();
  simulate->add_option("--eps", options.solver.physics.weights.collision_margin, "collision margin (m)")
      ->capture_default_str();
  simulate
      ->add_option("--margin-floor", options.solver.physics.margin_floor,
                   "per vertex, the margin is its rest clearance clamped to [this, --eps] (m; < 0: off)")
      ->capture_default_str();
  simulate->add_option("--collision-stiffness", options.solver.physics.collision_stiffness, "kappa (N/m)")
      ->capture_default_str();
  AddSkinFlags(simulate, &options.skin);
}

CLI::App* AddSimulateCommand(CLI::App* app, SimulateFlags* f, const char* name = "simulate",
                             const char* description = "drape a garment through a motion clip, frame by frame") {
  CLI::App* simulate = app->add_subcommand(name, description);
  AddSimulateClipOptions(simulate, f);
  AddSimulatePatchingOptions(simulate, f);
  AddSimulateSolveOptions(simulate, f);
  AddSimulatePhysicsOptions(simulate, f);
  simulate->add_option("--threads", f->options.solver.num_threads, "threads")->capture_default_str();
  return simulate;
}

// What an earlier run left in `dir` (its last file `marker`), said before
// this one replaces it.
void SayWhatAnEarlierRunLeft(const std::string& dir, const char* marker) {
  const std::string earlier = polyfit::CleanOutputFolder(dir, marker).Describe(dir, marker);
  if (!earlier.empty()) std::printf("%s\n", earlier.c_str());
}

int RunSimulate(SimulateFlags& f) {
  polyfit::DrapeSimulationOptions& options = f.options;
  if (!f.shape.empty()) options.shape = polyfit::BodyShape::Parse(f.shape);
  options.solver.slide.enabled = !f.no_slide;
  if (f.cholesky) options.solver.solve.linear_solver = polyfit::DrapeLinearSolver::kSparseCholesky;
  SayWhatAnEarlierRunLeft(options.out_dir, "metrics.json");
  const polyfit::DrapeSimulationSummary summary = polyfit::RunDrapeSimulation(options);
  for (const std::string& warning : summary.warnings) std::cerr << "warning: " << warning << '\n';
  for (const std::string& note : summary.notes) std::printf("note: %s\n", note.c_str());
  std::printf("%s\n", summary.BriefReport().c_str());
  std::printf("wrote %s (meshes/, renders/, frames.csv, metrics.json)\n", options.out_dir.c_str());
  return summary.termination_type == polyfit::TerminationType::kFailure ? polyfit::kExitSolverFailure
                                                                        : polyfit::kExitSuccess;
}

struct TrainFlags {
  polyfit::OneFitTrainingRunOptions options;
  std::string shape;
  std::string optimizer = "adam";
};

// onefit train's inputs: the body, garments, clips and their augmentation.
void AddTrainDataFlags(CLI::App* train, TrainFlags* f) {
  polyfit::OneFitTrainingRunOptions& o = f->options;
  train->add_option("--body", o.body_dir, "MakeHuman body folder; none: procedural body");
  train->add_option("--garments", o.garment_paths, ".mhclo garments or meshes in the body's rest pose")->required();
  train->add_option("--motions", o.motion_paths, "BVH clips")->required();
  train->add_option("--out", o.model_path, "the model file to write (and MODEL.csv, the progress)")->required();
  train->add_option("--shape", f->shape, "macro shape of the body, e.g. gender=0.2,weight=0.8");
  train->add_option("--bvh-scale", o.bvh_units_to_metres, "metres per BVH unit")->capture_default_str();
  AddSkinFlags(train, &o.skin);
  train->add_option("--frames-per-clip", o.max_frames_per_clip, "frames used per clip (0: all)")->capture_default_str();
  train
      ->add_option("--speeds", o.speeds,
                   "augmentation: each clip also played at these speeds (e.g. 0.8 1 1.25); default: as recorded")
      ->expected(1, 8);
  train->add_flag("--mirror", o.mirror, "augmentation: each clip also mirrored left to right");
  train
      ->add_option("--perturb", o.perturb_degrees,
                   "augmentation: each clip also played with its joint angles perturbed smoothly by up to this many "
                   "degrees (0: none)")
      ->capture_default_str();
  train
      ->add_option("--mix-clips", o.mix_clips,
                   "augmentation: this many more clips, each a recorded one whose arms, neck and spine move as other "
                   "recorded clips' do (seeded; before --perturb, which covers them too)")
      ->capture_default_str();
  train
      ->add_option("--limb-excursions", o.excursion_clips,
                   "augmentation: this many more clips, each a recorded or mixed one whose arms, legs and spine also "
                   "swing between seeded key angles far from the recordings' (arms overhead, lunges, bends; before "
                   "--perturb, which covers them too)")
      ->capture_default_str();
  train->add_flag("--subdivide", o.subdivide,
                  "augmentation: each garment also subdivided once at its edges' midpoints (the loss then sees points "
                  "between its vertices)");
  train
      ->add_option("--decimate", o.decimate,
                   "augmentation: each garment also decimated to this fraction of its edges (0: none)")
      ->capture_default_str();
  train->add_option("--garment-offsets", o.garment_offsets,
                    "augmentation: each garment also moved along its normals by these distances (m; > 0 looser, "
                    "< 0 tighter; |d| <= 0.03)");
  train
      ->add_option(
          "--repatch", o.repatch,
          "augmentation: each garment (decimated and offset ones too) also patched under this many other clustering "
          "seeds (0: none)")
      ->capture_default_str();
  train
      ->add_option("--procedural-garments", o.procedural_garments,
                   "augmentation: this many tight garments cut from the body's skin (tops, bottoms, suits of drawn "
                   "sleeve and leg lengths, 3-15 mm off it; seeded; needs --body)")
      ->capture_default_str();
  train
      ->add_option("--shape-samples", o.shape_samples,
                   "augmentation: also train on this many body shapes sampled uniformly in range (seeded; needs "
                   "--body), each with every garment fitted to it and every clip")
      ->capture_default_str();
}

// The loss's weights (the patching's area is with them: both shape what
// the network is trained to move).
void AddTrainLossFlags(CLI::App* train, polyfit::OneFitTrainerOptions* trainer) {
  polyfit::OneFitTrainerOptions& t = *trainer;
  train->add_option("--patch-area", t.drape.patching.patch_area, "garment area per patch (m^2)")->capture_default_str();
  train
      ->add_option("--k-c", t.drape.physics.weights.collision,
                   "the loss's collision weight (the reference drape's by default; refinement keeps its own)")
      ->capture_default_str();
  train->add_option("--eps", t.drape.physics.weights.collision_margin, "the loss's collision margin (m)")
      ->capture_default_str();
  train
      ->add_option("--margin-floor", t.drape.physics.margin_floor,
                   "per vertex, the loss's margin is its rest clearance clamped to [this, --eps] (m; < 0: off)")
      ->capture_default_str();
  train
      ->add_option("--k-mi", t.drape.physics.weights.inextensibility,
                   "the loss's inextensibility weight (metric tensor and edges; the reference drape's by default)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  train
      ->add_option("--k-b", t.drape.physics.weights.boundary,
                   "the loss's patch boundary weight (positions and normals; the reference drape's by default)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  train
      ->add_option("--stretch-factor", t.drape.physics.stretch_factor,
                   "the inextensibility terms' residuals where the cloth stretches times this (1: symmetric)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
}

// The network's layer and embedding sizes.
void AddTrainNetworkSizeFlags(CLI::App* train, polyfit::OneFitTrainerOptions* trainer) {
  polyfit::OneFitTrainerOptions& t = *trainer;
  train->add_option("--decoder-hidden", t.network.decoder_hidden, "the decoder's hidden layer widths")
      ->capture_default_str();
  train->add_option("--body-hidden", t.network.body_hidden, "the body encoder's hidden layer widths")
      ->capture_default_str();
  train->add_option("--patch-hidden", t.network.patch_hidden, "the patch encoder's hidden layer widths")
      ->capture_default_str();
  train
      ->add_option("--patch-embedding", t.network.patch_embedding,
                   "the patch embedding's size (computed once per garment: no inference cost per frame)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  train
      ->add_option("--body-embedding", t.network.body_embedding,
                   "the body embedding's size (computed once per frame, shared by every patch)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
}

// What the network reads and predicts, and how the garment's patches are
// framed (all recorded in the model).
void AddTrainNetworkInputFlags(CLI::App* train, polyfit::OneFitTrainerOptions* trainer) {
  polyfit::OneFitTrainerOptions& t = *trainer;
  train
      ->add_option("--warp-order", t.network.warp_order,
                   "order of each patch's predicted in-plane warp (its vertices' slides), at most 2 without "
                   "--warp-slide-bound; -1: none")
      ->capture_default_str();
  train
      ->add_option("--warp-slide-bound", t.warp_slide_bound,
                   "bound on each point's slide by the warp, in units of its patch's radius (recorded in the model); "
                   "0: each warp coefficient bounded instead")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  train->add_flag("--local-pose", t.network.local_pose,
                  "each patch also reads its own joints' pose, skinning-weighted (recorded in the model)");
  CLI::Option* proximity = train->add_flag(
      "--body-proximity", t.network.body_proximity,
      "each patch also reads where it meets the body when posed by skinning alone: signed distances and the body's "
      "normals at points of it (recorded in the model)");
  train
      ->add_option("--proximity-probes", t.network.proximity_probes,
                   "with --body-proximity: 5 (its centre and four points half-way to its rim) or 9 (also four on "
                   "its rim; recorded in the model)")
      ->capture_default_str()
      ->check(CLI::IsMember({5, 9}))
      ->needs(proximity);
  CLI::Option* feedback =
      train
          ->add_flag("--feedback", t.network.feedback,
                     "with --body-proximity: a second, small decoder reads where the first's patches meet the body "
                     "and corrects them (recorded in the model)")
          ->needs(proximity);
  train->add_option("--feedback-hidden", t.network.feedback_hidden, "with --feedback: its hidden layers' widths")
      ->capture_default_str()
      ->needs(feedback);
  train
      ->add_option("--feedback-passes", t.network.feedback_passes,
                   "with --feedback: how many times it is applied, each pass reading the proximity where the last "
                   "one's patches sit (recorded in the model)")
      ->capture_default_str()
      ->check(CLI::Range(1, polyfit::kMaxFeedbackPasses))
      ->needs(feedback);
  train->add_flag("--align-frames", t.drape.patching.align_frames,
                  "patch frames turned to the body's up axis (recorded in the model)");
  train->add_flag("--curved-faces", t.drape.patching.curved_faces,
                  "jets fitted to the faces' Phong tessellation, not their planes (recorded in the model)");
  train
      ->add_option("--joint-mask-reach", t.joint_mask_reach,
                   "each garment reads only the rotations of the joints that move some vertex of it by at least this "
                   "skinning weight (recorded in the model); 0: every joint's")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  train->add_flag_callback(
      "--absolute-root", [&t] { t.root_rotation = polyfit::RootRotation::kAbsolute; },
      "the body features hold the root's rotation with its heading, as models before file version 6 did");
  train->add_flag_callback(
      "--scale-units", [&t] { t.area_units = false; },
      "outputs and jet features in units of each patch's scale, as models before file version 8 had them");
}

// The optimisation: batches, optimiser, resumption, validation, polish.
void AddTrainRunFlags(CLI::App* train, TrainFlags* f) {
  polyfit::OneFitTrainingRunOptions& o = f->options;
  polyfit::OneFitTrainerOptions& t = o.trainer;
  train->add_option("--batches", t.num_batches, "mini-batches")->capture_default_str();
  train->add_option("--batch-size", t.batch_size, "samples (garment, frame) per batch")->capture_default_str();
  train->add_option("--iterations-per-batch", t.iterations_per_batch, "L-BFGS iterations per batch")
      ->capture_default_str();
  train->add_option("--seed", t.seed, "seed of the weights and the data order")->capture_default_str();
  train->add_option("--threads", t.num_threads, "threads")->capture_default_str();
  train->add_flag("--resume", o.resume, "continue from the model file and its progress, if they exist");
  train->add_option("--init", o.init_model_path, "fine-tune: start from this model (network, normalisers, weights)");
  train->add_option("--validate-every", t.validation_every, "a validation drape every N batches (0: none)")
      ->capture_default_str();
  train
      ->add_option("--validate-frames", t.validation_frames,
                   "frames of each validation drape, spread evenly through its clip")
      ->capture_default_str();
  train->add_option("--validation-motion", o.validation_motion_path,
                    "BVH clip held out of training for the validation drape; the model at its lowest loss is "
                    "written to MODEL.best");
  train->add_option("--optimizer", f->optimizer, "adam, or lbfgs (a ceres::GradientProblem per batch)")
      ->capture_default_str();
  train->add_option("--learning-rate", t.learning_rate, "Adam's step size")->capture_default_str();
  train->add_option("--warmup", t.warmup_batches, "Adam's step size ramps up linearly over this many batches")
      ->capture_default_str();
  train
      ->add_option("--final-rate", t.final_rate_fraction,
                   "Adam's step size then follows a cosine down to this fraction of --learning-rate at the last batch "
                   "(1: constant)")
      ->capture_default_str();
  train
      ->add_option("--kext-final-epoch", t.kext_final_epoch,
                   "k_ext's epoch (eq. 4) at the last batch, reached linearly from 0 (0: no allowance)")
      ->capture_default_str();
  train
      ->add_option("--k-c-start", t.collision_start,
                   "a curriculum: the collision weight at the first batch, held over the first --k-c-ramp START of "
                   "the batches, then raised linearly to --k-c at END (< 0: none)")
      ->capture_default_str();
  train
      ->add_option_function<std::vector<double>>(
          "--k-c-ramp", [&t](const std::vector<double>& v) { t.collision_ramp = {v[0], v[1]}; },
          "with --k-c-start: the ramp's START and END, fractions of --batches (default 0.4 0.7)")
      ->expected(2);
  train
      ->add_option("--average-batches", t.average_batches,
                   "validate, keep in MODEL.best and return the weights averaged exponentially over about N "
                   "batches (Adam only; 0: the last batch's)")
      ->capture_default_str();
  train
      ->add_option("--weight-decay", t.weight_decay,
                   "decoupled weight decay (AdamW): each step also shrinks the layers' matrices by the step size "
                   "times this (Adam only; 0: none)")
      ->capture_default_str();
  train
      ->add_option("--polish", t.polish.iterations,
                   "then this many Levenberg-Marquardt iterations on the output layer, features frozen (with "
                   "--batches 0: a polish of --init's model); progress in MODEL.polish.csv")
      ->capture_default_str();
  train->add_option("--polish-samples", t.polish.samples, "samples the polish fits")->capture_default_str();
  train->add_option("--polish-damping", t.polish.initial_damping, "the polish's initial Marquardt lambda")
      ->capture_default_str();
}

// The warm start from the reference drape (OneFitTeacherOptions).
void AddTrainTeacherFlags(CLI::App* train, polyfit::OneFitTrainerOptions* options) {
  polyfit::OneFitTeacherOptions& t = options->teacher;
  train
      ->add_option("--teacher-clips", t.clips,
                   "warm start: per garment, the reference drape runs on this many training clips (drawn) and the "
                   "network is first fitted to its positions (0: none)")
      ->capture_default_str();
  train->add_option("--teacher-batches", t.batches, "the warm start's Adam batches")->capture_default_str();
  train->add_option("--teacher-frames", t.max_frames, "the warm start's frames per clip (0: all)")
      ->capture_default_str();
  train
      ->add_option("--teacher-weight", t.weight,
                   "then through training the distance to the reference drape also pulls, at this weight (J per "
                   "m^2) falling linearly to 0 (0: the warm start alone)")
      ->capture_default_str();
  train
      ->add_option("--teacher-max-inside", t.max_inside_percent,
                   "the warm start keeps a reference frame only with at most this % of the garment inside the body")
      ->capture_default_str();
  train->add_option("--teacher-max-strain", t.max_edge_strain_percent, "... and at most this mean edge strain (%)")
      ->capture_default_str();
  train
      ->add_option("--warp-target", options->warp_target_weight,
                   "the warps each batch's jets ask for (re-solved per sample) pull the warp head at this weight "
                   "(J per m^2; 0: none)")
      ->capture_default_str();
  train
      ->add_option("--warp-target-sweeps", options->warp_target_sweeps, "the warp target's sweeps")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  train->add_flag("--warp-target-translations", options->warp_target_translations,
                  "the warp target re-solves and pulls each patch's translation too");
}

CLI::App* AddTrainCommand(CLI::App* app, TrainFlags* f) {
  polyfit::OneFitTrainingRunOptions& o = f->options;
  polyfit::OneFitTrainerOptions& t = o.trainer;
  CLI::App* train = app->add_subcommand("train", "train OneFit's network, self-supervised, on the drape's losses");
  AddTrainDataFlags(train, f);
  AddTrainLossFlags(train, &t);
  AddTrainNetworkSizeFlags(train, &t);
  AddTrainNetworkInputFlags(train, &t);
  AddTrainRunFlags(train, f);
  AddTrainTeacherFlags(train, &t);
  return train;
}

// Every rank of an MPI job (`mpirun -n N onefit train`) trains the same
// weights on its share of each mini-batch; rank 0 prints and writes.
int RunTrainOn(TrainFlags& f, bool quiet) {
  const polyfit::OneFitTrainingSummary summary = polyfit::RunOneFitTraining(
      f.options,
      [quiet](const polyfit::OneFitBatchSummary& b) {
        if (quiet) return;
        std::printf("batch %4d  loss %.5g -> %.5g J  %2d it  %7.1f s", b.batch, b.initial_loss, b.final_loss,
                    b.iterations, b.time_s);
        if (b.undone) std::printf("  undone (the loss grew over %g-fold)", polyfit::kSpikeRatio);
        if (std::isfinite(b.validation_inside_percent)) {
          std::printf("  validation epsilon_c %.2f%% epsilon_e %.2f%% loss %.5g J", b.validation_inside_percent,
                      b.validation_edge_strain_percent, b.validation_loss);
        }
        std::printf("\n");
        std::fflush(stdout);
      },
      [quiet](int step, const polyfit::OneFitPolishStep& s) {
        if (quiet) return;
        std::printf("polish step %2d  loss %.5g J  lambda %.3g  %s  %7.1f s\n", step, s.loss, s.damping,
                    s.accepted ? "kept" : "rejected", s.time_s);
        std::fflush(stdout);
      },
      [quiet](const polyfit::OneFitTeacherBatch& b) {
        if (quiet) return;
        std::printf("teacher batch %4d  distance %.2f -> %.2f mm  %7.1f s\n", b.batch, b.initial_rms_mm, b.final_rms_mm,
                    b.time_s);
        std::fflush(stdout);
      });
  if (!quiet) {
    std::printf("%s\nwrote %s (and %s.csv)\n", summary.BriefReport().c_str(), f.options.model_path.c_str(),
                f.options.model_path.c_str());
  }
  return summary.termination_type == polyfit::TerminationType::kFailure ? polyfit::kExitSolverFailure
                                                                        : polyfit::kExitSuccess;
}

int RunTrain(TrainFlags& f) {
  if (!f.shape.empty()) f.options.shape = polyfit::BodyShape::Parse(f.shape);
  if (f.optimizer != "lbfgs" && f.optimizer != "adam") {
    throw std::invalid_argument("--optimizer: lbfgs or adam, not '" + f.optimizer + "'");
  }
  f.options.trainer.optimizer =
      f.optimizer == "adam" ? polyfit::OneFitOptimizer::kAdam : polyfit::OneFitOptimizer::kLbfgs;
#ifdef POLYFIT_WITH_MPI
  if (polyfit::LaunchedByMpi()) {
    polyfit::MpiSession mpi;
    f.options.trainer.distribution = {mpi.rank(), mpi.size(), [](double* values, int count) {
                                        MPI_Allreduce(MPI_IN_PLACE, values, count, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
                                      }};
    if (mpi.rank() == 0) std::printf("training on %d ranks x %d threads\n", mpi.size(), f.options.trainer.num_threads);
    return mpi.Run("onefit", [&] { return RunTrainOn(f, mpi.rank() != 0); });
  }
#endif
  return RunTrainOn(f, false);
}

// `onefit eval`: simulate's flags, --project the network's post-process.
int RunEval(SimulateFlags& f) {
  polyfit::OneFitEvaluationOptions options;
  options.simulation = f.options;
  if (!f.shape.empty()) options.simulation.shape = polyfit::BodyShape::Parse(f.shape);
  options.simulation.solver.slide.enabled = !f.no_slide;
  if (f.cholesky) options.simulation.solver.solve.linear_solver = polyfit::DrapeLinearSolver::kSparseCholesky;
  options.project_offset = f.options.project_offset;
  options.strain_limit_passes = f.options.strain_limit_passes;
  options.simulation.project_offset = -1.0;
  SayWhatAnEarlierRunLeft(options.simulation.out_dir, "eval.md");
  const polyfit::OneFitEvaluationSummary summary = polyfit::EvaluateOneFitModel(options);
  std::printf("%s\n%s", summary.BriefReport().c_str(), summary.Table().c_str());
  std::printf("wrote %s (reference/, network/, %seval.csv, eval.md, eval.png)\n", options.simulation.out_dir.c_str(),
              summary.has_predicted ? "network_predicted/, " : "");
  return summary.termination_type == polyfit::TerminationType::kFailure ? polyfit::kExitSolverFailure
                                                                        : polyfit::kExitSuccess;
}

// --model when not given: the shipped model, from the source tree or the
// installation.
std::string ShippedModel() {
  for (const char* path : {POLYFIT_SHIPPED_ONEFIT_MODEL, POLYFIT_INSTALLED_ONEFIT_MODEL}) {
    if (std::filesystem::exists(path)) return path;
  }
  throw polyfit::Error(
      polyfit::ErrorKind::kInvalidArgument,
      std::string("no --model given and the shipped model is missing (") + POLYFIT_SHIPPED_ONEFIT_MODEL + ")");
}

// What a fine-tune (--init) takes from the model besides its skinning: the
// network's shape and inputs, and the patching.
const std::vector<const char*> kNetworkFlags = {
    "--patch-area",       "--decoder-hidden",   "--body-hidden",      "--patch-hidden",    "--patch-embedding",
    "--body-embedding",   "--warp-order",       "--warp-slide-bound", "--local-pose",      "--body-proximity",
    "--proximity-probes", "--feedback",         "--feedback-hidden",  "--feedback-passes", "--align-frames",
    "--curved-faces",     "--joint-mask-reach", "--absolute-root",    "--scale-units"};

const std::vector<const char*> kSkinFlags = {"--skin-smoothing",       "--skin-smoothing-method",
                                             "--skin-smoothing-steps", "--skin-anchor",
                                             "--skin-loose",           "--skin-resample"};

// What a drape takes from the model besides its skinning: the patching.
const std::vector<const char*> kPatchingFlags = {"--patch-area", "--max-fit-error", "--curved-faces", "--jet-order"};

// A network's patches must be laid out, fitted and skinned as in its
// training, so the model sets these; given on the command line they would
// be ignored.
int RejectFlagsTheModelSets(const CLI::App& command,
                            std::initializer_list<const std::vector<const char*>*> flag_lists) {
  for (const std::vector<const char*>* flags : flag_lists) {
    for (const char* flag : *flags) {
      if (command.get_option(flag)->count() > 0) {
        std::fprintf(stderr,
                     "onefit %s: %s is set by the model (its network, and how it lays out, fits and skins a garment, "
                     "are its training's)\n",
                     command.get_name().c_str(), flag);
        return polyfit::kExitUsage;
      }
    }
  }
  return polyfit::kExitSuccess;
}

// What `drape` and `eval` take beyond `simulate`'s: the model, and what
// follows each prediction (refinement, or re-solved warps).
void AddNetworkOptions(CLI::App* command, polyfit::DrapeSimulationOptions* options) {
  command->add_option("--model", options->model_path, "a model from onefit train (default: the shipped one)");
  command
      ->add_option("--refine", options->refine_iterations,
                   "Levenberg-Marquardt iterations of the reference drape from each prediction (0: none)")
      ->capture_default_str();
  command
      ->add_option("--relax", options->relax_passes,
                   "strain-limiting passes on each prediction against the body's planes under the garment, "
                   "skinned from rest (part of the inference; 0: the network's drape as predicted; not with --refine "
                   "or --warp-sweeps)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  command
      ->add_option("--warp-sweeps", options->warp_sweeps,
                   "re-solve each prediction's warps for its jets with this many sweeps, under the collision settings "
                   "of the model's training unless --k-c/--eps/--margin-floor are given (0: the network's own)")
      ->capture_default_str();
  command->add_flag("--warp-translations,!--warp-only", options->warp_translations,
                    "with --warp-sweeps: each patch's translation re-solved with its warp (the default; "
                    "--warp-only: the warps alone)");
  command
      ->add_option("--warp-carry", options->warp_carry,
                   "with --warp-sweeps: each frame's re-solve starts from its prediction plus this fraction of "
                   "the last frame's correction (0: from the prediction alone)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
}

// The collision flags given on the command line override the ones the
// model records for its re-solve (--warp-sweeps).
void CollisionFromModelUnlessGiven(const CLI::App& command, polyfit::DrapeSimulationOptions* options) {
  for (const char* flag : {"--k-c", "--eps", "--margin-floor"}) {
    if (command.get_option(flag)->count() > 0) options->collision_from_model = false;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"onefit: garment draping on patch-wise jets"};
  app.require_subcommand(1);
  SimulateFlags simulate, drape;
  AddSimulateCommand(&app, &simulate);
  CLI::App* drape_command = AddSimulateCommand(&app, &drape, "drape", "drape a garment with a trained network");
  AddNetworkOptions(drape_command, &drape.options);
  SimulateFlags eval;
  eval.options.render_every = 0;
  eval.options.project_offset = polyfit::kNetworkProjectOffset;
  eval.options.strain_limit_passes = polyfit::kNetworkStrainLimitPasses;
  CLI::App* eval_command =
      AddSimulateCommand(&app, &eval, "eval", "compare a trained network with the reference drape on a clip");
  AddNetworkOptions(eval_command, &eval.options);
  TrainFlags train;
  CLI::App* train_command = AddTrainCommand(&app, &train);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? polyfit::kExitSuccess : polyfit::kExitUsage;
  }
  return polyfit::RunReportingErrors("onefit", [&]() -> int {
    if (train_command->parsed()) {
      // A fine-tune keeps the model's network and patches and skins its
      // garments as the model's training did.
      if (!train.options.init_model_path.empty()) {
        if (const int rejected = RejectFlagsTheModelSets(*train_command, {&kNetworkFlags, &kSkinFlags});
            rejected != polyfit::kExitSuccess)
          return rejected;
      }
      return RunTrain(train);
    }
    if (drape_command->parsed()) {
      if (const int rejected = RejectFlagsTheModelSets(*drape_command, {&kPatchingFlags, &kSkinFlags});
          rejected != polyfit::kExitSuccess)
        return rejected;
      if (drape.options.model_path.empty()) drape.options.model_path = ShippedModel();
      CollisionFromModelUnlessGiven(*drape_command, &drape.options);
      return RunSimulate(drape);
    }
    if (eval_command->parsed()) {
      if (eval.options.model_path.empty()) eval.options.model_path = ShippedModel();
      CollisionFromModelUnlessGiven(*eval_command, &eval.options);
      return RunEval(eval);
    }
    return RunSimulate(simulate);
  });
}
