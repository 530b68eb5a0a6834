// A PolyFit model of a mesh: its patches (frame and jet each), the mesh's
// faces, and for every vertex the patches it lies on with its (u, v) in
// each, so that the model alone rebuilds the surface (reconstruction.h).
// Saved in the versioned binary format of docs/model-format.md.
#ifndef POLYFIT_MODEL_POLYFIT_MODEL_H_
#define POLYFIT_MODEL_POLYFIT_MODEL_H_

#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "polyfit/patch/jet_patch.h"
#include "polyfit/util/index_range.h"
#include "polyfit/util/status.h"

namespace polyfit {

inline constexpr int kPolyFitModelVersion = 1;

// A vertex on the boundary between two patches, with its parameters in
// both: OneFit's boundary-continuity term compares the two jets there.
struct PatchBoundaryPoint {
  int vertex = 0;
  int patch_a = 0;  // patch_a < patch_b
  int patch_b = 0;
  Eigen::Vector2d uv_a = Eigen::Vector2d::Zero();
  Eigen::Vector2d uv_b = Eigen::Vector2d::Zero();
};

struct PolyFitModel {
  std::vector<JetPatch> patches;
  // 3 by #F: the fitted mesh's faces.
  Eigen::Matrix3Xi faces;
  // #F: the patch of each face.
  std::vector<int> face_patch;
  // The patches of vertex v are memberships [membership_offsets[v],
  // membership_offsets[v + 1]); the first is its owner (the patch with the
  // most of its incident area). #V + 1 offsets.
  std::vector<int> membership_offsets;
  std::vector<int> membership_patch;
  // 2 by #memberships: the vertex's (u, v) in that patch's frame.
  Eigen::Matrix2Xd membership_uv;

  int num_vertices() const { return membership_offsets.empty() ? 0 : static_cast<int>(membership_offsets.size()) - 1; }
  int num_patches() const { return static_cast<int>(patches.size()); }
  int num_memberships() const { return static_cast<int>(membership_patch.size()); }
  // The memberships of vertex v, owner first: `for (int k : memberships(v))`.
  IndexRange memberships(int v) const { return {membership_offsets[v], membership_offsets[v + 1]}; }
  int owner(int v) const { return membership_patch[membership_offsets[v]]; }
  bool is_boundary(int v) const { return membership_offsets[v + 1] - membership_offsets[v] > 1; }
  // Membership k's (u, v) in its patch, and its point in the world.
  Eigen::Vector2d uv(int k) const { return membership_uv.col(k); }
  Eigen::Vector3d MembershipPoint(int k) const {
    return patches[membership_patch[k]].PointInWorld(membership_uv(0, k), membership_uv(1, k));
  }
  // The membership of vertex v in patch p, or -1.
  int FindMembership(int v, int p) const {
    for (int k : memberships(v)) {
      if (membership_patch[k] == p) return k;
    }
    return -1;
  }

  // Every (vertex, pair of its patches), ordered by vertex.
  std::vector<PatchBoundaryPoint> BoundaryPoints() const;
  // Patches sharing a vertex with each patch: neighbours of p are
  // adjacency[p], sorted.
  std::vector<std::vector<int>> PatchAdjacency() const;

  // Empty when consistent (sizes, indices in range, finite numbers), else
  // the first problem found.
  std::string Validate() const;
};

class ModelIoError : public Error {
 public:
  explicit ModelIoError(const std::string& message, ErrorKind kind = ErrorKind::kInput) : Error(kind, message) {}
};

// Throws ModelIoError naming the file; writes atomically.
void SavePolyFitModel(const std::string& path, const PolyFitModel& model);
PolyFitModel LoadPolyFitModel(const std::string& path);

}  // namespace polyfit

#endif  // POLYFIT_MODEL_POLYFIT_MODEL_H_
