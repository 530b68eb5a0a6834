// `onefit simulate`: a garment on a body through a motion clip, by the
// reference drape (drape_solver.h). Loads and checks every input before
// writing anything, then writes into out_dir:
//   meshes/frame_NNNN.ply   the garment per clip frame (atomically)
//   meshes/body_NNNN.ply    the posed body per clip frame
//   rest_garment.ply        the garment at rest as its patches rebuild it
//                           (what epsilon_e and epsilon_a compare against)
//   renders/frame_NNNN.png  body and garment, front and side, every k frames
//   frames.csv              per-frame metrics and times
//   metrics.json            options, sizes, termination, per-frame metrics,
//                           their summary
// Metrics per frame: epsilon_c (% of garment vertices inside the body, exact
// signed distance; by area; and with the nearest-vertex approximation),
// epsilon_e and
// epsilon_a (mean % edge-length and area change against the garment at rest
// as its patches rebuild it),
// the StVK stretch and bending energies (J), the solver's cost, time.
#ifndef POLYFIT_DRAPE_SIMULATE_DRAPE_SIMULATION_H_
#define POLYFIT_DRAPE_SIMULATE_DRAPE_SIMULATION_H_

#include <stdexcept>
#include <string>
#include <vector>

#include "drape/body/body_shape.h"
#include "drape/garment/skin_transfer.h"
#include "drape/simulate/drape_solver.h"
#include "drape/simulate/network_relaxation.h"
#include "polyfit/util/status.h"

namespace polyfit {

class DrapeInputError : public Error {
 public:
  explicit DrapeInputError(const std::string& message, ErrorKind kind = ErrorKind::kInput) : Error(kind, message) {}
};

// The network's post-process (`onefit eval` applies it by default, `onefit
// drape --project`): vertices left inside the body projected out, then
// strain-limiting passes (DrapeSolver::PostProcessed).
inline constexpr double kNetworkProjectOffset = 2e-3;  // m
inline constexpr int kNetworkStrainLimitPasses = 10;

struct DrapeSimulationOptions {
  // The MakeHuman body folder (../shared/data/drape/body); empty for the
  // procedural capsule body.
  std::string body_dir;
  // Macro shape of the MakeHuman body (needs body_dir/targets_macro_young).
  BodyShape shape;
  // A MakeHuman garment (.mhclo, fitted to the shaped body by its binding)
  // or a mesh file (OBJ, PLY, ...) in the body's rest pose, metres.
  std::string garment_path;
  // A BVH clip; its units and the frame rate to resample to.
  std::string motion_path;
  double bvh_units_to_metres = 0.056444;
  std::string out_dir;
  // A trained OneFit model (`onefit train`): the network drapes every frame
  // instead of the reference drape's solve; the outputs are the same. Its
  // time per frame is the network's inference with the garment's skinning
  // and the relaxation (relax_passes).
  std::string model_path;
  // With a model: after each prediction, this many Levenberg-Marquardt
  // iterations of the reference drape from it (slides included, one
  // collision pass), timed with the inference; 0: the network alone.
  int refine_iterations = 0;
  // With a model that has a warp head and no refinement: each prediction's
  // warps re-solved for its jets by this many sweeps of
  // DrapeSolver::SolveWarps (the body posed for its collision term), timed
  // with the inference; 0: the network's own warps.
  int warp_sweeps = 0;
  // With warp_sweeps: each patch's translation re-solved with its warp (a
  // patch held off or pushed into the body moves back; better on every
  // measured clip on both counts than the warps alone: docs/benchmarks.md).
  bool warp_translations = true;
  // With warp_sweeps: each frame's re-solve starts from the network's
  // prediction plus this fraction of the change the last frame's re-solve
  // made to its own (warps and translations, in the patches' rest frames:
  // the correction moves with the body), so that the sweeps go on from
  // where the last frame's left off. Below 1 the correction's memory is
  // bounded (1 / (1 - carry) frames): carried whole, what the sweeps leave
  // unconstrained (patches sliding along one another) drifts over a clip.
  // 0: each frame from the prediction alone.
  double warp_carry = 0.95;
  // With a model, no refinement and no re-solved warps: each drape the
  // network predicts relaxed by this many passes (NetworkRelaxation, its
  // other settings its defaults), timed with the inference; 0: the
  // network's drape as predicted. Not after re-solved warps: they already
  // take the strain, under exact collisions, which the relaxation's
  // planes would undo (the walk 0.69% -> 1.45% inside for 7.6 -> 5.4%
  // strain).
  int relax_passes = NetworkRelaxationOptions{}.passes;
  // With warp_sweeps and a model that records its loss's collision settings
  // (OneFitModel::loss_collision): the re-solve, and the drape's metrics,
  // use those instead of solver.physics' (the warps it solves for are the
  // ones the network's loss asks for).
  bool collision_from_model = true;

  int first_frame = 0;
  int num_frames = -1;  // -1: to the clip's end
  // Frames that blend the rest pose into the first frame's, not written.
  int lead_in_frames = 10;
  int render_every = 10;  // 0: no renders
  int render_height = 480;
  bool write_meshes = true;
  // Post-process: move garment vertices left inside the body onto its
  // surface (plus this offset, m) in the written meshes and renders, and
  // measure those; the solver's own state is untouched. < 0: off.
  double project_offset = -1.0;
  // With project_offset: then this many strain-limiting passes
  // (drape/simulate/strain_limit.h) over the garment's edges.
  int strain_limit_passes = kNetworkStrainLimitPasses;
  // Keep every frame's garment (what is written) in the summary.
  bool keep_positions = false;

  DrapeSolverOptions solver;
  SkinTransferOptions skin;

  std::string Validate() const;
};

struct DrapeFrameSummary {
  int frame = 0;
  TerminationType termination_type = TerminationType::kConvergence;
  double time_s = 0.0;
  double solve_time_s = 0.0;
  int iterations = 0;
  int passes = 0;
  double inside_percent = 0.0;              // epsilon_c, exact signed distance
  double inside_unprojected_percent = 0.0;  // before project_offset's post-process (= inside_percent without it)
  // epsilon_c by area, before the post-process: the % of the garment's
  // area (lumped at its vertices) inside the body. Unlike the vertex count
  // it does not change with how densely a region is meshed.
  double inside_area_percent = 0.0;
  double inside_nearest_percent = 0.0;           // epsilon_c, nearest body vertex
  double min_distance = 0.0;                     // m, negative inside
  double edge_strain_percent = 0.0;              // epsilon_e
  double edge_strain_unprojected_percent = 0.0;  // before the post-process (= edge_strain_percent without it)
  double area_change_percent = 0.0;              // epsilon_a
  double max_edge_strain_percent = 0.0;
  double stretch_energy = 0.0;
  double bending_energy = 0.0;
  double cost = 0.0;
  bool finite = true;  // false: the solver failed and the previous state was kept
};

struct DrapeSimulationSummary {
  // kFailure when a frame's solve was not finite (those frames kept the
  // previous state); else kNoConvergence when a frame's iteration budget
  // ran out (the normal case), kConvergence when every solve converged.
  TerminationType termination_type = TerminationType::kConvergence;
  std::string message;
  int garment_vertices = 0;
  int garment_faces = 0;
  int patches = 0;
  // The patches' rest shape against the input garment (m); stretch is
  // measured against the former.
  double fit_error_mean = 0.0;
  double fit_error_max = 0.0;
  int frames = 0;
  std::vector<DrapeFrameSummary> records;
  // Per record, the garment as written (3 by #V); with keep_positions.
  std::vector<Eigen::Matrix3Xd> positions;
  double mean_time_s = 0.0;  // per clip frame
  double max_time_s = 0.0;
  double mean_inside_percent = 0.0;
  double max_inside_percent = 0.0;
  double mean_edge_strain_percent = 0.0;
  double max_edge_strain_percent = 0.0;  // the worst frame's mean
  double mean_area_change_percent = 0.0;
  bool all_finite = true;
  double total_time_s = 0.0;
  std::vector<std::string> warnings;
  // What the run took from elsewhere than its options (the model's
  // collision settings), for the user to see.
  std::vector<std::string> notes;

  std::string BriefReport() const;
};

// Throws DrapeInputError naming the file or option before anything is
// written; Error (kOutput) when an output cannot be written.
DrapeSimulationSummary RunDrapeSimulation(const DrapeSimulationOptions& options);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_SIMULATE_DRAPE_SIMULATION_H_
