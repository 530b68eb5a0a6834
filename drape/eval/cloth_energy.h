// Physical measures of a draped garment against its rest shape, for
// evaluation (not optimised): the StVK membrane and discrete-shell bending
// energies that SNUG and HOOD use, with their material, and the mean
// relative edge-length and area changes (epsilon_e, epsilon_a).
//
//   stretch  sum_f A_f (mu tr(E^2) + lambda / 2 tr(E)^2),
//            E = (F^T F - I) / 2, F = [x1 - x0, x2 - x0] D_m^-1 (3 by 2)
//   bending  k_bend sum_e 3 |e|^2 / (A_1 + A_2) (theta_e - theta_e^rest)^2
//            over interior edges, theta the signed dihedral angle
//   epsilon_e = 100 mean_e |l_e - L_e| / L_e,  epsilon_a = 100 mean_f |A_f - A_f^rest| / A_f^rest
#ifndef POLYFIT_DRAPE_EVAL_CLOTH_ENERGY_H_
#define POLYFIT_DRAPE_EVAL_CLOTH_ENERGY_H_

#include <array>
#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

// SNUG's and HOOD's cotton-like material.
struct ClothMaterial {
  double area_density = 0.2002;  // kg / m^2
  double mu = 2.36e4;            // Lame, N / m (membrane)
  double lambda = 4.44e4;        // Lame, N / m
  double bending = 3.96e-5;      // k_bend, N m
};

struct ClothRest {
  Eigen::Matrix3Xi faces;
  std::vector<double> face_area;              // #F, m^2
  std::vector<Eigen::Matrix2d> face_inverse;  // #F, D_m^-1
  std::vector<std::array<int, 2>> edges;      // unique edges
  std::vector<double> edge_length;            // #E rest lengths
  // Interior edges: (i, j) the edge, (k, l) the opposite corners of its two faces.
  std::vector<std::array<int, 4>> hinges;
  std::vector<double> hinge_angle;   // rest dihedral angles
  std::vector<double> hinge_weight;  // 3 |e|^2 / (A_1 + A_2)
  std::vector<double> vertex_area;   // #V, a third of each incident face
};

// Throws std::invalid_argument for a degenerate (zero-area) rest face.
ClothRest PrepareClothRest(const TriangleMesh& rest);

struct ClothMeasures {
  double stretch_energy = 0.0;       // J
  double bending_energy = 0.0;       // J
  double edge_strain_percent = 0.0;  // epsilon_e
  double area_change_percent = 0.0;  // epsilon_a
  double max_edge_strain_percent = 0.0;
};

// positions: 3 by #V, the rest mesh's vertices moved.
ClothMeasures MeasureCloth(const ClothRest& rest, const Eigen::Matrix3Xd& positions,
                           const ClothMaterial& material = {});

// Edge e's strain |l - L| / L at positions (3 by #V): epsilon_e's term.
inline double EdgeStrain(const ClothRest& rest, const Eigen::Matrix3Xd& positions, size_t e) {
  const double length = (positions.col(rest.edges[e][0]) - positions.col(rest.edges[e][1])).norm();
  return std::abs(length - rest.edge_length[e]) / rest.edge_length[e];
}

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_EVAL_CLOTH_ENERGY_H_
