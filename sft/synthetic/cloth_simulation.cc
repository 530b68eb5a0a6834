#include "sft/synthetic/cloth_simulation.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

#include "polyfit/mesh/unique_edges.h"
#include "sft/render/soft_rasterizer.h"

namespace polyfit {

double ClothObstacle::Distance(const Eigen::Vector3d& x) const {
  switch (kind) {
    case Kind::kSphere: return (x - point).norm() - radius;
    case Kind::kPlane: return normal.dot(x - point);
    case Kind::kNone: break;
  }
  return std::numeric_limits<double>::infinity();
}

std::string ClothSimulationOptions::Validate() const {
  if (!gravity.allFinite()) return "gravity must be finite";
  if (!(areal_density > 0.0)) return "areal_density must be > 0";
  if (!(bending_stiffness >= 0.0)) return "bending_stiffness must be >= 0";
  if (!(edge_compliance >= 0.0)) return "edge_compliance must be >= 0";
  if (!(air_density >= 0.0) || !(drag_coefficient >= 0.0) || !(skin_drag_coefficient >= 0.0)) {
    return "air_density and the drag coefficients must be >= 0";
  }
  if (!(damping >= 0.0)) return "damping must be >= 0";
  if (substeps < 1 || substeps > 10000) return "substeps must be in [1, 10000]";
  if (iterations < 1 || iterations > 100) return "iterations must be in [1, 100]";
  if (!(thickness >= 0.0)) return "thickness must be >= 0";
  return {};
}

namespace {

// The bending force -K x, K = B L' D L: L the cotangent Laplacian (its
// negative weights kept), D = diag(1 / A_v) over interior vertices. Its
// energy 0.5 x' K x = (B / 2) sum_v |(L x)_v|^2 / A_v is the plate's
// (B / 2) integral of (2 H)^2 for the mean curvature normal
// H n = (L x)_v / (2 A_v), and zero on the flat rest state. Boundary rows
// are left out: a flat boundary's Laplacian is not zero. Applied as L, then
// D, then L (L is symmetric), which is sparser than K itself.
Eigen::VectorXd BendingWeights(const TriangleMesh& rest, double stiffness) {
  const Eigen::VectorXd area = VertexAreas(rest);
  std::vector<bool> boundary(rest.num_vertices(), false);
  const std::vector<std::uint8_t> boundary_edges = MeshBoundaryEdgeFlags(rest.faces);
  for (int f = 0; f < rest.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      if (boundary_edges[f] & (1u << c)) boundary[rest.faces(c, f)] = boundary[rest.faces((c + 1) % 3, f)] = true;
    }
  }
  Eigen::VectorXd weight(rest.num_vertices());
  for (int v = 0; v < weight.size(); ++v) weight[v] = boundary[v] || !(area[v] > 0.0) ? 0.0 : stiffness / area[v];
  return weight;
}

Eigen::Vector3i Cell(const Eigen::Vector3d& x, double cell) {
  return Eigen::Vector3i(static_cast<int>(std::floor(x[0] / cell)), static_cast<int>(std::floor(x[1] / cell)),
                         static_cast<int>(std::floor(x[2] / cell)));
}

int CellHash(const Eigen::Vector3i& c, int table) {
  const std::int64_t h = (static_cast<std::int64_t>(c[0]) * 92837111) ^ (static_cast<std::int64_t>(c[1]) * 689287499) ^
                         (static_cast<std::int64_t>(c[2]) * 283923481);
  return static_cast<int>(((h % table) + table) % table);
}

}  // namespace

double ClothThickness(const TriangleMesh& rest, const ClothSimulationOptions& options) {
  if (options.thickness > 0.0) return options.thickness;
  const Eigen::Matrix2Xi edges = UniqueEdges(rest);
  double shortest = std::numeric_limits<double>::infinity();
  for (int e = 0; e < edges.cols(); ++e) {
    shortest = std::min(shortest, (rest.vertices.col(edges(0, e)) - rest.vertices.col(edges(1, e))).norm());
  }
  return 0.8 * shortest;
}

ClothSimulation::ClothSimulation(const TriangleMesh& rest, const ClothSimulationOptions& options)
    : options_(options), faces_(rest.faces), rest_(rest.vertices), x_(rest.vertices) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw std::invalid_argument("ClothSimulationOptions: " + problem);
  }
  if (const std::string problem = rest.Validate(); !problem.empty()) {
    throw std::invalid_argument("ClothSimulation: the rest mesh: " + problem);
  }
  const int n = rest.num_vertices();
  v_ = previous_ = Eigen::Matrix3Xd::Zero(3, n);
  pin_from_ = pin_to_ = x_;
  const Eigen::VectorXd mass = options.areal_density * VertexAreas(rest);
  inverse_mass_.resize(n);
  for (int v = 0; v < n; ++v) inverse_mass_[v] = mass[v] > 0.0 ? 1.0 / mass[v] : 0.0;
  edges_ = UniqueEdges(rest);
  rest_length_.resize(edges_.cols());
  for (int e = 0; e < edges_.cols(); ++e) {
    rest_length_[e] = (rest_.col(edges_(0, e)) - rest_.col(edges_(1, e))).norm();
  }
  thickness_ = ClothThickness(rest, options);
  laplacian_ = MakeCotangentLaplacian(rest, /*clamp_negative_weights=*/false);
  bending_weight_ = BendingWeights(rest, options.bending_stiffness);
  curvature_.resize(3, n);
  force_.resize(3, n);
}

void ClothSimulation::Pin(int vertex) {
  if (vertex < 0 || vertex >= x_.cols())
    throw std::out_of_range("ClothSimulation::Pin: no vertex " + std::to_string(vertex));
  if (inverse_mass_[vertex] == 0.0) return;
  inverse_mass_[vertex] = 0.0;
  v_.col(vertex).setZero();
  pin_from_.col(vertex) = pin_to_.col(vertex) = x_.col(vertex);
  pinned_.push_back(vertex);
}

void ClothSimulation::SetPinTarget(int vertex, const Eigen::Vector3d& target) {
  if (vertex < 0 || vertex >= x_.cols() || inverse_mass_[vertex] != 0.0) {
    throw std::invalid_argument("ClothSimulation::SetPinTarget: vertex " + std::to_string(vertex) + " is not pinned");
  }
  pin_to_.col(vertex) = target;
}

void ClothSimulation::AddAirForces(Eigen::Matrix3Xd* force) const {
  const double c = 0.5 * options_.air_density * options_.drag_coefficient;
  const double c_skin = 0.5 * options_.air_density * options_.skin_drag_coefficient;
  if (c == 0.0 && c_skin == 0.0) return;
  for (int f = 0; f < faces_.cols(); ++f) {
    const int a = faces_(0, f), b = faces_(1, f), d = faces_(2, f);
    const Eigen::Vector3d cross = (x_.col(b) - x_.col(a)).cross(x_.col(d) - x_.col(a));
    const double norm = cross.norm();
    if (norm <= 0.0) continue;
    const Eigen::Vector3d normal = cross / norm;
    const Eigen::Vector3d relative = wind_ - (v_.col(a) + v_.col(b) + v_.col(d)) / 3.0;
    const double un = relative.dot(normal);
    const Eigen::Vector3d tangential = relative - un * normal;
    const double third = 0.5 * norm / 3.0;  // a third of the area
    const Eigen::Vector3d share = third * (c * un * std::abs(un) * normal + c_skin * tangential.norm() * tangential);
    force->col(a) += share;
    force->col(b) += share;
    force->col(d) += share;
  }
}

void ClothSimulation::Predict(double h) {
  BendingForce(&force_);
  AddAirForces(&force_);
  const double keep = std::max(0.0, 1.0 - options_.damping * h);
  previous_ = x_;
  for (int v = 0; v < x_.cols(); ++v) {
    if (inverse_mass_[v] == 0.0) continue;
    v_.col(v) = keep * (v_.col(v) + h * (options_.gravity + inverse_mass_[v] * force_.col(v)));
    x_.col(v) += h * v_.col(v);
  }
}

// One XPBD pass: with the multiplier starting at zero every substep,
// d lambda = -C / (w_i + w_j + alpha / h^2).
void ClothSimulation::SolveEdges(double h) {
  const double alpha = options_.edge_compliance / (h * h);
  for (int e = 0; e < edges_.cols(); ++e) {
    const int i = edges_(0, e), j = edges_(1, e);
    const double w = inverse_mass_[i] + inverse_mass_[j];
    if (w == 0.0) continue;
    const Eigen::Vector3d d = x_.col(i) - x_.col(j);
    const double length = d.norm();
    if (length <= 0.0) continue;
    const Eigen::Vector3d step = (-(length - rest_length_[e]) / (w + alpha) / length) * d;
    x_.col(i) += inverse_mass_[i] * step;
    x_.col(j) -= inverse_mass_[j] * step;
  }
}

// Long-range attachments (Kim, Chentanez, Mueller 2012): a free vertex is
// kept within its rest distance of every pin (the rest being flat, the
// straight distance is the geodesic one). One Gauss-Seidel pass over a
// long chain leaves it stretched under its own weight; the tethers carry
// the weight to the pins at once.
void ClothSimulation::SolveTethers() {
  for (int v = 0; v < x_.cols(); ++v) {
    if (inverse_mass_[v] == 0.0) continue;
    for (int pin : pinned_) {
      const Eigen::Vector3d d = x_.col(v) - x_.col(pin);
      const double length = d.norm(), limit = (rest_.col(v) - rest_.col(pin)).norm();
      if (length > limit) x_.col(v) -= ((length - limit) / length) * d;
    }
  }
}

// Pairs closer than the thickness pushed apart; candidates from a spatial hash of cells one
// thickness wide, rebuilt every substep.
void ClothSimulation::SolveSelfCollisions() {
  const int n = static_cast<int>(x_.cols()), table = 2 * n + 1;
  cell_.resize(n);
  cell_start_.assign(table + 1, 0);
  cell_entries_.resize(n);
  for (int v = 0; v < n; ++v) {
    cell_[v] = Cell(x_.col(v), thickness_);
    ++cell_start_[CellHash(cell_[v], table)];
  }
  for (int k = 1; k <= table; ++k) cell_start_[k] += cell_start_[k - 1];
  for (int v = 0; v < n; ++v) cell_entries_[--cell_start_[CellHash(cell_[v], table)]] = v;
  for (int i = 0; i < n; ++i) {
    int seen[27];
    int seen_count = 0;
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int bucket = CellHash(cell_[i] + Eigen::Vector3i(dx, dy, dz), table);
          if (std::find(seen, seen + seen_count, bucket) != seen + seen_count) continue;
          seen[seen_count++] = bucket;
          for (int k = cell_start_[bucket]; k < cell_start_[bucket + 1]; ++k) {
            const int j = cell_entries_[k];
            if (j <= i) continue;
            const double w = inverse_mass_[i] + inverse_mass_[j];
            const Eigen::Vector3d d = x_.col(i) - x_.col(j);
            const double squared = d.squaredNorm();
            if (w == 0.0 || squared >= thickness_ * thickness_) continue;
            // Neighbours at rest are the edges' and bending's business: a
            // thickness between them would fight every sharp fold.
            if ((rest_.col(i) - rest_.col(j)).squaredNorm() < 4.0 * thickness_ * thickness_) continue;
            const double length = std::sqrt(squared);
            if (length <= 0.0) continue;
            const Eigen::Vector3d step = ((thickness_ - length) / (w * length)) * d;
            x_.col(i) += inverse_mass_[i] * step;
            x_.col(j) -= inverse_mass_[j] * step;
          }
        }
      }
    }
  }
}

// Vertices kept half a thickness outside. Coulomb friction, as positions
// (Macklin et al. 2014): a contact's tangential motion in this substep is
// stopped if it is under friction times the depth pushed out, else cut by
// that much.
void ClothSimulation::SolveObstacle() {
  if (obstacle_.kind == ClothObstacle::Kind::kNone) return;
  const double offset = 0.5 * thickness_;
  for (int v = 0; v < x_.cols(); ++v) {
    if (inverse_mass_[v] == 0.0) continue;
    const double distance = obstacle_.Distance(x_.col(v));
    if (distance >= offset) continue;
    const Eigen::Vector3d normal = obstacle_.kind == ClothObstacle::Kind::kSphere
                                       ? Eigen::Vector3d((x_.col(v) - obstacle_.point).normalized())
                                       : obstacle_.normal;
    const double depth = offset - distance;
    x_.col(v) += depth * normal;
    const Eigen::Vector3d moved = x_.col(v) - previous_.col(v);
    const Eigen::Vector3d slide = moved - moved.dot(normal) * normal;
    const double length = slide.norm(), limit = obstacle_.friction * depth;
    x_.col(v) -= length <= limit ? slide : (limit / length) * slide;
  }
}

void ClothSimulation::Advance(double seconds) {
  const int steps = options_.substeps;
  const double h = seconds / steps;
  for (int s = 0; s < steps; ++s) {
    Predict(h);
    const double along = static_cast<double>(s + 1) / steps;
    for (int v : pinned_) x_.col(v) = (1.0 - along) * pin_from_.col(v) + along * pin_to_.col(v);
    SolveTethers();
    // Contacts last but one: a last pass over the edges takes up what
    // they moved (without it, a cloth squeezed between layers or against
    // the obstacle at impact stretches by tens of percent).
    for (int pass = 1; pass < options_.iterations; ++pass) SolveEdges(h);
    if (options_.self_collision) SolveSelfCollisions();
    SolveObstacle();
    SolveEdges(h);
    v_ = (x_ - previous_) / h;
  }
  for (int v : pinned_) pin_from_.col(v) = pin_to_.col(v);
}

void ClothSimulation::SetPositions(const Eigen::Matrix3Xd& x) {
  if (x.cols() != x_.cols() || !x.allFinite()) {
    throw std::invalid_argument("ClothSimulation::SetPositions: 3 by " + std::to_string(x_.cols()) +
                                " finite positions expected");
  }
  x_ = previous_ = pin_from_ = pin_to_ = x;
  v_.setZero();
}

void ClothSimulation::BendingForce(Eigen::Matrix3Xd* force) {
  laplacian_.ApplyToColumns(x_, &curvature_);
  for (int v = 0; v < curvature_.cols(); ++v) curvature_.col(v) *= -bending_weight_[v];
  laplacian_.ApplyToColumns(curvature_, force);
}

double ClothSimulation::BendingEnergy() const {
  Eigen::Matrix3Xd curvature(3, x_.cols());
  laplacian_.ApplyToColumns(x_, &curvature);
  return 0.5 * (curvature.colwise().squaredNorm().transpose().array() * bending_weight_.array()).sum();
}

double ClothSimulation::MaxEdgeStrain() const {
  double worst = 0.0;
  for (int e = 0; e < edges_.cols(); ++e) {
    const double length = (x_.col(edges_(0, e)) - x_.col(edges_(1, e))).norm();
    worst = std::max(worst, std::abs(length / rest_length_[e] - 1.0));
  }
  return worst;
}

double ClothSimulation::MinSelfDistance() const {
  double closest = std::numeric_limits<double>::infinity();
  const double apart = 2.0 * thickness_;
  for (int i = 0; i < x_.cols(); ++i) {
    for (int j = i + 1; j < x_.cols(); ++j) {
      if ((rest_.col(i) - rest_.col(j)).squaredNorm() < apart * apart) continue;
      closest = std::min(closest, (x_.col(i) - x_.col(j)).norm());
    }
  }
  return closest;
}

double ClothSimulation::MinObstacleDistance() const {
  double closest = std::numeric_limits<double>::infinity();
  for (int v = 0; v < x_.cols(); ++v) closest = std::min(closest, obstacle_.Distance(x_.col(v)));
  return closest;
}

}  // namespace polyfit
