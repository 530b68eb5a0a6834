// PolyFit on a mesh: optional subdivision, uniform patches, a jet per patch,
// reconstruction, and (optionally) its error against the input.
#ifndef POLYFIT_PIPELINE_FIT_MESH_H_
#define POLYFIT_PIPELINE_FIT_MESH_H_

#include <cstdint>
#include <limits>
#include <string>

#include "polyfit/cluster/acvd_clustering.h"
#include "polyfit/mesh/subdivision.h"
#include "polyfit/mesh/triangle_mesh.h"
#include "polyfit/model/polyfit_model.h"
#include "polyfit/model/reconstruction.h"
#include "polyfit/patch/jet_fit.h"

namespace polyfit {

struct MeshFitOptions {
  ClusteringOptions clustering;
  // Coarse meshes are subdivided until they have at least this many
  // vertices per patch (0: never), by at most max_subdivision_levels.
  int min_vertices_per_patch = 40;
  int max_subdivision_levels = 3;
  SubdivisionScheme subdivision_scheme = SubdivisionScheme::kMidpoint;
  JetFitOptions jet_fit;
  ReconstructionOptions reconstruction;
  // Score the reconstruction against the input (see MeshFitSummary).
  bool evaluate = true;
  int evaluation_samples = 10000;
  std::uint64_t evaluation_seed = 7;
  // Threads for the jet fits; 0: all hardware threads.
  int num_threads = 0;

  std::string Validate() const;
};

struct MeshFitSummary {
  int input_vertices = 0;
  int input_faces = 0;
  // The mesh that was clustered and fitted (after subdivision).
  int fitted_vertices = 0;
  int fitted_faces = 0;
  SubdivisionSummary subdivision;
  ClusteringSummary clustering;
  JetFitSummary jet_fit;
  ReconstructionSummary reconstruction;

  double subdivide_time_s = 0.0;
  double cluster_time_s = 0.0;
  double fit_time_s = 0.0;
  double reconstruct_time_s = 0.0;
  // Subdivision to reconstruction: what fitting the mesh costs.
  double total_time_s = 0.0;
  double evaluate_time_s = 0.0;

  // With evaluate, in the input's unit-sphere normalisation
  // (UnitSphereNormalization): Chamfer (the paper's protocol) between
  // evaluation_samples uniform samples on the input and on the
  // reconstruction; the RMS distance from
  // each fitted vertex to its reconstruction; the area-weighted mean
  // unoriented angle between each face's normal and its patch's jet normal
  // at the face's centroid. NaN without evaluate.
  double chamfer = std::numeric_limits<double>::quiet_NaN();
  // The same protocol between two independent samplings of the input: what
  // a perfect reconstruction scores.
  double chamfer_floor = std::numeric_limits<double>::quiet_NaN();
  // Samples measured to the other surface instead (no sampling floor):
  // MeshToSurfaceChamferDistance.
  double surface_chamfer = std::numeric_limits<double>::quiet_NaN();
  double height_rmse = std::numeric_limits<double>::quiet_NaN();
  double normal_error_deg = std::numeric_limits<double>::quiet_NaN();

  std::string BriefReport() const;
};

// Fits `mesh`. model and reconstruction may be null. Throws
// std::invalid_argument on invalid options or an invalid mesh.
MeshFitSummary FitMesh(const MeshFitOptions& options, const TriangleMesh& mesh, PolyFitModel* model,
                       TriangleMesh* reconstruction);

// Per patch, the vertices that lie on it (every corner of its faces) and
// their weights (lumped vertex areas), as the model's membership lists
// with the owner first. Exposed for tests and for OneFit's garments.
void BuildPatchMemberships(const TriangleMesh& mesh, const std::vector<int>& face_patch, PolyFitModel* model);

// Fits every patch's jet and sets its members' (u, v): model->face_patch
// and the memberships (BuildPatchMemberships) must be set. With
// face_subdivisions = 0 the jet is fitted to the members (area-weighted);
// with L > 0 to the points of a barycentric grid of L + 1 points per side
// on each of the patch's faces (each face's area shared among its points),
// so that a patch with fewer vertices than the jet has coefficients is
// still determined by its surface. With curved_faces the grid points lie on
// the faces' Phong tessellation (vertex normals), not on their planes: a
// coarse mesh's flat faces cut chords inside the smooth surface its
// vertices sample, and jets fitted to them sit inside it. Returns the fit's
// summary.
JetFitSummary FitPatchJets(const JetFitOptions& options, const TriangleMesh& mesh, PolyFitModel* model,
                           int face_subdivisions = 0, bool curved_faces = false);

}  // namespace polyfit

#endif  // POLYFIT_PIPELINE_FIT_MESH_H_
