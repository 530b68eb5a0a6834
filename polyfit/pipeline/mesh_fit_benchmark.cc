// Time of clustering and fitting against mesh size: a bumpy torus of
// 10k to 1M triangles (or the meshes given) into K patches.
//
//   mesh_fit_benchmark [--patches K] [--threads N] [--csv FILE] [MESH...]
//   mesh_fit_benchmark --seams [--patches K] MESH...   error of each seam mode
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "polyfit/mesh/mesh_io.h"
#include "polyfit/mesh/primitives.h"
#include "polyfit/pipeline/fit_mesh.h"

int main(int argc, char** argv) {
  int patches = 400, threads = 0;
  bool seams = false;
  std::string csv_path;
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--patches") && i + 1 < argc) {
      patches = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--threads") && i + 1 < argc) {
      threads = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--seams")) {
      seams = true;
    } else if (!std::strcmp(argv[i], "--csv") && i + 1 < argc) {
      csv_path = argv[++i];
    } else {
      files.emplace_back(argv[i]);
    }
  }
  std::vector<std::pair<std::string, polyfit::TriangleMesh>> meshes;
  if (files.empty()) {
    for (int n : {10000, 30000, 100000, 300000, 1000000}) {
      const int nv = static_cast<int>(std::round(std::sqrt(n / 2.0 / 2.86)));
      const int nu = static_cast<int>(std::round(n / 2.0 / nv));
      meshes.emplace_back("torus_" + std::to_string(2 * nu * nv), polyfit::MakeBumpyTorus(nu, nv));
    }
  } else {
    for (const std::string& f : files) {
      meshes.emplace_back(f.substr(f.find_last_of('/') + 1), polyfit::ReadTriangleMesh(f));
    }
  }

  if (seams) {
    // Error of the reconstruction for each way of reconciling seams.
    std::printf("%-28s %-16s %14s %14s %12s %12s\n", "mesh", "seams", "surf Ch x1e3", "height RMSE", "normal deg",
                "seam gap (mesh units)");
    for (const auto& [name, mesh] : meshes) {
      for (int mode = 0; mode < 4; ++mode) {
        polyfit::MeshFitOptions options;
        options.clustering.num_patches = patches;
        options.reconstruction.seam_mode = mode == 0 ? polyfit::SeamMode::kOwner : polyfit::SeamMode::kAverage;
        options.reconstruction.boundary_smoothing_iterations = mode == 2 ? 1 : mode == 3 ? 3 : 0;
        const char* label = mode == 0   ? "owner"
                            : mode == 1 ? "average"
                            : mode == 2 ? "average+smooth1"
                                        : "average+smooth3";
        const polyfit::MeshFitSummary s = polyfit::FitMesh(options, mesh, nullptr, nullptr);
        std::printf("%-28s %-16s %14.5f %14.3e %12.2f %12.3e\n", name.c_str(), label, 1e3 * s.surface_chamfer,
                    s.height_rmse, s.normal_error_deg, s.reconstruction.mean_seam_gap);
      }
    }
    return 0;
  }

  polyfit::MeshFitOptions options;
  options.clustering.num_patches = patches;
  options.min_vertices_per_patch = 0;
  options.evaluate = false;
  options.num_threads = threads;
  FILE* csv = csv_path.empty() ? nullptr : std::fopen(csv_path.c_str(), "w");
  if (csv) std::fprintf(csv, "mesh,faces,patches,cluster_s,fit_s,reconstruct_s,total_s,cluster_iterations\n");
  std::printf("%-28s %9s %8s %10s %8s %8s %8s %6s %18s\n", "mesh", "faces", "patches", "cluster s", "fit s", "recon s",
              "total s", "iters", "area min/max/std");
  for (const auto& [name, mesh] : meshes) {
    // Best of three: the machine is shared.
    polyfit::MeshFitSummary best;
    best.total_time_s = 1e30;
    for (int repeat = 0; repeat < 3; ++repeat) {
      const polyfit::MeshFitSummary s = polyfit::FitMesh(options, mesh, nullptr, nullptr);
      if (s.total_time_s < best.total_time_s) best = s;
    }
    std::printf("%-28s %9d %8d %10.3f %8.3f %8.3f %8.3f %6d %6.2f/%4.2f/%4.2f\n", name.c_str(), best.input_faces,
                best.clustering.num_patches, best.cluster_time_s, best.fit_time_s, best.reconstruct_time_s,
                best.total_time_s, best.clustering.iterations, best.clustering.min_relative_area,
                best.clustering.max_relative_area, best.clustering.relative_area_stddev);
    if (csv) {
      std::fprintf(csv, "%s,%d,%d,%.4f,%.4f,%.4f,%.4f,%d\n", name.c_str(), best.input_faces,
                   best.clustering.num_patches, best.cluster_time_s, best.fit_time_s, best.reconstruct_time_s,
                   best.total_time_s, best.clustering.iterations);
    }
  }
  if (csv) std::fclose(csv);
  return 0;
}
