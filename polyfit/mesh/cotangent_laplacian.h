// The discrete Laplace–Beltrami operator of a triangle mesh (the linear
// finite-element stiffness matrix, cotangent weights), the lumped mass,
// and heat diffusion with them: a field spread over a set distance
// whatever the meshing, which a count of umbrella steps does not do (it
// reaches a distance in proportion to the edge length).
//
// Plain CSR arrays and CHOLMOD's C interface (SuiteSparse, which Ceres
// brings), not Eigen's sparse module: Eigen's sparse templates are weak
// symbols that the statically linked Ceres (built for baseline x86-64)
// instantiates too, and a copy built for the host CPU replaced Ceres' own
// in binaries that link both (the drape solver's Cholesky then freed
// memory it had not allocated).
#ifndef POLYFIT_MESH_COTANGENT_LAPLACIAN_H_
#define POLYFIT_MESH_COTANGENT_LAPLACIAN_H_

#include <vector>

#include <Eigen/Core>

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// (L f)_i = sum_j w_ij (f_i - f_j), w_ij = (cot a_ij + cot b_ij) / 2 over
// the angles opposite edge ij: symmetric, rows summing to zero. Degenerate
// faces add nothing. Negative weights (obtuse angles on both sides) are
// clamped to zero by default (positive semi-definite then), so that
// diffusion never makes a field overshoot its neighbours; a curvature
// (bending) measure keeps them.
struct CotangentLaplacian {
  // Vertex i's neighbours: neighbour[offsets[i] .. offsets[i + 1]), with
  // their weights w_ij >= 0.
  std::vector<int> offsets;
  std::vector<int> neighbour;
  std::vector<double> weight;

  int num_vertices() const { return static_cast<int>(offsets.size()) - 1; }
  // L f for #V by k fields.
  Eigen::MatrixXd Apply(const Eigen::MatrixXd& fields) const;
  // The same for points as columns: out (3 by #V, sized by the caller) =
  // (L x')', without allocation.
  void ApplyToColumns(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd* out) const;
  // #V by #V (tests, small meshes).
  Eigen::MatrixXd ToDense() const;
};

CotangentLaplacian MakeCotangentLaplacian(const TriangleMesh& mesh, bool clamp_negative_weights = true);

// Heat diffusion of fields over the mesh's surface for time t (m^2):
// df/dt = -rate M^-1 L f, in `substeps` implicit Euler steps
// (M + tau diag(rate) L) f' = M f, tau = t / substeps, all solved with one
// sparse Cholesky factorisation (symmetric once a row is divided by its
// rate). A step is spread over about sqrt(2 t) whatever
// the meshing; the boundary is insulated. fields: #V by k (one field per
// column). rate: #V, each vertex's diffusivity (1 everywhere if empty; 0
// holds a vertex's values). Vertices on no face keep their values.
// Throws std::invalid_argument on sizes that do not match, a negative t
// or rate, or substeps < 1; std::runtime_error where the system cannot be
// factored (out of memory).
Eigen::MatrixXd DiffuseHeat(const TriangleMesh& mesh, const Eigen::MatrixXd& fields, double t,
                            const std::vector<double>& rate = {}, int substeps = 8);

}  // namespace polyfit

#endif  // POLYFIT_MESH_COTANGENT_LAPLACIAN_H_
