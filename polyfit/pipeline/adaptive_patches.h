// Patches for a mesh fitted as it is (its vertices, or points resampled on
// its faces, never a subdivided mesh), refined where a jet cannot hold its patch: ACVD clusters,
// jets fitted to them, then every patch whose jet misses one of its
// vertices by more than max_fit_error (a fold, a cuff: no height field) is
// split in two (split_cluster.h) and all are refitted, for up to
// max_splits rounds. The draping garments are patched this way.
#ifndef POLYFIT_PIPELINE_ADAPTIVE_PATCHES_H_
#define POLYFIT_PIPELINE_ADAPTIVE_PATCHES_H_

#include <string>
#include <vector>

#include "polyfit/cluster/acvd_clustering.h"
#include "polyfit/mesh/triangle_mesh.h"
#include "polyfit/model/polyfit_model.h"
#include "polyfit/patch/jet_fit.h"

namespace polyfit {

struct AdaptivePatchOptions {
  // The initial clustering (its num_patches: the initial count; 0 for the
  // area rule).
  ClusteringOptions clustering;
  JetFitOptions jet;
  // Jets fitted to a barycentric grid of this many subdivisions per face
  // edge (FitPatchJets); 0: to the vertices.
  int face_subdivisions = 0;
  // The grid on the faces' Phong tessellation (FitPatchJets' curved_faces).
  bool curved_faces = false;
  // Metres (the mesh's units).
  double max_fit_error = 8e-3;
  int max_splits = 4;

  std::string Validate() const;
};

// The model of `mesh` (faces, face patches, memberships and their (u, v)).
// Throws std::invalid_argument on invalid options or mesh.
PolyFitModel FitAdaptivePatches(const AdaptivePatchOptions& options, const TriangleMesh& mesh);

// #patches: the largest distance from a member vertex to its patch's jet.
std::vector<double> PatchMaxFitErrors(const TriangleMesh& mesh, const PolyFitModel& model);

}  // namespace polyfit

#endif  // POLYFIT_PIPELINE_ADAPTIVE_PATCHES_H_
