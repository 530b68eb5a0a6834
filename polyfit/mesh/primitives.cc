#include "polyfit/mesh/primitives.h"

#include <cmath>
#include <stdexcept>

#include "polyfit/mesh/subdivision.h"

namespace polyfit {

TriangleMesh MakeIcosphere(int levels, double radius) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  TriangleMesh mesh;
  mesh.vertices.resize(3, 12);
  mesh.vertices << -1, 1, -1, 1, 0, 0, 0, 0, t, t, -t, -t,  //
      t, t, -t, -t, -1, 1, -1, 1, 0, 0, 0, 0,               //
      0, 0, 0, 0, t, t, -t, -t, -1, 1, -1, 1;
  mesh.faces.resize(3, 20);
  mesh.faces << 0, 0, 0, 0, 0, 1, 5, 11, 10, 7, 3, 3, 3, 3, 3, 4, 2, 6, 8, 9,  //
      11, 5, 1, 7, 10, 5, 11, 10, 7, 1, 9, 4, 2, 6, 8, 9, 4, 2, 6, 8,          //
      5, 1, 7, 10, 11, 9, 4, 2, 6, 8, 4, 2, 6, 8, 9, 5, 11, 10, 7, 1;
  for (int level = 0; level < levels; ++level) mesh = SubdivideMidpoint(mesh);
  mesh.vertices.colwise().normalize();
  mesh.vertices *= radius;
  return mesh;
}

TriangleMesh MakeGrid(int nx, int ny, double size) {
  TriangleMesh mesh;
  mesh.vertices.resize(3, (nx + 1) * (ny + 1));
  for (int j = 0; j <= ny; ++j) {
    for (int i = 0; i <= nx; ++i) {
      mesh.vertices.col(j * (nx + 1) + i) << size * (static_cast<double>(i) / nx - 0.5),
          size * (static_cast<double>(j) / ny - 0.5), 0.0;
    }
  }
  mesh.faces.resize(3, 2 * nx * ny);
  mesh.corner_texcoords.resize(2, 6 * nx * ny);
  int f = 0;
  auto uv = [&](int v) {
    return Eigen::Vector2d(static_cast<double>(v % (nx + 1)) / nx, static_cast<double>(v / (nx + 1)) / ny);
  };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i, b = a + 1, c = a + nx + 2, d = a + nx + 1;
      for (const Eigen::Vector3i& face : {Eigen::Vector3i(a, b, c), Eigen::Vector3i(a, c, d)}) {
        mesh.faces.col(f) = face;
        for (int k = 0; k < 3; ++k) mesh.corner_texcoords.col(3 * f + k) = uv(face[k]);
        ++f;
      }
    }
  }
  return mesh;
}

TriangleMesh MakeBumpyTorus(int nu, int nv, double bumps) {
  TriangleMesh mesh;
  mesh.vertices.resize(3, nu * nv);
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      const double a = 2 * M_PI * i / nu, b = 2 * M_PI * j / nv;
      const double r = 0.35 * (1.0 + bumps * std::sin(5 * a) * std::cos(3 * b));
      mesh.vertices.col(i * nv + j) << (1.0 + r * std::cos(b)) * std::cos(a), (1.0 + r * std::cos(b)) * std::sin(a),
          r * std::sin(b);
    }
  }
  mesh.faces.resize(3, 2 * nu * nv);
  int f = 0;
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      const int a = i * nv + j, b = ((i + 1) % nu) * nv + j, c = ((i + 1) % nu) * nv + (j + 1) % nv,
                d = i * nv + (j + 1) % nv;
      mesh.faces.col(f++) << a, b, c;
      mesh.faces.col(f++) << a, c, d;
    }
  }
  return mesh;
}

TriangleMesh MakeTube(double radius, double y0, double y1, int segments, int rings) {
  if (segments < 3 || rings < 1) throw std::invalid_argument("MakeTube: needs segments >= 3 and rings >= 1");
  TriangleMesh tube;
  tube.vertices.resize(3, segments * (rings + 1));
  for (int r = 0; r <= rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      const double a = 2.0 * M_PI * s / segments;
      tube.vertices.col(r * segments + s) =
          Eigen::Vector3d(radius * std::sin(a), y0 + (y1 - y0) * r / rings, radius * std::cos(a));
    }
  }
  tube.faces.resize(3, 2 * segments * rings);
  int f = 0;
  for (int r = 0; r < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      const int a = r * segments + s, b = r * segments + (s + 1) % segments;
      tube.faces.col(f++) = Eigen::Vector3i(a, b, b + segments);
      tube.faces.col(f++) = Eigen::Vector3i(a, b + segments, a + segments);
    }
  }
  return tube;
}

}  // namespace polyfit
