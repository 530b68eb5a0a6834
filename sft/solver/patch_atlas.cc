#include "sft/solver/patch_atlas.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <utility>

#include "polyfit/cluster/acvd_clustering.h"

namespace polyfit {

std::string PatchAtlasOptions::Validate() const {
  if (max_patches < 1) return "atlas.max_patches must be >= 1";
  if (initial_patches < 1) return "atlas.initial_patches must be >= 1";
  if (!(split_ratio >= 1.0)) return "atlas.split_ratio must be >= 1";
  if (!(split_significance > 0.0)) return "atlas.split_significance must be > 0";
  if (max_hidden_patches < 0) return "atlas.max_hidden_patches must be >= 0";
  if (min_hidden_vertices < 1) return "atlas.min_hidden_vertices must be >= 1";
  if (!(hidden_split_share >= 0.0 && hidden_split_share <= 0.5)) {
    return "atlas.hidden_split_share must be in [0, 0.5] (0: never)";
  }
  if (!(split_min_step_pixels >= 0.0) || !std::isfinite(split_min_step_pixels)) {
    return "atlas.split_min_step_pixels must be finite and >= 0";
  }
  if (children < 2 || children > 8) return "atlas.children must be in [2, 8]";
  if (min_vertices < 4) return "atlas.min_vertices must be >= 4";
  if (min_children != 0 && (min_children < 2 || min_children > children)) {
    return "atlas.min_children must be in [2, children], or 0 (children)";
  }
  if (!(seam_position_weight >= 0.0) || !(coarse_seam_position_weight >= 0.0) ||
      !(seen_seam_position_weight >= 0.0) || !(seam_normal_weight >= 0.0) ||
      !(seam_uv_weight >= 0.0) || !(coarse_seam_uv_weight >= 0.0) || !(seen_seam_uv_weight >= 0.0)) {
    return "atlas seam weights must be >= 0";
  }
  if (!(seam_uv_robust >= 0.0) || !std::isfinite(seam_uv_robust)) {
    return "atlas.seam_uv_robust must be finite and >= 0 (0: squared)";
  }
  if (!(seen_seam_uv_robust >= 0.0) || !std::isfinite(seen_seam_uv_robust)) {
    return "atlas.seen_seam_uv_robust must be finite and >= 0 (0: squared)";
  }
  return {};
}

int PatchAtlasOptions::ChildrenFor(int vertices) const {
  const int fit = std::min(children, vertices / min_vertices);
  return fit >= FewestChildren() ? fit : 0;
}

AtlasTerms GroupAtlasTerms(const JetDeformationModel& model, const std::vector<Eigen::Vector2i>& edges,
                           const std::vector<double>& rest_lengths, const HingeRest* hinges) {
  AtlasTerms terms;
  std::map<std::pair<int, int>, int> group_of;
  std::map<std::pair<int, int>, std::vector<Eigen::Vector2i>> seam_edges;
  for (size_t e = 0; e < edges.size(); ++e) {
    const int a = model.patch_of_vertex(edges[e][0]), b = model.patch_of_vertex(edges[e][1]);
    const std::pair<int, int> key(std::min(a, b), std::max(a, b));
    auto [it, added] = group_of.emplace(key, static_cast<int>(terms.edge_groups.size()));
    if (added) {
      AtlasTerms::EdgeGroup group;
      group.patches = a == b ? std::vector<int>{a} : std::vector<int>{key.first, key.second};
      terms.edge_groups.push_back(std::move(group));
    }
    terms.edge_groups[it->second].edges.push_back(edges[e]);
    terms.edge_groups[it->second].rest_lengths.push_back(rest_lengths[e]);
    if (a != b) seam_edges[key].push_back(edges[e]);
  }
  for (auto& [key, across] : seam_edges) terms.seams.push_back({key.first, key.second, std::move(across)});
  if (hinges == nullptr) return terms;
  std::map<std::vector<int>, int> hinge_group_of;
  for (size_t h = 0; h < hinges->hinges.size(); ++h) {
    const std::array<int, 4>& vertices = hinges->hinges[h].vertices;
    std::vector<int> patches;
    for (int v : vertices) patches.push_back(model.patch_of_vertex(v));
    std::sort(patches.begin(), patches.end());
    patches.erase(std::unique(patches.begin(), patches.end()), patches.end());
    auto [it, added] = hinge_group_of.emplace(patches, static_cast<int>(terms.hinge_groups.size()));
    if (added) terms.hinge_groups.push_back({patches, {}, {}, {}});
    AtlasTerms::HingeGroup& group = terms.hinge_groups[it->second];
    group.hinges.push_back(vertices);
    group.rest_angles.push_back(hinges->angles[h]);
    group.weights.push_back(hinges->weights[h]);
  }
  return terms;
}

std::vector<int> SplitPatchVertices(const TriangleMesh& mesh, const std::vector<int>& vertex_patch, int patch,
                                    int children) {
  // The patch's faces: those with at least two of their vertices in it.
  std::vector<int> faces, local(mesh.num_vertices(), -1);
  TriangleMesh sub;
  std::vector<Eigen::Vector3i> sub_faces;
  std::vector<int> sub_vertices;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    int inside = 0;
    for (int c = 0; c < 3; ++c) inside += vertex_patch[mesh.faces(c, f)] == patch;
    if (inside < 2) continue;
    faces.push_back(f);
    Eigen::Vector3i face;
    for (int c = 0; c < 3; ++c) {
      const int v = mesh.faces(c, f);
      if (local[v] < 0) {
        local[v] = static_cast<int>(sub_vertices.size());
        sub_vertices.push_back(v);
      }
      face[c] = local[v];
    }
    sub_faces.push_back(face);
  }
  if (static_cast<int>(faces.size()) < 2 * children) return {};
  sub.vertices.resize(3, sub_vertices.size());
  for (size_t v = 0; v < sub_vertices.size(); ++v) sub.vertices.col(v) = mesh.vertices.col(sub_vertices[v]);
  sub.faces.resize(3, sub_faces.size());
  for (size_t f = 0; f < sub_faces.size(); ++f) sub.faces.col(f) = sub_faces[f];
  ClusteringOptions clustering;
  clustering.num_patches = children;
  std::vector<int> labels;
  try {
    labels = ClusterMeshFaces(clustering, sub);
  } catch (const std::invalid_argument&) {
    return {};
  }
  // Each vertex of the patch goes to the cell most of its faces are in.
  std::vector<std::vector<int>> votes(mesh.num_vertices());
  for (size_t f = 0; f < faces.size(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int v = mesh.faces(c, faces[f]);
      if (vertex_patch[v] != patch) continue;
      if (votes[v].empty()) votes[v].assign(children, 0);
      ++votes[v][labels[f]];
    }
  }
  std::vector<int> child(mesh.num_vertices(), 0), count(children, 0);
  std::vector<Eigen::Vector3d> centre(children, Eigen::Vector3d::Zero());
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (votes[v].empty()) continue;
    child[v] = static_cast<int>(std::max_element(votes[v].begin(), votes[v].end()) - votes[v].begin());
    centre[child[v]] += mesh.vertices.col(v);
    ++count[child[v]];
  }
  for (int c = 0; c < children; ++c) {
    if (count[c] == 0) return {};
    centre[c] /= count[c];
  }
  // A vertex none of the patch's faces hold: the nearest cell.
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (vertex_patch[v] != patch || !votes[v].empty()) continue;
    double best = 1e300;
    for (int c = 0; c < children; ++c) {
      const double d = (mesh.vertices.col(v) - centre[c]).squaredNorm();
      if (d < best) {
        best = d;
        child[v] = c;
      }
    }
  }
  return child;
}

std::vector<int> PatchesToSplit(const PatchAtlasOptions& options, const JetDeformationModel& model,
                                const Eigen::VectorXd& squared, const Eigen::VectorXd& pixels,
                                const Eigen::VectorXd& floor_squared, const Eigen::VectorXd& floor_pixels,
                                std::vector<double>* ratios) {
  const int K = model.num_patches();
  std::vector<double> s(K, 0.0), w(K, 0.0), fs(K, 0.0), fw(K, 0.0);
  const std::vector<int> sizes = model.PatchSizes();
  for (int i = 0; i < model.num_vertices(); ++i) {
    const int p = model.patch_of_vertex(i);
    s[p] += squared[i];
    w[p] += pixels[i];
    fs[p] += floor_squared[i];
    fw[p] += floor_pixels[i];
  }
  std::vector<double> ratio(K, 0.0);
  for (int p = 0; p < K; ++p) {
    if (w[p] < 0.25 * fw[p] || fw[p] <= 0.0 || w[p] <= 0.0) continue;
    ratio[p] = (s[p] / w[p]) / std::max(fs[p] / fw[p], 1e-300);
  }
  if (ratios != nullptr) *ratios = ratio;
  std::vector<int> order(K);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return ratio[a] > ratio[b]; });
  std::vector<int> chosen;
  int patches = K;
  for (int p : order) {
    if (!(ratio[p] > options.split_ratio)) break;
    const int children = options.ChildrenFor(sizes[p]);
    if (children == 0) continue;
    if (patches + children - 1 > options.max_patches) break;
    chosen.push_back(p);
    patches += children - 1;
  }
  return chosen;
}

}  // namespace polyfit
