#include "polyfit/pipeline/adaptive_patches.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "polyfit/cluster/split_cluster.h"
#include "polyfit/mesh/face_centroids.h"
#include "polyfit/mesh/per_face_normals.h"
#include "polyfit/pipeline/fit_mesh.h"

namespace polyfit {

std::string AdaptivePatchOptions::Validate() const {
  if (std::string p = clustering.Validate(); !p.empty()) return "clustering: " + p;
  if (jet.order < 1 || jet.order > kMaxJetOrder)
    return "jet.order must be in [1, " + std::to_string(kMaxJetOrder) + "]";
  if (!(max_fit_error > 0.0)) return "max_fit_error must be > 0";
  if (max_splits < 0) return "max_splits must be >= 0";
  if (face_subdivisions < 0 || face_subdivisions > 16) return "face_subdivisions must be in [0, 16]";
  return {};
}

std::vector<double> PatchMaxFitErrors(const TriangleMesh& mesh, const PolyFitModel& model) {
  std::vector<double> error(model.num_patches(), 0.0);
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    for (int k : model.memberships(v)) {
      const int p = model.membership_patch[k];
      error[p] = std::max(error[p], (model.MembershipPoint(k) - mesh.vertices.col(v)).norm());
    }
  }
  return error;
}

PolyFitModel FitAdaptivePatches(const AdaptivePatchOptions& options, const TriangleMesh& mesh) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw std::invalid_argument("AdaptivePatchOptions: " + problem);
  }
  PolyFitModel model;
  model.face_patch = ClusterMeshFaces(options.clustering, mesh);
  model.faces = mesh.faces;
  const Eigen::Matrix3Xd normals = PerFaceNormals(mesh);
  const Eigen::Matrix3Xd centroids = FaceCentroids(mesh);
  for (int round = 0;; ++round) {
    BuildPatchMemberships(mesh, model.face_patch, &model);
    FitPatchJets(options.jet, mesh, &model, options.face_subdivisions, options.curved_faces);
    if (round == options.max_splits) break;
    const std::vector<double> error = PatchMaxFitErrors(mesh, model);
    std::vector<std::vector<int>> faces(model.num_patches());
    for (int f = 0; f < mesh.num_faces(); ++f) faces[model.face_patch[f]].push_back(f);
    int next = model.num_patches();
    for (int p = 0; p < model.num_patches(); ++p) {
      if (error[p] <= options.max_fit_error) continue;
      const std::vector<int> side = SplitClusterInTwo(normals, centroids, faces[p]);
      if (side.empty()) continue;
      for (size_t i = 0; i < faces[p].size(); ++i) {
        if (side[i] == 1) model.face_patch[faces[p][i]] = next;
      }
      ++next;
    }
    if (next == model.num_patches()) break;
  }
  return model;
}

}  // namespace polyfit
