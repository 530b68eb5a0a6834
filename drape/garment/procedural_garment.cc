#include "drape/garment/procedural_garment.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <vector>

#include "polyfit/eval/mesh_metrics.h"
#include "polyfit/mesh/decimation.h"
#include "polyfit/mesh/mesh_topology.h"

namespace polyfit {
namespace {

// The body's parts, by the joint that heads each one's subtree.
enum Part { kTorso = 0, kLeftArm, kRightArm, kLeftLeg, kRightLeg, kHeadAndNeck, kNumParts };

int FindJoint(const Skeleton& skeleton, const char* name) {
  const int j = skeleton.Find(name);
  if (j < 0) throw std::invalid_argument(std::string("MakeProceduralGarment: the rig has no joint '") + name + "'");
  return j;
}

// Arc length fraction along the chain a -> b -> c of the chain's point
// nearest x; beyond c it keeps growing past 1 (a hand or a foot).
double ChainParameter(const Eigen::Vector3d& x, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                      const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, bc = c - b;
  const double lab = ab.norm(), lbc = bc.norm();
  const double s1 = std::clamp((x - a).dot(ab) / (lab * lab), 0.0, 1.0);
  const double s2 = std::max((x - b).dot(bc) / (lbc * lbc), 0.0);
  const double d1 = (a + s1 * ab - x).squaredNorm();
  const double d2 = (b + std::min(s2, 1.0) * bc - x).squaredNorm();
  const double arc = d1 < d2 ? s1 * lab : lab + s2 * lbc;
  return arc / (lab + lbc);
}

// The faces' largest edge-connected piece, its vertices renumbered.
TriangleMesh LargestPiece(const TriangleMesh& skin, const std::vector<int>& faces) {
  TriangleMesh cut;
  cut.vertices = skin.vertices;
  cut.faces.resize(3, static_cast<Eigen::Index>(faces.size()));
  for (size_t i = 0; i < faces.size(); ++i) cut.faces.col(static_cast<Eigen::Index>(i)) = skin.faces.col(faces[i]);
  std::vector<int> labels;
  const int pieces = ConnectedComponents(FaceFaceAdjacency(cut), &labels);
  std::vector<int> size(pieces, 0);
  for (int l : labels) ++size[l];
  const int largest = static_cast<int>(std::max_element(size.begin(), size.end()) - size.begin());
  std::vector<int> index(skin.num_vertices(), -1);
  TriangleMesh piece;
  piece.faces.resize(3, size[largest]);
  int n = 0, f = 0;
  for (int i = 0; i < cut.num_faces(); ++i) {
    if (labels[i] != largest) continue;
    for (int c = 0; c < 3; ++c) {
      int& v = index[cut.faces(c, i)];
      if (v < 0) v = n++;
      piece.faces(c, f) = v;
    }
    ++f;
  }
  piece.vertices.resize(3, n);
  for (int v = 0; v < skin.num_vertices(); ++v) {
    if (index[v] >= 0) piece.vertices.col(index[v]) = skin.vertices.col(v);
  }
  return piece;
}

// Per skin vertex, whether the cut keeps it: classified by the part its
// skinning weights mostly lie in, then by its place along the limb's bone
// chain or by its height against the hem or waist.
std::vector<char> KeptSkinVertices(const SkinnedBody& body, const ProceduralGarmentOptions& options) {
  const Skeleton& skeleton = body.skeleton;
  const int num_joints = skeleton.num_joints();
  auto head = [&](const char* name) -> Eigen::Vector3d { return skeleton.rest_heads.col(FindJoint(skeleton, name)); };

  // Each joint's part, and whether it is a hand or a foot (or below one).
  std::vector<int> part(num_joints, kTorso);
  std::vector<char> extremity(num_joints, 0);
  const std::array<std::pair<const char*, int>, 5> roots = {{{"LeftArm", kLeftArm},
                                                             {"RightArm", kRightArm},
                                                             {"LeftUpLeg", kLeftLeg},
                                                             {"RightUpLeg", kRightLeg},
                                                             {"Neck", kHeadAndNeck}}};
  std::array<int, 5> root_joint{};
  for (size_t r = 0; r < roots.size(); ++r) root_joint[r] = FindJoint(skeleton, roots[r].first);
  const std::array<int, 4> ends = {FindJoint(skeleton, "LeftHand"), FindJoint(skeleton, "RightHand"),
                                   FindJoint(skeleton, "LeftFoot"), FindJoint(skeleton, "RightFoot")};
  for (int j = 0; j < num_joints; ++j) {
    for (int a = j; a >= 0; a = skeleton.parents[a]) {
      if (std::find(ends.begin(), ends.end(), a) != ends.end()) extremity[j] = 1;
      const auto r = std::find(root_joint.begin(), root_joint.end(), a);
      if (r != root_joint.end()) {
        part[j] = roots[r - root_joint.begin()].second;
        break;
      }
    }
  }
  const double hip_y = 0.5 * (head("LeftUpLeg").y() + head("RightUpLeg").y());
  const double spine_y = head("Spine1").y();
  const double hem_y = hip_y + options.hem * (spine_y - hip_y);
  const double waist_y = hip_y + options.waist * (spine_y - hip_y);
  const bool top = options.kind != ProceduralGarmentKind::kBottom;
  const bool bottom = options.kind != ProceduralGarmentKind::kTop;
  const std::array<std::array<Eigen::Vector3d, 3>, 4> chains = {{
      {head("LeftArm"), head("LeftForeArm"), head("LeftHand")},
      {head("RightArm"), head("RightForeArm"), head("RightHand")},
      {head("LeftUpLeg"), head("LeftLeg"), head("LeftFoot")},
      {head("RightUpLeg"), head("RightLeg"), head("RightFoot")},
  }};

  const TriangleMesh& skin = body.mesh;
  std::vector<char> keep(skin.num_vertices(), 0);
  for (int v = 0; v < skin.num_vertices(); ++v) {
    std::array<double, kNumParts> weight{};
    double extremity_weight = 0.0;
    for (int i = body.weight_offsets[v]; i < body.weight_offsets[v + 1]; ++i) {
      const int j = body.weight_joint[i];
      if (j < 0 || j >= num_joints) throw std::invalid_argument("MakeProceduralGarment: a skin weight names no joint");
      weight[part[j]] += body.weight_value[i];
      if (extremity[j]) extremity_weight += body.weight_value[i];
    }
    if (extremity_weight >= 0.5) continue;
    const int p = static_cast<int>(std::max_element(weight.begin(), weight.end()) - weight.begin());
    const Eigen::Vector3d x = skin.vertices.col(v);
    const double y = x.y();
    switch (p) {
      case kHeadAndNeck: break;
      case kLeftArm:
      case kRightArm: {
        const auto& c = chains[p - kLeftArm];
        keep[v] = top && ChainParameter(x, c[0], c[1], c[2]) <= options.sleeve;
        break;
      }
      case kLeftLeg:
      case kRightLeg: {
        const auto& c = chains[2 + p - kLeftLeg];
        keep[v] = bottom ? ChainParameter(x, c[0], c[1], c[2]) <= options.leg : y >= hem_y;
        break;
      }
      default: keep[v] = (!top || bottom || y >= hem_y) && (!bottom || top || y <= waist_y); break;
    }
  }
  return keep;
}

}  // namespace

std::string ProceduralGarmentOptions::Validate() const {
  auto unit = [](double x) { return x >= 0.0 && x <= 1.0; };
  if (!unit(sleeve) || !unit(leg)) return "sleeve and leg must be in [0, 1]";
  if (!unit(hem) || !unit(waist)) return "hem and waist must be in [0, 1]";
  if (!(offset >= 0.0 && offset <= 0.05)) return "offset must be in [0, 0.05] m";
  if (target_vertices != 0 && target_vertices < 100) return "target_vertices must be 0 or at least 100";
  return "";
}

std::string ProceduralGarmentOptions::Describe() const {
  char text[128];
  switch (kind) {
    case ProceduralGarmentKind::kTop:
      std::snprintf(text, sizeof(text), "top (sleeve %.2f, hem %.2f, %.1f mm)", sleeve, hem, offset * 1e3);
      break;
    case ProceduralGarmentKind::kBottom:
      std::snprintf(text, sizeof(text), "bottom (leg %.2f, waist %.2f, %.1f mm)", leg, waist, offset * 1e3);
      break;
    case ProceduralGarmentKind::kSuit:
      std::snprintf(text, sizeof(text), "suit (sleeve %.2f, leg %.2f, %.1f mm)", sleeve, leg, offset * 1e3);
      break;
  }
  return text;
}

ProceduralGarmentOptions DrawProceduralGarment(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  ProceduralGarmentOptions o;
  o.kind = static_cast<ProceduralGarmentKind>(std::uniform_int_distribution<int>(0, 2)(rng));
  o.sleeve = u(rng);
  o.leg = 0.15 + 0.85 * u(rng);
  o.hem = 0.6 * u(rng);
  o.waist = 0.2 + 0.4 * u(rng);
  o.offset = 0.003 + 0.012 * u(rng);
  return o;
}

TriangleMesh MakeProceduralGarment(const SkinnedBody& body, const ProceduralGarmentOptions& options) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("MakeProceduralGarment: " + problem);
  const std::vector<char> keep = KeptSkinVertices(body, options);
  const TriangleMesh& skin = body.mesh;
  std::vector<int> faces;
  for (int f = 0; f < skin.num_faces(); ++f) {
    if (keep[skin.faces(0, f)] && keep[skin.faces(1, f)] && keep[skin.faces(2, f)]) faces.push_back(f);
  }
  if (faces.empty()) throw std::invalid_argument("MakeProceduralGarment: the cut " + options.Describe() + " is empty");

  TriangleMesh garment = LargestPiece(skin, faces);
  garment.vertices += options.offset * VertexNormals(garment);
  if (options.target_vertices > 0 && options.target_vertices < garment.num_vertices()) {
    garment = DecimateMesh(garment, static_cast<double>(options.target_vertices) / garment.num_vertices());
  }
  return garment;
}

}  // namespace polyfit
