// Time of body-garment signed distances: the MakeHuman body (or an
// icosphere without the shared data), 2,000 and 20,000 query points near
// its surface, exact (AABB tree + pseudonormals) and nearest-vertex.
//
//   signed_distance_benchmark [BODY_DIR]
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <random>

#include "drape/body/makehuman_body.h"
#include "drape/collision/signed_distance.h"
#include "polyfit/eval/mesh_metrics.h"
#include "polyfit/mesh/primitives.h"

int main(int argc, char** argv) {
  using Clock = std::chrono::steady_clock;
  const std::string dir = argc > 1 ? argv[1] : "../shared/data/drape/body";
  polyfit::TriangleMesh body;
  if (std::filesystem::exists(dir + "/makehuman/base.obj")) {
    body = polyfit::LoadMakeHumanBody(dir).mesh;
    std::printf("MakeHuman body: %d vertices, %d triangles\n", body.num_vertices(), body.num_faces());
  } else {
    body = polyfit::MakeIcosphere(5);
    std::printf("no body at %s: icosphere, %d triangles\n", dir.c_str(), body.num_faces());
  }
  auto t0 = Clock::now();
  polyfit::BodySignedDistance exact(body);
  const double build = std::chrono::duration<double>(Clock::now() - t0).count();
  polyfit::NearestVertexDistance approximate(body);
  // A new pose: every vertex moved (the tree is refitted, the normals
  // recomputed).
  Eigen::Matrix3Xd moved = body.vertices;
  moved.row(0) *= 1.01;
  t0 = Clock::now();
  exact.SetVertices(moved);
  exact.SetVertices(body.vertices);
  const double pose = 0.5 * std::chrono::duration<double>(Clock::now() - t0).count();
  std::printf("build: %.1f ms once, %.2f ms per pose (exact)\n", 1e3 * build, 1e3 * pose);
  for (int count : {2000, 20000}) {
    Eigen::Matrix3Xd points = polyfit::SampleSurfaceUniform(body, count, 1);
    std::mt19937 rng(2);
    std::normal_distribution<double> offset(0.0, 0.01);
    for (int i = 0; i < count; ++i) points.col(i) += Eigen::Vector3d(offset(rng), offset(rng), offset(rng));
    for (int threads : {1, 2}) {
      t0 = Clock::now();
      const Eigen::VectorXd d = exact.SignedDistances(points, threads);
      const double exact_s = std::chrono::duration<double>(Clock::now() - t0).count();
      std::printf("%6d points, %d thread(s): exact %.2f ms", count, threads, 1e3 * exact_s);
      if (threads == 1) {
        t0 = Clock::now();
        double sum = 0.0;
        for (int i = 0; i < count; ++i) sum += approximate.Query(points.col(i)).distance;
        std::printf(", nearest vertex %.2f ms (checksum %.3f, %.3f)",
                    1e3 * std::chrono::duration<double>(Clock::now() - t0).count(), sum, d.sum());
      }
      std::printf("\n");
    }
  }
  return 0;
}
