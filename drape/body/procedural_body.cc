#include "drape/body/procedural_body.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace polyfit {
namespace {

struct Capsule {
  int bone;
  Eigen::Vector3d a, b;  // axis from a (proximal) to b
  double radius;
};

// A closed capsule: a cylinder from a to b with hemispherical caps, rings
// along the axis; appended to `vertices` and `faces` with the proximal
// blend of `bone` into `parent` in `weights`.
void AppendCapsule(const Capsule& c, int parent, int segments, std::vector<Eigen::Vector3d>* vertices,
                   std::vector<Eigen::Vector3i>* faces, std::vector<std::vector<std::pair<int, double>>>* weights) {
  const Eigen::Vector3d axis = (c.b - c.a).normalized();
  const Eigen::Vector3d side = std::abs(axis.x()) < 0.9 ? axis.cross(Eigen::Vector3d::UnitX()).normalized()
                                                        : axis.cross(Eigen::Vector3d::UnitY()).normalized();
  const Eigen::Vector3d up = axis.cross(side);
  const double length = (c.b - c.a).norm();
  const int cap_rings = std::max(2, segments / 4), body_rings = std::max(2, static_cast<int>(length / c.radius) * 2);
  // Ring profile: (position along the axis from a, radius).
  std::vector<std::pair<double, double>> rings;
  for (int i = 1; i <= cap_rings; ++i) {  // the proximal cap, from its pole
    const double angle = M_PI / 2 * i / cap_rings;
    rings.emplace_back(-c.radius * std::cos(angle), c.radius * std::sin(angle));
  }
  for (int i = 1; i < body_rings; ++i) rings.emplace_back(length * i / body_rings, c.radius);
  for (int i = cap_rings; i >= 1; --i) {
    const double angle = M_PI / 2 * i / cap_rings;
    rings.emplace_back(length + c.radius * std::cos(angle), c.radius * std::sin(angle));
  }
  const int first = static_cast<int>(vertices->size());
  auto add = [&](const Eigen::Vector3d& p, double along) {
    vertices->push_back(p);
    // Proximal blend: fully the parent's at the joint, fully the bone's a
    // radius further along.
    const double t = std::clamp((along + 0.5 * c.radius) / (1.5 * c.radius), 0.0, 1.0);
    const double w = parent < 0 ? 1.0 : t * t * (3 - 2 * t);
    std::vector<std::pair<int, double>> list;
    if (w > 0.0) list.emplace_back(c.bone, w);
    if (w < 1.0) list.emplace_back(parent, 1.0 - w);
    weights->push_back(list);
  };
  add(c.a - c.radius * axis, -c.radius);  // pole at a
  for (const auto& [along, radius] : rings) {
    for (int s = 0; s < segments; ++s) {
      const double phi = 2 * M_PI * s / segments;
      add(c.a + along * axis + radius * (std::cos(phi) * side + std::sin(phi) * up), along);
    }
  }
  add(c.b + c.radius * axis, length + c.radius);  // pole at b
  const int pole_a = first, pole_b = static_cast<int>(vertices->size()) - 1;
  const int num_rings = static_cast<int>(rings.size());
  auto ring = [&](int r, int s) { return first + 1 + r * segments + (s % segments); };
  for (int s = 0; s < segments; ++s) faces->emplace_back(pole_a, ring(0, s + 1), ring(0, s));
  for (int r = 0; r + 1 < num_rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      faces->emplace_back(ring(r, s), ring(r, s + 1), ring(r + 1, s + 1));
      faces->emplace_back(ring(r, s), ring(r + 1, s + 1), ring(r + 1, s));
    }
  }
  for (int s = 0; s < segments; ++s) faces->emplace_back(pole_b, ring(num_rings - 1, s), ring(num_rings - 1, s + 1));
}

}  // namespace

SkinnedBody MakeProceduralBody(int segments) {
  if (segments < 6) throw std::invalid_argument("MakeProceduralBody: segments must be >= 6");
  SkinnedBody body;
  Skeleton& s = body.skeleton;
  const double d = std::sqrt(0.5);
  const Eigen::Vector3d arm_down(d, -d, 0.0);
  const Eigen::Vector3d mirror(-1.0, 1.0, 1.0);
  struct Joint {
    const char* name;
    int parent;
    Eigen::Vector3d head;
  };
  const Eigen::Vector3d l_shoulder(0.18, 0.45, 0.0), l_elbow = l_shoulder + 0.28 * arm_down;
  const std::vector<Joint> joints = {
      {"Hips", -1, {0, 0, 0}},
      {"Spine", 0, {0, 0.25, 0}},
      {"Neck", 1, {0, 0.52, 0}},
      {"Head", 2, {0, 0.6, 0}},
      {"LeftArm", 1, l_shoulder},
      {"LeftForeArm", 4, l_elbow},
      {"RightArm", 1, l_shoulder.cwiseProduct(mirror)},
      {"RightForeArm", 6, l_elbow.cwiseProduct(mirror)},
      {"LeftUpLeg", 0, {0.1, -0.05, 0}},
      {"LeftLeg", 8, {0.1, -0.5, 0}},
      {"RightUpLeg", 0, {-0.1, -0.05, 0}},
      {"RightLeg", 10, {-0.1, -0.5, 0}},
  };
  s.rest_heads.resize(3, static_cast<Eigen::Index>(joints.size()));
  for (size_t j = 0; j < joints.size(); ++j) {
    s.names.emplace_back(joints[j].name);
    s.parents.push_back(joints[j].parent);
    s.rest_heads.col(j) = joints[j].head;
  }
  const std::vector<Capsule> capsules = {
      {1, {0, -0.02, 0}, {0, 0.5, 0}, 0.14},  // the torso: hips blending into the spine
      {3, {0, 0.66, 0}, {0, 0.76, 0}, 0.1},   // head
      {4, l_shoulder, l_elbow, 0.045},
      {5, l_elbow, l_elbow + 0.26 * arm_down, 0.04},
      {6, l_shoulder.cwiseProduct(mirror), l_elbow.cwiseProduct(mirror), 0.045},
      {7, l_elbow.cwiseProduct(mirror), (l_elbow + 0.26 * arm_down).cwiseProduct(mirror), 0.04},
      {8, {0.1, -0.05, 0}, {0.1, -0.5, 0}, 0.07},
      {9, {0.1, -0.5, 0}, {0.1, -0.9, 0}, 0.055},
      {10, {-0.1, -0.05, 0}, {-0.1, -0.5, 0}, 0.07},
      {11, {-0.1, -0.5, 0}, {-0.1, -0.9, 0}, 0.055},
  };
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> faces;
  std::vector<std::vector<std::pair<int, double>>> weights;
  for (const Capsule& c : capsules) AppendCapsule(c, s.parents[c.bone], segments, &vertices, &faces, &weights);
  body.mesh.vertices.resize(3, static_cast<Eigen::Index>(vertices.size()));
  for (size_t v = 0; v < vertices.size(); ++v) body.mesh.vertices.col(v) = vertices[v];
  body.mesh.faces.resize(3, static_cast<Eigen::Index>(faces.size()));
  for (size_t f = 0; f < faces.size(); ++f) body.mesh.faces.col(f) = faces[f];
  body.base_vertices = body.mesh.vertices;
  body.weight_offsets.assign(1, 0);
  for (const auto& list : weights) {
    for (const auto& [j, w] : list) {
      body.weight_joint.push_back(j);
      body.weight_value.push_back(w);
    }
    body.weight_offsets.push_back(static_cast<int>(body.weight_joint.size()));
  }
  return body;
}

}  // namespace polyfit
