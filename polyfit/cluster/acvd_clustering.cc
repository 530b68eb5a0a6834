#include "polyfit/cluster/acvd_clustering.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <queue>
#include <random>
#include <stdexcept>

#include <Eigen/Geometry>

#include "polyfit/cluster/kmeans.h"
#include "polyfit/eval/kd_tree.h"
#include "polyfit/mesh/face_centroids.h"
#include "polyfit/mesh/mesh_topology.h"
#include "polyfit/mesh/per_face_normals.h"

namespace polyfit {

std::string ClusteringOptions::Validate() const {
  if (num_patches < 0) return "num_patches must be >= 0 (0: automatic)";
  if (num_patches == 0) {
    if (!(auto_area_per_patch > 0.0)) return "auto_area_per_patch must be > 0";
    if (auto_min_patches < 1 || auto_max_patches < auto_min_patches) {
      return "need 1 <= auto_min_patches <= auto_max_patches";
    }
  }
  if (max_iterations < 0) return "max_iterations must be >= 0";
  if (!(debris_fraction >= 0.0)) return "debris_fraction must be >= 0";
  if (!(normal_weight >= 0.0)) return "normal_weight must be >= 0";
  return {};
}

int ClusteringOptions::ResolveNumPatches(double surface_area) const {
  if (num_patches > 0) return num_patches;
  const double by_area = std::floor(surface_area / auto_area_per_patch);
  return static_cast<int>(std::max<double>(auto_min_patches, std::min<double>(auto_max_patches, by_area)));
}

namespace {

// A face's point in the clustering space: its centroid, then its unoriented
// normal as the 6 independent entries of n n^T (scaled so that the squared
// distance between two of them is 2 (1 - (n . m)^2)), times a weight.
using Feature = Eigen::Matrix<double, 9, 1>;

// Cell sums: mass m = sum rho, first moment s = sum rho gamma.
struct Cell {
  double mass = 0.0;
  Feature moment = Feature::Zero();
  int count = 0;
  double Energy() const { return mass > 0.0 ? -moment.squaredNorm() / mass : 0.0; }
};

double TotalEnergy(const std::vector<Cell>& cells) {
  double e = 0.0;
  for (const Cell& c : cells) e += c.Energy();
  return e;
}

// Splits `total` into parts proportional to `weights` (largest
// remainders), then raises empty parts to 1 at the expense of the largest.
std::vector<int> Apportion(int total, const std::vector<double>& weights) {
  const int n = static_cast<int>(weights.size());
  std::vector<int> parts(n, 0);
  const double sum = std::accumulate(weights.begin(), weights.end(), 0.0);
  std::vector<std::pair<double, int>> remainders;
  int assigned = 0;
  for (int i = 0; i < n; ++i) {
    const double share = total * weights[i] / sum;
    parts[i] = static_cast<int>(std::floor(share));
    assigned += parts[i];
    remainders.emplace_back(share - parts[i], i);
  }
  std::sort(remainders.rbegin(), remainders.rend());
  for (int k = 0; k < total - assigned && k < n; ++k) ++parts[remainders[k].second];
  for (int i = 0; i < n; ++i) {
    if (parts[i] > 0) continue;
    parts[i] = 1;
    const int largest = static_cast<int>(std::max_element(parts.begin(), parts.end()) - parts.begin());
    if (parts[largest] > 1) --parts[largest];
  }
  return parts;
}

// Farthest-point seeds among `faces` (a random area-weighted subset of them
// when there are many, which keeps seeding linear in the mesh size).
std::vector<int> FarthestPointSeeds(const std::vector<int>& faces, int count, const Eigen::Matrix3Xd& centroids,
                                    const Eigen::VectorXd& areas, std::mt19937_64& rng) {
  std::vector<int> candidates;
  const size_t max_candidates = std::max<size_t>(64, 40 * static_cast<size_t>(count));
  if (faces.size() <= max_candidates) {
    candidates = faces;
  } else {
    std::vector<double> w(faces.size());
    for (size_t i = 0; i < faces.size(); ++i) w[i] = areas[faces[i]] + 1e-300;
    std::discrete_distribution<size_t> pick(w.begin(), w.end());
    candidates.reserve(max_candidates);
    for (size_t k = 0; k < max_candidates; ++k) candidates.push_back(faces[pick(rng)]);
  }
  std::vector<int> seeds;
  std::vector<double> distance(candidates.size(), std::numeric_limits<double>::infinity());
  size_t next = std::uniform_int_distribution<size_t>(0, candidates.size() - 1)(rng);
  for (int s = 0; s < count; ++s) {
    const int seed = candidates[next];
    seeds.push_back(seed);
    const Eigen::Vector3d c = centroids.col(seed);
    double best = -1.0;
    for (size_t i = 0; i < candidates.size(); ++i) {
      distance[i] = std::min(distance[i], (centroids.col(candidates[i]) - c).squaredNorm());
      if (distance[i] > best) {
        best = distance[i];
        next = i;
      }
    }
  }
  std::sort(seeds.begin(), seeds.end());
  seeds.erase(std::unique(seeds.begin(), seeds.end()), seeds.end());
  return seeds;
}

// Whether face f can leave its cell without cutting it: its edge neighbours
// in the cell must stay connected through cell faces around f's vertices
// (a local, sufficient test).
bool CanLeave(int f, int cell, const TriangleMesh& mesh, const AdjacencyList& face_faces,
              const AdjacencyList& vertex_faces, const std::vector<int>& labels) {
  int same[3];
  int num_same = 0;
  for (const int* g = face_faces.begin(f); g != face_faces.end(f); ++g) {
    if (labels[*g] == cell && num_same < 3) same[num_same++] = *g;
  }
  if (num_same <= 1) return true;
  // Faces of the cell around f (excluding f), at most a few dozen.
  int ring[96];
  int num_ring = 0;
  for (int c = 0; c < 3; ++c) {
    const int v = mesh.faces(c, f);
    for (const int* g = vertex_faces.begin(v); g != vertex_faces.end(v); ++g) {
      if (*g == f || labels[*g] != cell) continue;
      if (std::find(ring, ring + num_ring, *g) != ring + num_ring) continue;
      if (num_ring == 96) return false;
      ring[num_ring++] = *g;
    }
  }
  bool reached[96] = {false};
  int stack[96];
  int top = 0;
  const int start = static_cast<int>(std::find(ring, ring + num_ring, same[0]) - ring);
  reached[start] = true;
  stack[top++] = start;
  while (top > 0) {
    const int i = stack[--top];
    for (const int* g = face_faces.begin(ring[i]); g != face_faces.end(ring[i]); ++g) {
      const int j = static_cast<int>(std::find(ring, ring + num_ring, *g) - ring);
      if (j < num_ring && !reached[j]) {
        reached[j] = true;
        stack[top++] = j;
      }
    }
  }
  for (int k = 1; k < num_same; ++k) {
    const int j = static_cast<int>(std::find(ring, ring + num_ring, same[k]) - ring);
    if (!reached[j]) return false;
  }
  return true;
}

// Lloyd iterations on face centroids: the fallback for triangle soups.
void KMeansCells(const std::vector<int>& faces, const std::vector<int>& seeds, const Eigen::Matrix3Xd& centroids,
                 const Eigen::VectorXd& areas, std::vector<int>* labels) {
  Eigen::Matrix3Xd points(3, faces.size());
  Eigen::VectorXd weights(faces.size());
  for (size_t i = 0; i < faces.size(); ++i) {
    points.col(i) = centroids.col(faces[i]);
    weights[i] = areas[faces[i]];
  }
  Eigen::Matrix3Xd centres(3, seeds.size());
  for (size_t k = 0; k < seeds.size(); ++k) centres.col(k) = centroids.col(seeds[k]);
  std::vector<int> local;
  LloydKMeans<3>(points, weights, &centres, &local, 10);
  for (size_t i = 0; i < faces.size(); ++i) (*labels)[faces[i]] = local[i];
}

}  // namespace

namespace {

// What every phase reads: the faces' masses, centroids and adjacency.
struct FaceGraph {
  explicit FaceGraph(const TriangleMesh& m) : mesh(m) {}

  const TriangleMesh& mesh;
  Eigen::VectorXd raw_areas;  // #F
  Eigen::VectorXd areas;      // #F, zero areas raised to a tiny positive mass
  double total_area = 0.0;
  Eigen::Matrix3Xd centroids;  // 3 by #F, relative to their mean
  AdjacencyList face_faces, vertex_faces;
  std::vector<int> component;  // #F
  std::vector<double> component_area;
  std::vector<std::vector<int>> component_faces;

  int num_faces() const { return mesh.num_faces(); }
};

FaceGraph BuildFaceGraph(const TriangleMesh& mesh) {
  FaceGraph g(mesh);
  const int num_faces = mesh.num_faces();
  g.raw_areas = FaceAreas(mesh);
  g.total_area = g.raw_areas.sum();
  // Zero-area faces still need a positive mass for the cell ratios.
  g.areas = g.raw_areas.array().max(1e-12 * g.total_area / num_faces + 1e-300);
  // Centroids relative to the mesh's mean keep the moment sums well scaled.
  g.centroids = FaceCentroids(mesh);
  const Eigen::Vector3d mean = g.centroids.rowwise().mean();
  g.centroids.colwise() -= mean;
  g.face_faces = FaceFaceAdjacency(mesh);
  g.vertex_faces = VertexFaceAdjacency(mesh);
  const int num_components = ConnectedComponents(g.face_faces, &g.component);
  g.component_area.assign(num_components, 0.0);
  g.component_faces.resize(num_components);
  for (int f = 0; f < num_faces; ++f) {
    g.component_area[g.component[f]] += g.raw_areas[f];
    g.component_faces[g.component[f]].push_back(f);
  }
  return g;
}

// Components large enough for patches of their own.
std::vector<int> KeptComponents(const FaceGraph& g, double debris_area, double* kept_area) {
  std::vector<int> kept;
  *kept_area = 0.0;
  for (int c = 0; c < static_cast<int>(g.component_area.size()); ++c) {
    if (g.component_area[c] >= debris_area && g.component_area[c] > 0.0) {
      kept.push_back(c);
      *kept_area += g.component_area[c];
    }
  }
  return kept;
}

// Seeds apportioned to the kept components by area, then region growing
// from every seed at once (Dijkstra over face centroids). Faces of other
// components stay -1. Returns the number of cells.
int GrowCells(const FaceGraph& g, const std::vector<int>& kept, int requested, std::mt19937_64& rng,
              std::vector<int>* labels) {
  std::vector<double> weights;
  for (int c : kept) weights.push_back(g.component_area[c]);
  const std::vector<int> per_component = Apportion(requested, weights);
  using Entry = std::pair<double, std::pair<int, int>>;  // distance, (face, cell)
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  std::vector<double> distance(g.num_faces(), std::numeric_limits<double>::infinity());
  int num_cells = 0;
  for (size_t k = 0; k < kept.size(); ++k) {
    const std::vector<int>& faces = g.component_faces[kept[k]];
    const int wanted = std::min<int>(per_component[k], static_cast<int>(faces.size()));
    for (int seed : FarthestPointSeeds(faces, wanted, g.centroids, g.areas, rng)) {
      distance[seed] = 0.0;
      queue.push({0.0, {seed, num_cells++}});
    }
  }
  while (!queue.empty()) {
    const auto [d, fc] = queue.top();
    queue.pop();
    const auto [f, cell] = fc;
    if ((*labels)[f] >= 0) continue;
    (*labels)[f] = cell;
    for (const int* h = g.face_faces.begin(f); h != g.face_faces.end(f); ++h) {
      if ((*labels)[*h] >= 0) continue;
      const double dh = d + (g.centroids.col(*h) - g.centroids.col(f)).norm();
      if (dh < distance[*h]) {
        distance[*h] = dh;
        queue.push({dh, {*h, cell}});
      }
    }
  }
  return num_cells;
}

// Every face's point in the clustering space (Feature): its centroid, then
// normal_scale times the 6 independent entries of n n^T.
Eigen::Matrix<double, 9, Eigen::Dynamic> ClusteringFeatures(const FaceGraph& g, double normal_scale) {
  Eigen::Matrix<double, 9, Eigen::Dynamic> features(9, g.num_faces());
  const Eigen::Matrix3Xd normals = PerFaceNormals(g.mesh);
  const double r2 = std::sqrt(2.0);
  for (int f = 0; f < g.num_faces(); ++f) {
    const Eigen::Vector3d n = normals.col(f);
    features.col(f) << g.centroids.col(f), normal_scale * n.x() * n.x(), normal_scale * n.y() * n.y(),
        normal_scale * n.z() * n.z(), normal_scale * r2 * n.x() * n.y(), normal_scale * r2 * n.x() * n.z(),
        normal_scale * r2 * n.y() * n.z();
  }
  return features;
}

// Greedy boundary moves lowering the energy, in the space of positions and
// (weighted) normals: the weight is relative to the mean patch's size, so
// that the normal term means the same at every scale. Fills the summary's
// energies, iterations and moves.
void RefineCellBoundaries(const FaceGraph& g, const ClusteringOptions& options, int requested, int num_cells,
                          std::vector<int>* labels_out, ClusteringSummary* local) {
  std::vector<int>& labels = *labels_out;
  const int num_faces = g.num_faces();
  const Eigen::Matrix<double, 9, Eigen::Dynamic> features =
      ClusteringFeatures(g, options.normal_weight * std::sqrt(g.total_area / requested));
  std::vector<Cell> cells(num_cells);
  for (int f = 0; f < num_faces; ++f) {
    if (labels[f] < 0) continue;
    Cell& c = cells[labels[f]];
    c.mass += g.areas[f];
    c.moment += g.areas[f] * features.col(f);
    ++c.count;
  }
  local->initial_energy = TotalEnergy(cells);
  const double tolerance = 1e-13 * std::abs(local->initial_energy) / num_faces;
  // Only faces on a cell boundary can move: keep a list of them, updated
  // around each move, so a pass costs the boundary's size, not the mesh's.
  const auto on_boundary = [&](int f) {
    const int a = labels[f];
    if (a < 0) return false;
    for (const int* h = g.face_faces.begin(f); h != g.face_faces.end(f); ++h) {
      if (labels[*h] != a && labels[*h] >= 0) return true;
    }
    return false;
  };
  std::vector<int> boundary, touched;
  std::vector<int> stamp(num_faces, -1);
  for (int f = 0; f < num_faces; ++f) {
    if (on_boundary(f)) boundary.push_back(f);
  }
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    long long moves = 0;
    touched.clear();
    for (const int f : boundary) {
      const int a = labels[f];
      if (a < 0 || cells[a].count <= 1) continue;
      const double rho = g.areas[f];
      const Feature s = rho * features.col(f);
      const double leave_a = -(cells[a].moment - s).squaredNorm() / (cells[a].mass - rho) - cells[a].Energy();
      double best = -tolerance;
      int best_cell = -1;
      for (const int* h = g.face_faces.begin(f); h != g.face_faces.end(f); ++h) {
        const int b = labels[*h];
        if (b == a || b < 0 || b == best_cell) continue;
        const double delta = leave_a - (cells[b].moment + s).squaredNorm() / (cells[b].mass + rho) - cells[b].Energy();
        if (delta < best) {
          best = delta;
          best_cell = b;
        }
      }
      if (best_cell < 0 || !CanLeave(f, a, g.mesh, g.face_faces, g.vertex_faces, labels)) continue;
      cells[a].mass -= rho;
      cells[a].moment -= s;
      --cells[a].count;
      cells[best_cell].mass += rho;
      cells[best_cell].moment += s;
      ++cells[best_cell].count;
      labels[f] = best_cell;
      ++moves;
      for (const int* h = g.face_faces.begin(f); h != g.face_faces.end(f); ++h) touched.push_back(*h);
    }
    local->iterations = iteration + 1;
    local->num_moves += moves;
    if (moves == 0) break;
    // The next boundary: this one and the neighbours of moved faces.
    std::vector<int> next;
    next.reserve(boundary.size() + touched.size());
    for (const std::vector<int>* list : {&boundary, &touched}) {
      for (const int f : *list) {
        if (stamp[f] == iteration || !on_boundary(f)) continue;
        stamp[f] = iteration;
        next.push_back(f);
      }
    }
    boundary.swap(next);
  }
  local->final_energy = TotalEnergy(cells);
}

// Faces still unlabelled (debris) join the cell of the nearest labelled
// face. Returns how many joined.
int AssignDebris(const FaceGraph& g, std::vector<int>* labels) {
  std::vector<int> kept_faces;
  for (int f = 0; f < g.num_faces(); ++f) {
    if ((*labels)[f] >= 0) kept_faces.push_back(f);
  }
  if (static_cast<int>(kept_faces.size()) == g.num_faces()) return 0;
  Eigen::Matrix3Xd kept_centroids(3, kept_faces.size());
  for (size_t i = 0; i < kept_faces.size(); ++i) kept_centroids.col(i) = g.centroids.col(kept_faces[i]);
  const KdTree3 tree(kept_centroids);
  int joined = 0;
  for (int f = 0; f < g.num_faces(); ++f) {
    if ((*labels)[f] >= 0) continue;
    double d2;
    (*labels)[f] = (*labels)[kept_faces[tree.Nearest(g.centroids.col(f), &d2)]];
    ++joined;
  }
  return joined;
}

// Renumbers labels 0.. in order of first appearance (k-means can leave a
// centre with no face); returns the number of patches.
int CompactLabels(int num_cells, std::vector<int>* labels) {
  std::vector<int> compact(num_cells, -1);
  int num_patches = 0;
  for (int& label : *labels) {
    if (compact[label] < 0) compact[label] = num_patches++;
    label = compact[label];
  }
  return num_patches;
}

void SummarizePatchAreas(const FaceGraph& g, const std::vector<int>& labels, int num_patches,
                         ClusteringSummary* local) {
  std::vector<double> patch_area(num_patches, 0.0);
  for (int f = 0; f < g.num_faces(); ++f) patch_area[labels[f]] += g.raw_areas[f];
  const double mean_area = g.total_area / num_patches;
  double min_area = std::numeric_limits<double>::infinity(), max_area = 0.0, var = 0.0;
  for (double a : patch_area) {
    min_area = std::min(min_area, a);
    max_area = std::max(max_area, a);
    var += (a - mean_area) * (a - mean_area);
  }
  local->min_relative_area = min_area / mean_area;
  local->max_relative_area = max_area / mean_area;
  local->relative_area_stddev = std::sqrt(var / num_patches) / mean_area;
}

}  // namespace

std::vector<int> ClusterMeshFaces(const ClusteringOptions& options, const TriangleMesh& mesh,
                                  ClusteringSummary* summary) {
  const auto start_time = std::chrono::steady_clock::now();
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw std::invalid_argument("ClusteringOptions: " + problem);
  }
  if (const std::string problem = mesh.Validate(); !problem.empty()) {
    throw std::invalid_argument("ClusterMeshFaces: " + problem);
  }
  const FaceGraph graph = BuildFaceGraph(mesh);
  const int num_faces = mesh.num_faces();
  const int requested = std::min(options.ResolveNumPatches(graph.total_area), num_faces);
  double kept_area = 0.0;
  const std::vector<int> kept =
      KeptComponents(graph, options.debris_fraction * graph.total_area / requested, &kept_area);
  const bool soup = kept.empty() || kept_area < 0.5 * graph.total_area;

  std::mt19937_64 rng(options.seed);
  std::vector<int> labels(num_faces, -1);
  int num_cells = 0;
  ClusteringSummary local;
  if (soup) {
    std::vector<int> all(num_faces);
    std::iota(all.begin(), all.end(), 0);
    const std::vector<int> seeds = FarthestPointSeeds(all, requested, graph.centroids, graph.areas, rng);
    KMeansCells(all, seeds, graph.centroids, graph.areas, &labels);
    num_cells = static_cast<int>(seeds.size());
  } else {
    num_cells = GrowCells(graph, kept, requested, rng, &labels);
    RefineCellBoundaries(graph, options, requested, num_cells, &labels, &local);
    local.num_debris_faces = AssignDebris(graph, &labels);
  }
  const int num_patches = CompactLabels(num_cells, &labels);
  SummarizePatchAreas(graph, labels, num_patches, &local);
  local.requested_patches = requested;
  local.num_patches = num_patches;
  local.num_components = static_cast<int>(graph.component_area.size());
  local.soup_fallback = soup;
  local.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  if (summary != nullptr) *summary = local;
  return labels;
}

}  // namespace polyfit
