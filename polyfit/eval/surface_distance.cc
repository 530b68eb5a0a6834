// CGAL-heavy: the AABB tree lives in this translation unit only.
#include "polyfit/eval/surface_distance.h"

#include <vector>

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include "polyfit/eval/mesh_metrics.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {

namespace {
using Kernel = CGAL::Simple_cartesian<double>;
using Triangle = Kernel::Triangle_3;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, std::vector<Triangle>::const_iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
}  // namespace

struct SurfaceDistance::Impl {
  std::vector<Triangle> triangles;
  Tree tree;
};

SurfaceDistance::SurfaceDistance(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>()) {
  impl_->triangles.reserve(mesh.num_faces());
  auto point = [&mesh](int v) {
    return Kernel::Point_3(mesh.vertices(0, v), mesh.vertices(1, v), mesh.vertices(2, v));
  };
  for (int f = 0; f < mesh.num_faces(); ++f) {
    impl_->triangles.emplace_back(point(mesh.faces(0, f)), point(mesh.faces(1, f)), point(mesh.faces(2, f)));
  }
  impl_->tree.insert(impl_->triangles.cbegin(), impl_->triangles.cend());
  impl_->tree.build();
  impl_->tree.accelerate_distance_queries();
}

SurfaceDistance::~SurfaceDistance() = default;
SurfaceDistance::SurfaceDistance(SurfaceDistance&&) noexcept = default;

double SurfaceDistance::SquaredDistance(const Eigen::Vector3d& p) const {
  return impl_->tree.squared_distance(Kernel::Point_3(p.x(), p.y(), p.z()));
}

Eigen::Vector3d SurfaceDistance::ClosestPoint(const Eigen::Vector3d& p, int* face) const {
  const auto hit = impl_->tree.closest_point_and_primitive(Kernel::Point_3(p.x(), p.y(), p.z()));
  if (face != nullptr) *face = static_cast<int>(hit.second - impl_->triangles.cbegin());
  return Eigen::Vector3d(hit.first.x(), hit.first.y(), hit.first.z());
}

Eigen::VectorXd SurfaceDistance::SquaredDistances(const Eigen::Matrix3Xd& points, int num_threads) const {
  Eigen::VectorXd d(points.cols());
  ParallelFor(
      static_cast<int>(points.cols()), num_threads, [&](int, int i) { d[i] = SquaredDistance(points.col(i)); }, 256);
  return d;
}

ChamferDistance MeshToSurfaceChamferDistance(const TriangleMesh& reference, const TriangleMesh& candidate, int count,
                                             std::uint64_t seed, int num_threads) {
  const Normalization normalization = UnitSphereNormalization(reference.vertices);
  TriangleMesh a = reference, b = candidate;
  a.vertices = normalization.Apply(a.vertices);
  b.vertices = normalization.Apply(b.vertices);
  const Eigen::Matrix3Xd samples_a = SampleSurfaceUniform(a, count, seed);
  const Eigen::Matrix3Xd samples_b = SampleSurfaceUniform(b, count, seed + 1);
  ChamferDistance chamfer;
  chamfer.a_to_b = SurfaceDistance(b).SquaredDistances(samples_a, num_threads).mean();
  chamfer.b_to_a = SurfaceDistance(a).SquaredDistances(samples_b, num_threads).mean();
  return chamfer;
}

}  // namespace polyfit
