// Uniform patches: area-weighted centroidal Voronoi clustering of a mesh's
// faces, after Valette and Chassery (2004, "Approximated centroidal Voronoi
// diagrams for uniform polygonal mesh coarsening").
//
// Each face i has mass rho_i (its area) and centroid gamma_i. A clustering
// into C_1..C_K minimises
//   E = sum_k ( sum_{i in C_k} rho_i |gamma_i|^2 - |sum_{i in C_k} rho_i gamma_i|^2 / sum_{i in C_k} rho_i ),
// whose minimisers are compact cells of near-equal area. With a normal
// weight, gamma_i is extended by the face's unoriented normal (n n^T), which
// keeps sharp creases between patches. Seeds come from
// farthest-point sampling, cells from region growing on the face graph, and
// the energy is then lowered by greedy moves of boundary faces to a
// neighbouring cell until no move lowers it. A move that would cut its cell
// in two is refused, so every patch stays edge-connected.
#ifndef POLYFIT_CLUSTER_ACVD_CLUSTERING_H_
#define POLYFIT_CLUSTER_ACVD_CLUSTERING_H_

#include <cstdint>
#include <string>
#include <vector>

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

struct ClusteringOptions {
  // Patches wanted; 0 picks max(auto_min, min(auto_max, floor(A / auto_area)))
  // from the surface area A (the paper's rule for garments in metres).
  int num_patches = 0;
  double auto_area_per_patch = 0.008;
  int auto_min_patches = 100;
  int auto_max_patches = 400;
  // Weight of the faces' normals beside their positions in the energy
  // (0: plain ACVD). Cells then also have coherent normals, so that patches
  // stop at sharp creases rather than fold over them; the weight is in units
  // of the mean patch's size sqrt(A / K).
  double normal_weight = 1.0;
  // Passes of greedy boundary moves.
  int max_iterations = 100;
  // Connected pieces of the mesh smaller than this fraction of the mean patch
  // area get no patch of their own: they join the patch nearest to them.
  double debris_fraction = 0.25;
  std::uint64_t seed = 1;

  std::string Validate() const;
  // The patch count for a surface of this area.
  int ResolveNumPatches(double surface_area) const;
};

struct ClusteringSummary {
  int requested_patches = 0;
  int num_patches = 0;
  int num_components = 0;
  // Faces in pieces too small for a patch of their own.
  int num_debris_faces = 0;
  // True when the mesh is mostly unconnected triangles: cells were then
  // formed by k-means on face centroids and need not be connected.
  bool soup_fallback = false;
  int iterations = 0;
  long long num_moves = 0;
  double initial_energy = 0.0;
  double final_energy = 0.0;
  // Patch areas relative to their mean.
  double min_relative_area = 0.0;
  double max_relative_area = 0.0;
  double relative_area_stddev = 0.0;
  double time_s = 0.0;
};

// #F patch labels in [0, num_patches). Throws std::invalid_argument on
// invalid options or an invalid mesh.
std::vector<int> ClusterMeshFaces(const ClusteringOptions& options, const TriangleMesh& mesh,
                                  ClusteringSummary* summary = nullptr);

}  // namespace polyfit

#endif  // POLYFIT_CLUSTER_ACVD_CLUSTERING_H_
