#include "polyfit/model/reconstruction.h"

#include <algorithm>
#include <stdexcept>
#include <vector>

namespace polyfit {

std::string ReconstructionOptions::Validate() const {
  if (boundary_smoothing_iterations < 0) return "boundary_smoothing_iterations must be >= 0";
  if (!(boundary_smoothing_step > 0.0 && boundary_smoothing_step <= 1.0)) {
    return "boundary_smoothing_step must be in (0, 1]";
  }
  return {};
}

Eigen::Matrix3Xd ReconstructVertices(const PolyFitModel& model, const ReconstructionOptions& options,
                                     ReconstructionSummary* summary) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw std::invalid_argument("ReconstructionOptions: " + problem);
  }
  if (const std::string problem = model.Validate(); !problem.empty()) {
    throw std::invalid_argument("ReconstructVertices: " + problem);
  }
  const int num_vertices = model.num_vertices();
  Eigen::Matrix3Xd positions(3, num_vertices);
  ReconstructionSummary local;
  double sum_gap = 0.0;
  for (int v = 0; v < num_vertices; ++v) {
    const IndexRange range = model.memberships(v);
    const int begin = range.front(), end = begin + range.size();
    const auto point_on = [&model](int m) { return model.MembershipPoint(m); };
    const Eigen::Vector3d own = point_on(begin);
    if (range.size() == 1) {
      positions.col(v) = own;
      continue;
    }
    ++local.num_boundary_vertices;
    Eigen::Vector3d sum = own;
    double gap = 0.0;
    for (int m = begin + 1; m < end; ++m) {
      const Eigen::Vector3d p = point_on(m);
      gap = std::max(gap, (p - own).norm());
      sum += p;
    }
    sum_gap += gap;
    local.max_seam_gap = std::max(local.max_seam_gap, gap);
    positions.col(v) = options.seam_mode == SeamMode::kAverage ? Eigen::Vector3d(sum / (end - begin)) : own;
  }
  if (local.num_boundary_vertices > 0) local.mean_seam_gap = sum_gap / local.num_boundary_vertices;

  if (options.boundary_smoothing_iterations > 0) {
    // Vertex neighbours from the faces (CSR over boundary vertices only).
    std::vector<std::vector<int>> neighbours(num_vertices);
    for (Eigen::Index f = 0; f < model.faces.cols(); ++f) {
      for (int c = 0; c < 3; ++c) {
        const int a = model.faces(c, f), b = model.faces((c + 1) % 3, f);
        if (model.is_boundary(a)) neighbours[a].push_back(b);
        if (model.is_boundary(b)) neighbours[b].push_back(a);
      }
    }
    std::vector<int> boundary;
    for (int v = 0; v < num_vertices; ++v) {
      if (!neighbours[v].empty()) {
        std::sort(neighbours[v].begin(), neighbours[v].end());
        neighbours[v].erase(std::unique(neighbours[v].begin(), neighbours[v].end()), neighbours[v].end());
        boundary.push_back(v);
      }
    }
    Eigen::Matrix3Xd next(3, boundary.size());
    for (int iteration = 0; iteration < options.boundary_smoothing_iterations; ++iteration) {
      for (size_t i = 0; i < boundary.size(); ++i) {
        const int v = boundary[i];
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (int n : neighbours[v]) mean += positions.col(n);
        mean /= static_cast<double>(neighbours[v].size());
        next.col(i) = positions.col(v) + options.boundary_smoothing_step * (mean - positions.col(v));
      }
      for (size_t i = 0; i < boundary.size(); ++i) positions.col(boundary[i]) = next.col(i);
    }
  }
  if (summary != nullptr) *summary = local;
  return positions;
}

}  // namespace polyfit
