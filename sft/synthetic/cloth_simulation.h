// Position-based cloth for the generator's physical motions: XPBD (Macklin,
// Mueller, Chentanez 2016) with small steps (one constraint pass per
// substep, Macklin et al. 2019). Stiff edge-length constraints keep the
// cloth near-inextensible; a soft quadratic bending force (the cotangent
// Laplacian's, zero on the flat rest state) lets folds form; gravity, air
// drag and wind act per triangle; pinned vertices follow scripted targets
// and tether the others (long-range attachments); vertices keep a thickness apart from each other (self
// collision) and from an optional sphere or plane.
#ifndef POLYFIT_SFT_SYNTHETIC_CLOTH_SIMULATION_H_
#define POLYFIT_SFT_SYNTHETIC_CLOTH_SIMULATION_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "polyfit/mesh/cotangent_laplacian.h"
#include "polyfit/mesh/triangle_mesh.h"

namespace polyfit {

struct ClothObstacle {
  enum class Kind { kNone, kSphere, kPlane };
  Kind kind = Kind::kNone;
  // The sphere's centre, or a point of the plane.
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double radius = 0.0;
  // The plane's normal, toward its free side (unit).
  Eigen::Vector3d normal = Eigen::Vector3d::UnitY();
  // Coulomb friction coefficient.
  double friction = 0.5;

  // Signed distance of x from the obstacle's surface (> 0 outside).
  double Distance(const Eigen::Vector3d& x) const;
};

struct ClothSimulationOptions {
  // Acceleration of gravity (m/s^2), in the simulation's frame.
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 9.81, 0.0);
  // Mass per area (kg/m^2): cotton cloth.
  double areal_density = 0.15;
  // Bending stiffness (N m): a bending length (B / (rho g))^(1/3) of about
  // 1.5 cm, light cotton.
  double bending_stiffness = 5e-6;
  // Edge compliance (m/N; 0: inextensible up to the solver's convergence).
  double edge_compliance = 0.0;
  // Air: force per triangle 0.5 rho_air A (c_d (u.n)|u.n| n + c_f |u_t| u_t)
  // with u the wind relative to the triangle and u_t its part in the
  // triangle's plane (skin friction, which lets wind hold a flag out).
  double air_density = 1.2;
  double drag_coefficient = 1.0;
  double skin_drag_coefficient = 0.05;
  // Velocity damping (1/s) on every vertex.
  double damping = 0.05;
  // Substeps per call of Advance, and passes over the edges per substep
  // (the last after the contacts).
  int substeps = 150;
  int iterations = 3;
  // Vertices keep this far apart (m); 0: 0.8 of the shortest rest edge.
  // Above the largest gap in a layer, so a vertex cannot pass through it.
  double thickness = 0.0;
  bool self_collision = true;

  std::string Validate() const;
};

// The distance vertices keep apart: options.thickness, or if 0, 0.8 of
// the rest mesh's shortest edge.
double ClothThickness(const TriangleMesh& rest, const ClothSimulationOptions& options);

class ClothSimulation {
 public:
  // rest: the cloth at rest (its lengths and bending rest state, which is
  // taken as flat: its Laplacian is the reference) and its start.
  ClothSimulation(const TriangleMesh& rest, const ClothSimulationOptions& options);

  // A pinned vertex has infinite mass and follows its target, moved
  // linearly over each Advance from where it was.
  void Pin(int vertex);
  void SetPinTarget(int vertex, const Eigen::Vector3d& target);
  // Air velocity (m/s) until changed.
  void SetWind(const Eigen::Vector3d& wind) { wind_ = wind; }
  void SetObstacle(const ClothObstacle& obstacle) { obstacle_ = obstacle; }
  void SetDamping(double damping) { options_.damping = damping; }

  // Puts the cloth at x (3 by #V), at rest.
  void SetPositions(const Eigen::Matrix3Xd& x);

  // Moves the cloth on by `seconds` in options.substeps substeps.
  void Advance(double seconds);

  // 3 by #V.
  const Eigen::Matrix3Xd& positions() const { return x_; }
  const Eigen::Matrix3Xd& velocities() const { return v_; }
  double thickness() const { return thickness_; }
  // 0.5 x' K x summed over the coordinates (J): the plate's bending energy.
  double BendingEnergy() const;
  // max over edges of |l / l_rest - 1|.
  double MaxEdgeStrain() const;
  // The smallest distance between two vertices at least 2 thicknesses
  // apart at rest (m): below the thickness, the cloth has passed through
  // itself or nearly.
  double MinSelfDistance() const;
  // The smallest signed distance of a vertex from the obstacle (m; +inf
  // without one).
  double MinObstacleDistance() const;

 private:
  void Predict(double h);
  void SolveTethers();
  void SolveEdges(double h);
  void SolveSelfCollisions();
  void SolveObstacle();
  // force = -K x for the bending stiffness K (cloth_simulation.cc).
  void BendingForce(Eigen::Matrix3Xd* force);
  void AddAirForces(Eigen::Matrix3Xd* force) const;

  ClothSimulationOptions options_;
  Eigen::Matrix3Xi faces_;
  Eigen::Matrix2Xi edges_;          // 2 by #E
  Eigen::VectorXd rest_length_;     // #E
  Eigen::VectorXd inverse_mass_;    // #V (0: pinned)
  CotangentLaplacian laplacian_;    // negative weights kept
  Eigen::VectorXd bending_weight_;  // #V: B / A_v, 0 on the boundary
  Eigen::Matrix3Xd rest_;
  Eigen::Matrix3Xd x_, v_, previous_;
  Eigen::Matrix3Xd pin_from_, pin_to_;  // per vertex; used where pinned
  std::vector<int> pinned_;
  double thickness_ = 0.0;
  Eigen::Vector3d wind_ = Eigen::Vector3d::Zero();
  ClothObstacle obstacle_;
  // Buffers reused across substeps: forces, and the self-collision hash.
  Eigen::Matrix3Xd curvature_, force_;
  std::vector<Eigen::Vector3i> cell_;
  std::vector<int> cell_start_, cell_entries_;
};

}  // namespace polyfit

#endif  // POLYFIT_SFT_SYNTHETIC_CLOTH_SIMULATION_H_
