// Rebuilding a mesh from a PolyFit model: each vertex evaluated on the jet
// surface of its patch, with a choice of how seams between patches are
// reconciled.
#ifndef POLYFIT_MODEL_RECONSTRUCTION_H_
#define POLYFIT_MODEL_RECONSTRUCTION_H_

#include <string>

#include <Eigen/Core>

#include "polyfit/model/polyfit_model.h"

namespace polyfit {

enum class SeamMode {
  // Each vertex from its owner patch only: neighbouring patches may leave
  // gaps along their shared boundary.
  kOwner,
  // A boundary vertex is the mean of its points on every patch it lies on:
  // the mesh is watertight where the input was.
  kAverage,
};

struct ReconstructionOptions {
  SeamMode seam_mode = SeamMode::kAverage;
  // Laplacian smoothing of boundary vertices only (the paper's light
  // smoothing along patch boundaries): x <- x + step * (mean of neighbours - x).
  int boundary_smoothing_iterations = 0;
  double boundary_smoothing_step = 0.5;

  std::string Validate() const;
};

struct ReconstructionSummary {
  int num_boundary_vertices = 0;
  // Over boundary vertices: the largest distance between the points the
  // patches give for the same vertex (before reconciliation).
  double mean_seam_gap = 0.0;
  double max_seam_gap = 0.0;
};

// 3 by #V positions. Throws std::invalid_argument on invalid options or
// model.
Eigen::Matrix3Xd ReconstructVertices(const PolyFitModel& model, const ReconstructionOptions& options,
                                     ReconstructionSummary* summary = nullptr);

}  // namespace polyfit

#endif  // POLYFIT_MODEL_RECONSTRUCTION_H_
