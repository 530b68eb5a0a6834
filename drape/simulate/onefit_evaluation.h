// `onefit eval`: a trained model against the reference drape on one clip.
// Both drape the same garment through the same frames (the reference by
// its solve, the network by inference, the latter also post-processed:
// vertices left inside the body projected out); then, per frame and as
// means, epsilon_c (raw and post-processed), epsilon_e, epsilon_a, the
// network's distance to the reference drape (mean over vertices, mm), the
// frame-to-frame jitter (mean |x_t - 2 x_(t-1) + x_(t-2)|, mm: what the
// eye sees as shaking) and the time per frame. Writes into out_dir:
//   reference/, network/   each drape's outputs (as `onefit simulate`)
//   network_predicted/     with the relaxation on, the network's drape
//                          without it (a row of the table)
//   eval.csv               per-frame values of both
//   eval.md                the summary table
//   eval.png               epsilon_c, epsilon_e, distance and jitter per frame
#ifndef POLYFIT_DRAPE_SIMULATE_ONEFIT_EVALUATION_H_
#define POLYFIT_DRAPE_SIMULATE_ONEFIT_EVALUATION_H_

#include <string>
#include <vector>

#include "drape/simulate/drape_simulation.h"
#include "polyfit/util/status.h"

namespace polyfit {

struct OneFitEvaluationOptions {
  // Body, garment, clip, frames, out_dir and the solver's options, shared by
  // both drapes; model_path is the network's (required).
  DrapeSimulationOptions simulation;
  // The network's post-process: inside vertices moved onto the body plus
  // this offset (m).
  double project_offset = kNetworkProjectOffset;
  // ... then this many strain-limiting passes (0: the projection alone).
  int strain_limit_passes = kNetworkStrainLimitPasses;

  std::string Validate() const;
};

// One drape's means over the clip.
struct OneFitEvaluationRow {
  std::string name;
  double inside_percent = 0.0;            // epsilon_c, raw
  double inside_projected_percent = 0.0;  // after the post-process (network only; raw for the reference)
  double inside_area_percent = 0.0;       // epsilon_c by area, raw (resolution-agnostic)
  double edge_strain_percent = 0.0;       // epsilon_e (after the post-process, network only)
  double edge_strain_raw_percent = 0.0;   // epsilon_e before it
  double area_change_percent = 0.0;       // epsilon_a
  double distance_to_reference_mm = 0.0;  // mean over frames of the mean over vertices
  double max_distance_to_reference_mm = 0.0;
  double jitter_mm = 0.0;
  double ms_per_frame = 0.0;  // network: inference and post-process
};

struct OneFitEvaluationSummary {
  TerminationType termination_type = TerminationType::kConvergence;
  std::string message;
  int frames = 0;
  int garment_vertices = 0;
  OneFitEvaluationRow reference, network;
  // With the relaxation on: the network's drape as predicted, beside it.
  bool has_predicted = false;
  OneFitEvaluationRow predicted;
  std::vector<int> frame_numbers;
  std::vector<double> distance_mm;  // per frame

  // The table as Markdown.
  std::string Table() const;
  std::string BriefReport() const;
};

// Throws what RunDrapeSimulation throws (inputs named before anything is
// written).
OneFitEvaluationSummary EvaluateOneFitModel(const OneFitEvaluationOptions& options);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_SIMULATE_ONEFIT_EVALUATION_H_
