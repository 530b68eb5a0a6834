#include "polyfit/pipeline/fit_mesh.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

#include "polyfit/eval/mesh_metrics.h"
#include "polyfit/eval/surface_distance.h"
#include "polyfit/mesh/face_centroids.h"
#include "polyfit/mesh/mesh_topology.h"
#include "polyfit/mesh/per_face_normals.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {
namespace {

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

std::string MeshFitOptions::Validate() const {
  if (std::string p = clustering.Validate(); !p.empty()) return "clustering: " + p;
  if (std::string p = jet_fit.Validate(); !p.empty()) return "jet_fit: " + p;
  if (std::string p = reconstruction.Validate(); !p.empty()) return "reconstruction: " + p;
  if (min_vertices_per_patch < 0) return "min_vertices_per_patch must be >= 0";
  if (max_subdivision_levels < 0 || max_subdivision_levels > 6) return "max_subdivision_levels must be in [0, 6]";
  if (evaluate && evaluation_samples < 1) return "evaluation_samples must be >= 1";
  return {};
}

std::string MeshFitSummary::BriefReport() const {
  char line[512];
  std::snprintf(line, sizeof(line),
                "%d faces -> %d patches (%d subdivision levels), %.3f s (cluster %.3f, fit %.3f); "
                "Chamfer x1e3 %.4f (floor %.4f, to surface %.4f), height RMSE %.2e, normal error %.2f deg",
                input_faces, clustering.num_patches, subdivision.levels, total_time_s, cluster_time_s, fit_time_s,
                1e3 * chamfer, 1e3 * chamfer_floor, 1e3 * surface_chamfer, height_rmse, normal_error_deg);
  return line;
}

void BuildPatchMemberships(const TriangleMesh& mesh, const std::vector<int>& face_patch, PolyFitModel* model) {
  const AdjacencyList vertex_faces = VertexFaceAdjacency(mesh);
  const Eigen::VectorXd face_areas = FaceAreas(mesh);
  const int num_vertices = mesh.num_vertices();
  model->membership_offsets.assign(1, 0);
  model->membership_patch.clear();
  model->membership_patch.reserve(static_cast<size_t>(num_vertices) * 5 / 4);
  std::vector<std::pair<int, double>> local;  // (patch, incident area)
  for (int v = 0; v < num_vertices; ++v) {
    local.clear();
    for (const int* f = vertex_faces.begin(v); f != vertex_faces.end(v); ++f) {
      const int p = face_patch[*f];
      auto it = std::find_if(local.begin(), local.end(), [p](const auto& e) { return e.first == p; });
      if (it == local.end()) {
        local.emplace_back(p, face_areas[*f]);
      } else {
        it->second += face_areas[*f];
      }
    }
    // Owner first: most incident area, ties to the lower patch index.
    std::sort(local.begin(), local.end(), [](const auto& a, const auto& b) {
      return a.second != b.second ? a.second > b.second : a.first < b.first;
    });
    for (const auto& e : local) model->membership_patch.push_back(e.first);
    model->membership_offsets.push_back(static_cast<int>(model->membership_patch.size()));
  }
  model->membership_uv = Eigen::Matrix2Xd::Zero(2, model->membership_patch.size());
}

namespace {

// The fitting points grouped by patch (points, their weights, the offsets
// of each patch's run).
struct PatchPointSets {
  Eigen::Matrix3Xd points;
  std::vector<double> weights;
  std::vector<int> offsets;
};

PatchPointSets MemberPoints(const TriangleMesh& mesh, const PolyFitModel& model, int num_patches) {
  PatchPointSets sets;
  sets.offsets.assign(num_patches + 1, 0);
  for (int p : model.membership_patch) ++sets.offsets[p + 1];
  for (int p = 0; p < num_patches; ++p) sets.offsets[p + 1] += sets.offsets[p];
  std::vector<int> slot(sets.offsets.begin(), sets.offsets.end() - 1);
  sets.points.resize(3, model.membership_patch.size());
  sets.weights.resize(model.membership_patch.size());
  const Eigen::VectorXd vertex_areas = VertexAreas(mesh);
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    for (int m : model.memberships(v)) {
      const int s = slot[model.membership_patch[m]]++;
      sets.points.col(s) = mesh.vertices.col(v);
      sets.weights[s] = vertex_areas[v];
    }
  }
  return sets;
}

// 3 by #V unit normals for the Phong tessellation: area-weighted means of
// the incident faces' normals, except on the boundary, where that mean sees
// the faces of one side only and tilts inward by about half their angle (5
// degrees on a sphere sampled 0.125 rad apart, which bends the boundary
// faces' tessellation as much as the chords' sag it corrects). There the
// normal is a 2-jet's fitted to the vertex's two-ring (kept as the mean
// where the ring is too small or the fit is not trustworthy).
Eigen::Matrix3Xd SurfaceNormals(const TriangleMesh& mesh) {
  Eigen::Matrix3Xd normals = VertexNormals(mesh);
  std::vector<char> boundary(mesh.num_vertices(), 0);
  const std::vector<std::pair<std::uint64_t, int>> edges = SortedEdgeCorners(mesh);
  for (size_t i = 0; i < edges.size(); ++i) {
    const bool single = (i == 0 || edges[i - 1].first != edges[i].first) &&
                        (i + 1 == edges.size() || edges[i + 1].first != edges[i].first);
    if (!single) continue;
    boundary[edges[i].first >> 32] = boundary[edges[i].first & 0xffffffffu] = 1;
  }
  const AdjacencyList neighbours = VertexVertexAdjacency(mesh);
  JetFitOptions options;
  options.order = 2;
  options.num_threads = 1;
  JetFitter fitter(options);
  std::vector<int> ring;
  Eigen::Matrix3Xd points;
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (!boundary[v] || normals.col(v).squaredNorm() == 0.0) continue;
    ring.assign(1, v);
    for (const int* a = neighbours.begin(v); a != neighbours.end(v); ++a) {
      ring.push_back(*a);
      ring.insert(ring.end(), neighbours.begin(*a), neighbours.end(*a));
    }
    std::sort(ring.begin(), ring.end());
    ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
    if (ring.size() < 8) continue;
    points.resize(3, static_cast<Eigen::Index>(ring.size()));
    for (size_t i = 0; i < ring.size(); ++i) points.col(static_cast<Eigen::Index>(i)) = mesh.vertices.col(ring[i]);
    const JetPatch jet = fitter.Fit(points);
    if (jet.flags != 0) continue;
    const Eigen::Vector3d uv = jet.frame.PointToPatch(mesh.vertices.col(v));
    const Eigen::Vector3d n = jet.NormalInWorld(uv.x(), uv.y());
    if (n.allFinite()) normals.col(v) = n.dot(normals.col(v)) < 0.0 ? -n : n;
  }
  return normals;
}

// Phong tessellation (Boubekeur and Alexa 2008) of the point q with
// barycentric weights w on the face with corners p_i and unit vertex normals
// n_i: q moved by alpha sum_i w_i (the step projecting q onto p_i's tangent
// plane). On a circle of radius R through two corners, the flat chord's sag
// at weight w is 2 w (1 - w) R theta^2 and the full projection moves it
// twice that, so alpha = 1/2 puts the point on the circle to second order.
// The step is the same for n_i and -n_i; a zero normal leaves q alone.
Eigen::Vector3d PhongPoint(const Eigen::Vector3d& q, const Eigen::Matrix3d& corners, const Eigen::Matrix3d& normals,
                           const Eigen::Vector3d& w) {
  constexpr double kAlpha = 0.5;
  Eigen::Vector3d p = q;
  for (int i = 0; i < 3; ++i) p -= kAlpha * w[i] * (q - corners.col(i)).dot(normals.col(i)) * normals.col(i);
  return p;
}

// Barycentric grid points (i, j, L - i - j) / L of every face, by patch;
// curved: on the faces' Phong tessellation rather than their planes.
PatchPointSets ResampledPoints(const TriangleMesh& mesh, const std::vector<int>& face_patch, int num_patches,
                               int subdivisions, bool curved) {
  const int per_face = (subdivisions + 1) * (subdivisions + 2) / 2;
  PatchPointSets sets;
  sets.offsets.assign(num_patches + 1, 0);
  for (int p : face_patch) sets.offsets[p + 1] += per_face;
  for (int p = 0; p < num_patches; ++p) sets.offsets[p + 1] += sets.offsets[p];
  std::vector<int> slot(sets.offsets.begin(), sets.offsets.end() - 1);
  sets.points.resize(3, sets.offsets.back());
  sets.weights.resize(sets.offsets.back());
  const Eigen::VectorXd face_areas = FaceAreas(mesh);
  const Eigen::Matrix3Xd vertex_normals = curved ? SurfaceNormals(mesh) : Eigen::Matrix3Xd();
  Eigen::Matrix3d corners, normals;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      corners.col(c) = mesh.vertices.col(mesh.faces(c, f));
      if (curved) normals.col(c) = vertex_normals.col(mesh.faces(c, f));
    }
    int& s = slot[face_patch[f]];
    for (int i = 0; i <= subdivisions; ++i) {
      for (int j = 0; i + j <= subdivisions; ++j, ++s) {
        const double wa = static_cast<double>(i) / subdivisions, wb = static_cast<double>(j) / subdivisions;
        const Eigen::Vector3d w(wa, wb, 1.0 - wa - wb);
        const Eigen::Vector3d q = corners * w;
        sets.points.col(s) = curved ? PhongPoint(q, corners, normals, w) : q;
        sets.weights[s] = face_areas[f] / per_face;
      }
    }
  }
  return sets;
}

}  // namespace

JetFitSummary FitPatchJets(const JetFitOptions& options, const TriangleMesh& mesh, PolyFitModel* model,
                           int face_subdivisions, bool curved_faces) {
  if (face_subdivisions < 0) throw std::invalid_argument("FitPatchJets: face_subdivisions must be >= 0");
  const int num_patches =
      model->face_patch.empty() ? 0 : *std::max_element(model->face_patch.begin(), model->face_patch.end()) + 1;
  const PatchPointSets sets =
      face_subdivisions > 0 ? ResampledPoints(mesh, model->face_patch, num_patches, face_subdivisions, curved_faces)
                            : MemberPoints(mesh, *model, num_patches);
  const JetFitSummary summary = FitJetPatches(options, sets.points, sets.offsets, &sets.weights, &model->patches);
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    for (int m : model->memberships(v)) {
      model->membership_uv.col(m) =
          model->patches[model->membership_patch[m]].frame.PointToPatch(mesh.vertices.col(v)).head<2>();
    }
  }
  return summary;
}

namespace {

// Subdivision levels for a coarse mesh, so that every patch has points
// enough (min_vertices_per_patch), up to max_subdivision_levels.
int SubdivisionLevels(const MeshFitOptions& options, const TriangleMesh& input) {
  const int wanted_patches = std::min(options.clustering.ResolveNumPatches(SurfaceArea(input)), input.num_faces());
  int levels = 0;
  long long vertices = input.num_vertices(), faces = input.num_faces();
  while (levels < options.max_subdivision_levels &&
         vertices < static_cast<long long>(options.min_vertices_per_patch) * wanted_patches) {
    vertices += faces * 3 / 2;  // one new vertex per edge
    faces *= 4;
    ++levels;
  }
  return levels;
}

// The fit's errors against the input (Chamfer distances, height RMSE,
// normal error) into summary.
void EvaluateFit(const MeshFitOptions& options, const TriangleMesh& input, const TriangleMesh& mesh,
                 const PolyFitModel& model, const TriangleMesh& reconstruction, MeshFitSummary* summary_out) {
  MeshFitSummary& summary = *summary_out;
  const auto evaluate_start = std::chrono::steady_clock::now();
  summary.chamfer =
      MeshChamferDistance(input, reconstruction, options.evaluation_samples, options.evaluation_seed).sum();
  summary.chamfer_floor = MeshChamferDistance(input, input, options.evaluation_samples, options.evaluation_seed).sum();
  summary.surface_chamfer = MeshToSurfaceChamferDistance(input, reconstruction, options.evaluation_samples,
                                                         options.evaluation_seed, options.num_threads)
                                .sum();
  const Normalization normalization = UnitSphereNormalization(input.vertices);
  summary.height_rmse =
      normalization.scale * std::sqrt((reconstruction.vertices - mesh.vertices).colwise().squaredNorm().mean());
  // Normals compared where both are defined: at each face's centroid, the
  // face's normal against its patch's jet normal there, area-weighted
  // (vertex normals would blur sharp creases into false errors).
  const Eigen::VectorXd face_areas = FaceAreas(mesh);
  const Eigen::Matrix3Xd normals = PerFaceNormals(mesh);
  const Eigen::Matrix3Xd centroids = FaceCentroids(mesh);
  double sum_angle = 0.0, sum_area = 0.0;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    if (normals.col(f).squaredNorm() == 0.0) continue;
    const JetPatch& patch = model.patches[model.face_patch[f]];
    const Eigen::Vector3d uv = patch.frame.PointToPatch(centroids.col(f));
    const double cosine = std::min(1.0, std::abs(patch.NormalInWorld(uv.x(), uv.y()).dot(normals.col(f))));
    sum_angle += face_areas[f] * std::acos(cosine) * 180.0 / M_PI;
    sum_area += face_areas[f];
  }
  summary.normal_error_deg = sum_area > 0.0 ? sum_angle / sum_area : 0.0;
  summary.evaluate_time_s = SecondsSince(evaluate_start);
}

}  // namespace

MeshFitSummary FitMesh(const MeshFitOptions& options, const TriangleMesh& input, PolyFitModel* model_out,
                       TriangleMesh* reconstruction_out) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw std::invalid_argument("MeshFitOptions: " + problem);
  }
  if (const std::string problem = input.Validate(); !problem.empty()) {
    throw std::invalid_argument("FitMesh: " + problem);
  }
  if (!(SurfaceArea(input) > 0.0)) throw std::invalid_argument("FitMesh: the mesh has zero area");
  const auto start = std::chrono::steady_clock::now();
  MeshFitSummary summary;
  summary.input_vertices = input.num_vertices();
  summary.input_faces = input.num_faces();

  const int levels = SubdivisionLevels(options, input);
  TriangleMesh subdivided;
  if (levels > 0) {
    SubdivisionOptions subdivision;
    subdivision.levels = levels;
    subdivision.scheme = options.subdivision_scheme;
    subdivided = SubdivideMesh(input, subdivision, &summary.subdivision);
  }
  const TriangleMesh& mesh = levels > 0 ? subdivided : input;
  summary.fitted_vertices = mesh.num_vertices();
  summary.fitted_faces = mesh.num_faces();
  summary.subdivide_time_s = SecondsSince(start);

  // Patches.
  PolyFitModel model;
  model.face_patch = ClusterMeshFaces(options.clustering, mesh, &summary.clustering);
  model.faces = mesh.faces;
  BuildPatchMemberships(mesh, model.face_patch, &model);
  summary.cluster_time_s = summary.clustering.time_s;

  // Jets: every patch fitted to all of its vertices, weighted by area.
  const auto fit_start = std::chrono::steady_clock::now();
  JetFitOptions jet_options = options.jet_fit;
  jet_options.num_threads = options.num_threads;
  summary.jet_fit = FitPatchJets(jet_options, mesh, &model);
  summary.fit_time_s = SecondsSince(fit_start);

  // Reconstruction.
  const auto reconstruct_start = std::chrono::steady_clock::now();
  TriangleMesh reconstruction;
  reconstruction.vertices = ReconstructVertices(model, options.reconstruction, &summary.reconstruction);
  reconstruction.faces = mesh.faces;
  reconstruction.corner_texcoords = mesh.corner_texcoords;
  summary.reconstruct_time_s = SecondsSince(reconstruct_start);
  summary.total_time_s = SecondsSince(start);

  if (options.evaluate) EvaluateFit(options, input, mesh, model, reconstruction, &summary);
  if (model_out != nullptr) *model_out = std::move(model);
  if (reconstruction_out != nullptr) *reconstruction_out = std::move(reconstruction);
  return summary;
}

}  // namespace polyfit
