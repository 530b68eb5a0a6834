#include "drape/eval/cloth_energy.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "cost_functions/hinge_bending.h"
#include "polyfit/mesh/hinge_rest.h"
#include "polyfit/mesh/unique_edges.h"

namespace polyfit {

ClothRest PrepareClothRest(const TriangleMesh& rest) {
  ClothRest out;
  out.faces = rest.faces;
  const int nf = static_cast<int>(rest.faces.cols());
  out.vertex_area.assign(rest.num_vertices(), 0.0);
  for (int f = 0; f < nf; ++f) {
    const Eigen::Vector3i t = rest.faces.col(f);
    const Eigen::Vector3d x0 = rest.vertices.col(t[0]), x1 = rest.vertices.col(t[1]), x2 = rest.vertices.col(t[2]);
    const Eigen::Vector3d e1 = x1 - x0, e2 = x2 - x0;
    const Eigen::Vector3d normal = e1.cross(e2);
    const double area = 0.5 * normal.norm();
    if (!(area > 0.0)) throw std::invalid_argument("PrepareClothRest: face " + std::to_string(f) + " has zero area");
    const Eigen::Vector3d tangent = e1.normalized();
    const Eigen::Vector3d bitangent = normal.cross(e1).normalized();
    Eigen::Matrix2d dm;
    dm << e1.dot(tangent), e2.dot(tangent), e1.dot(bitangent), e2.dot(bitangent);
    out.face_area.push_back(area);
    out.face_inverse.push_back(dm.inverse());
    for (int c = 0; c < 3; ++c) out.vertex_area[t[c]] += area / 3.0;
  }
  const Eigen::Matrix2Xi edges = UniqueEdges(rest);
  for (Eigen::Index e = 0; e < edges.cols(); ++e) {
    out.edges.push_back({edges(0, e), edges(1, e)});
    out.edge_length.push_back((rest.vertices.col(edges(0, e)) - rest.vertices.col(edges(1, e))).norm());
  }
  HingeRest hinges = MeasureHingeRest(rest);
  for (const MeshHinge& hinge : hinges.hinges) out.hinges.push_back(hinge.vertices);
  out.hinge_angle = std::move(hinges.angles);
  out.hinge_weight = std::move(hinges.weights);
  return out;
}

ClothMeasures MeasureCloth(const ClothRest& rest, const Eigen::Matrix3Xd& x, const ClothMaterial& material) {
  ClothMeasures m;
  const int nf = static_cast<int>(rest.faces.cols());
  double area_change = 0.0;
  for (int f = 0; f < nf; ++f) {
    const Eigen::Vector3i t = rest.faces.col(f);
    Eigen::Matrix<double, 3, 2> ds;
    ds.col(0) = x.col(t[1]) - x.col(t[0]);
    ds.col(1) = x.col(t[2]) - x.col(t[0]);
    const Eigen::Matrix<double, 3, 2> deformation = ds * rest.face_inverse[f];
    const Eigen::Matrix2d strain = 0.5 * (deformation.transpose() * deformation - Eigen::Matrix2d::Identity());
    const double trace = strain.trace();
    m.stretch_energy +=
        rest.face_area[f] * (material.mu * (strain * strain).trace() + 0.5 * material.lambda * trace * trace);
    const double area = 0.5 * ds.col(0).cross(ds.col(1)).norm();
    area_change += std::abs(area - rest.face_area[f]) / rest.face_area[f];
  }
  double edge_strain = 0.0;
  for (size_t e = 0; e < rest.edges.size(); ++e) {
    const double strain = EdgeStrain(rest, x, e);
    edge_strain += strain;
    m.max_edge_strain_percent = std::max(m.max_edge_strain_percent, 100.0 * strain);
  }
  for (size_t h = 0; h < rest.hinges.size(); ++h) {
    const std::array<int, 4>& k = rest.hinges[h];
    const double angle =
        SignedDihedralAngle(x.col(k[0]).data(), x.col(k[1]).data(), x.col(k[2]).data(), x.col(k[3]).data());
    const double d = angle - rest.hinge_angle[h];
    m.bending_energy += material.bending * rest.hinge_weight[h] * d * d;
  }
  m.edge_strain_percent = rest.edges.empty() ? 0.0 : 100.0 * edge_strain / static_cast<double>(rest.edges.size());
  m.area_change_percent = nf == 0 ? 0.0 : 100.0 * area_change / nf;
  return m;
}

}  // namespace polyfit
