// Distances from points to a triangle mesh's surface (CGAL AABB tree), and
// the sampling-free Chamfer distance built on them.
#ifndef POLYFIT_EVAL_SURFACE_DISTANCE_H_
#define POLYFIT_EVAL_SURFACE_DISTANCE_H_

#include <cstdint>
#include <memory>

#include <Eigen/Core>

#include "polyfit/eval/metrics.h"
#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

class SurfaceDistance {
 public:
  // Builds the tree over the mesh's faces; the mesh need not outlive it.
  explicit SurfaceDistance(const TriangleMesh& mesh);
  ~SurfaceDistance();
  SurfaceDistance(SurfaceDistance&&) noexcept;

  // Squared distance from a point to the nearest point of the surface.
  // Thread-safe.
  double SquaredDistance(const Eigen::Vector3d& point) const;
  // The closest point of the surface, and the face it lies on.
  Eigen::Vector3d ClosestPoint(const Eigen::Vector3d& point, int* face) const;
  // #points squared distances for the 3 by N points.
  Eigen::VectorXd SquaredDistances(const Eigen::Matrix3Xd& points, int num_threads = 1) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Like MeshChamferDistance, but each side's samples are measured to the
// other mesh's surface rather than to its samples, which removes the
// sampling floor (two independent samplings of one surface have a Chamfer
// distance of about 2 A / (pi N), not 0). Same unit-sphere normalisation.
ChamferDistance MeshToSurfaceChamferDistance(const TriangleMesh& reference, const TriangleMesh& candidate, int count,
                                             std::uint64_t seed, int num_threads = 1);

}  // namespace polyfit

#endif  // POLYFIT_EVAL_SURFACE_DISTANCE_H_
