#include "polyfit/mesh/edge_split.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

namespace polyfit {
namespace {

constexpr int kMaxRounds = 20;
// Refuse rather than exhaust memory: a length far below the edges'.
constexpr Eigen::Index kMaxFaces = 4000000;

std::uint64_t EdgeKey(int a, int b) {
  const auto lo = static_cast<std::uint64_t>(std::min(a, b)), hi = static_cast<std::uint64_t>(std::max(a, b));
  return (lo << 32) | hi;
}

// One round: every edge longer than the length split once. False when none was.
bool SplitRound(double max_edge_length, TriangleMesh* mesh) {
  const int num_vertices = mesh->num_vertices();
  std::unordered_map<std::uint64_t, int> midpoint;
  std::vector<Eigen::Vector3d> added;
  for (int f = 0; f < mesh->num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int a = mesh->faces(c, f), b = mesh->faces((c + 1) % 3, f);
      if ((mesh->vertices.col(a) - mesh->vertices.col(b)).norm() <= max_edge_length) continue;
      if (midpoint.emplace(EdgeKey(a, b), num_vertices + static_cast<int>(added.size())).second) {
        added.push_back(0.5 * (mesh->vertices.col(a) + mesh->vertices.col(b)));
      }
    }
  }
  if (added.empty()) return false;
  std::vector<Eigen::Vector3i> faces;
  faces.reserve(4 * static_cast<size_t>(mesh->num_faces()));
  for (int f = 0; f < mesh->num_faces(); ++f) {
    int v[3], m[3], split = 0;
    for (int c = 0; c < 3; ++c) v[c] = mesh->faces(c, f);
    for (int c = 0; c < 3; ++c) {
      const auto it = midpoint.find(EdgeKey(v[c], v[(c + 1) % 3]));
      m[c] = it == midpoint.end() ? -1 : it->second;
      split += m[c] >= 0;
    }
    if (split == 0) {
      faces.emplace_back(v[0], v[1], v[2]);
      continue;
    }
    if (split == 3) {
      faces.emplace_back(v[0], m[0], m[2]);
      faces.emplace_back(m[0], v[1], m[1]);
      faces.emplace_back(m[2], m[1], v[2]);
      faces.emplace_back(m[0], m[1], m[2]);
      continue;
    }
    // Turn the corners so that edge (a, b) is split; c is the third.
    int r = 0;
    while (m[r] < 0) ++r;
    const int a = v[r], b = v[(r + 1) % 3], c = v[(r + 2) % 3];
    const int ab = m[r], bc = m[(r + 1) % 3], ca = m[(r + 2) % 3];
    if (split == 1) {
      faces.emplace_back(a, ab, c);
      faces.emplace_back(ab, b, c);
    } else if (bc >= 0) {
      faces.emplace_back(a, ab, c);
      faces.emplace_back(ab, b, bc);
      faces.emplace_back(ab, bc, c);
    } else {
      faces.emplace_back(a, ab, ca);
      faces.emplace_back(ab, b, c);
      faces.emplace_back(ca, ab, c);
    }
  }
  mesh->vertices.conservativeResize(3, num_vertices + static_cast<Eigen::Index>(added.size()));
  for (size_t i = 0; i < added.size(); ++i) mesh->vertices.col(num_vertices + static_cast<Eigen::Index>(i)) = added[i];
  mesh->faces.resize(3, static_cast<Eigen::Index>(faces.size()));
  for (size_t i = 0; i < faces.size(); ++i) mesh->faces.col(static_cast<Eigen::Index>(i)) = faces[i];
  return true;
}

}  // namespace

TriangleMesh SplitLongEdges(const TriangleMesh& mesh, double max_edge_length) {
  if (!(max_edge_length > 0.0) || !std::isfinite(max_edge_length)) {
    throw std::invalid_argument("SplitLongEdges: the edge length must be positive");
  }
  TriangleMesh out;
  out.vertices = mesh.vertices;
  out.faces = mesh.faces;
  for (int round = 0; round < kMaxRounds; ++round) {
    if (!SplitRound(max_edge_length, &out)) return out;
    if (out.faces.cols() > kMaxFaces) break;
  }
  throw std::invalid_argument("SplitLongEdges: edges too long for " + std::to_string(max_edge_length) +
                              " m (over 4 million faces or 20 rounds of splits)");
}

}  // namespace polyfit
