#include "polyfit/mesh/ordered_io.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "polyfit/mesh/ply_reader.h"

namespace polyfit {
namespace {

[[noreturn]] void Fail(const std::string& path, const std::string& reason) {
  throw std::runtime_error(path + ": " + reason);
}

}  // namespace

TriangleMesh ReadObjTemplate(const std::string& path) {
  std::ifstream in(path);
  if (!in) Fail(path, "cannot be opened (missing?)");
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector2d> texcoords;
  std::vector<Eigen::Vector3i> faces;
  std::vector<Eigen::Vector3i> face_texcoords;  // -1 where absent
  std::string line;
  int line_number = 0;
  auto where = [&] { return "line " + std::to_string(line_number) + ": "; };
  while (std::getline(in, line)) {
    ++line_number;
    std::istringstream tokens(line);
    std::string tag;
    tokens >> tag;
    if (tag == "v") {
      Eigen::Vector3d p;
      if (!(tokens >> p.x() >> p.y() >> p.z())) Fail(path, where() + "a vertex needs three numbers");
      if (!p.allFinite()) Fail(path, where() + "non-finite vertex coordinate");
      positions.push_back(p);
    } else if (tag == "vt") {
      Eigen::Vector2d t;
      if (!(tokens >> t.x() >> t.y())) Fail(path, where() + "a texture coordinate needs two numbers");
      if (!t.allFinite()) Fail(path, where() + "non-finite texture coordinate");
      texcoords.push_back(t);
    } else if (tag == "f") {
      std::vector<int> v_idx, t_idx;
      std::string corner;
      while (tokens >> corner) {
        int v = 0, t = 0;
        const size_t slash = corner.find('/');
        try {
          v = std::stoi(corner.substr(0, slash));
          if (slash != std::string::npos) {
            const size_t slash2 = corner.find('/', slash + 1);
            const std::string ts =
                corner.substr(slash + 1, slash2 == std::string::npos ? std::string::npos : slash2 - slash - 1);
            if (!ts.empty()) t = std::stoi(ts);
          }
        } catch (const std::exception&) {
          Fail(path, where() + "bad face corner '" + corner + "'");
        }
        const int nv = static_cast<int>(positions.size()), nt = static_cast<int>(texcoords.size());
        v = v < 0 ? nv + v : v - 1;
        if (v < 0 || v >= nv) Fail(path, where() + "vertex index out of range in '" + corner + "'");
        if (t != 0) {
          t = t < 0 ? nt + t : t - 1;
          if (t < 0 || t >= nt) Fail(path, where() + "texture index out of range in '" + corner + "'");
        } else {
          t = -1;
        }
        v_idx.push_back(v);
        t_idx.push_back(t);
      }
      if (v_idx.size() < 3) Fail(path, where() + "a face needs at least three corners");
      for (size_t k = 1; k + 1 < v_idx.size(); ++k) {
        faces.emplace_back(v_idx[0], v_idx[k], v_idx[k + 1]);
        face_texcoords.emplace_back(t_idx[0], t_idx[k], t_idx[k + 1]);
      }
    }
  }
  if (faces.empty()) Fail(path, "holds no faces");
  TriangleMesh mesh;
  mesh.vertices.resize(3, static_cast<Eigen::Index>(positions.size()));
  for (size_t i = 0; i < positions.size(); ++i) mesh.vertices.col(i) = positions[i];
  mesh.faces.resize(3, static_cast<Eigen::Index>(faces.size()));
  for (size_t f = 0; f < faces.size(); ++f) mesh.faces.col(f) = faces[f];
  const bool all_textured = std::all_of(face_texcoords.begin(), face_texcoords.end(),
                                        [](const Eigen::Vector3i& t) { return t.minCoeff() >= 0; });
  if (all_textured && !texcoords.empty()) {
    mesh.corner_texcoords.resize(2, 3 * static_cast<Eigen::Index>(faces.size()));
    for (size_t f = 0; f < faces.size(); ++f) {
      for (int c = 0; c < 3; ++c) mesh.corner_texcoords.col(3 * f + c) = texcoords[face_texcoords[f][c]];
    }
  }
  return mesh;
}

Eigen::Matrix3Xd ReadPlyVertices(const std::string& path) {
  std::ifstream probe(path, std::ios::binary);
  if (!probe) Fail(path, "cannot be opened (missing?)");
  const PolygonSoup soup = ReadPly(path);
  Eigen::Matrix3Xd points(3, static_cast<Eigen::Index>(soup.positions.size()));
  for (size_t v = 0; v < soup.positions.size(); ++v) {
    if (!soup.positions[v].allFinite()) Fail(path, "vertex " + std::to_string(v) + " is not finite");
    points.col(static_cast<Eigen::Index>(v)) = soup.positions[v];
  }
  return points;
}

}  // namespace polyfit
