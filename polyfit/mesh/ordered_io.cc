#include "polyfit/mesh/ordered_io.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

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

namespace {

enum class PlyFormat { kAscii, kBinaryLittle, kBinaryBig };

size_t PlyTypeSize(const std::string& type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" || type == "float32")
    return 4;
  if (type == "double" || type == "float64") return 8;
  return 0;
}

double ReadBinaryValue(const char* data, const std::string& type, bool swap) {
  char bytes[8];
  const size_t size = PlyTypeSize(type);
  std::memcpy(bytes, data, size);
  if (swap) std::reverse(bytes, bytes + size);
  if (type == "float" || type == "float32") {
    float f;
    std::memcpy(&f, bytes, 4);
    return f;
  }
  if (type == "double" || type == "float64") {
    double d;
    std::memcpy(&d, bytes, 8);
    return d;
  }
  if (size == 1) return type[0] == 'u' ? static_cast<double>(static_cast<std::uint8_t>(bytes[0])) : bytes[0];
  if (size == 2) {
    std::int16_t s;
    std::memcpy(&s, bytes, 2);
    return type[0] == 'u' ? static_cast<double>(static_cast<std::uint16_t>(s)) : s;
  }
  std::int32_t i;
  std::memcpy(&i, bytes, 4);
  return type[0] == 'u' ? static_cast<double>(static_cast<std::uint32_t>(i)) : i;
}

// The vertex element of a PLY header: its format, count and properties.
struct PlyVertexHeader {
  PlyFormat format = PlyFormat::kAscii;
  long long num_vertices = -1;
  std::vector<std::string> types, names;
  int x = 0, y = 0, z = 0;  // the coordinates' properties
};

PlyVertexHeader ReadPlyVertexHeader(const std::string& path, std::istream& in) {
  PlyVertexHeader h;
  std::string line;
  std::getline(in, line);
  if (line.rfind("ply", 0) != 0) Fail(path, "not a PLY file");
  bool in_vertex = false, vertex_seen = false, before_vertex = true;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream tokens(line);
    std::string word;
    tokens >> word;
    if (word == "format") {
      std::string f;
      tokens >> f;
      h.format = f == "ascii"                  ? PlyFormat::kAscii
                 : f == "binary_little_endian" ? PlyFormat::kBinaryLittle
                 : f == "binary_big_endian"    ? PlyFormat::kBinaryBig
                                               : (Fail(path, "unknown PLY format '" + f + "'"), PlyFormat::kAscii);
    } else if (word == "element") {
      std::string name;
      long long count = -1;
      tokens >> name >> count;
      in_vertex = name == "vertex";
      if (in_vertex) {
        h.num_vertices = count;
        vertex_seen = true;
      } else if (!vertex_seen) {
        before_vertex = false;  // another element first: not supported
      }
    } else if (word == "property" && in_vertex) {
      std::string type, name;
      tokens >> type;
      if (type == "list") Fail(path, "list property in the vertex element");
      tokens >> name;
      if (PlyTypeSize(type) == 0) Fail(path, "unknown property type '" + type + "'");
      h.types.push_back(type);
      h.names.push_back(name);
    } else if (word == "end_header") {
      break;
    }
  }
  if (!vertex_seen || h.num_vertices < 0) Fail(path, "no vertex element");
  if (!before_vertex) Fail(path, "the vertex element must come first");
  const auto find = [&](const char* n) {
    const auto it = std::find(h.names.begin(), h.names.end(), n);
    if (it == h.names.end()) Fail(path, std::string("no '") + n + "' property");
    return static_cast<int>(it - h.names.begin());
  };
  h.x = find("x");
  h.y = find("y");
  h.z = find("z");
  return h;
}

// The header's count against what the file holds, before it is allocated:
// an ASCII value takes at least two bytes ("0 "), a binary vertex its stride.
void CheckPlyVertexCount(const std::string& path, const PlyVertexHeader& h, std::istream& in) {
  size_t min_vertex_bytes = 0;
  for (const std::string& t : h.types) min_vertex_bytes += h.format == PlyFormat::kAscii ? 2 : PlyTypeSize(t);
  const std::streampos data_start = in.tellg();
  in.seekg(0, std::ios::end);
  const long long remaining = static_cast<long long>(in.tellg() - data_start);
  in.seekg(data_start);
  const long long most = remaining / static_cast<long long>(std::max<size_t>(min_vertex_bytes, 1)) + 1;
  if (data_start < 0 || h.num_vertices > most) {
    Fail(path, "the header declares " + std::to_string(h.num_vertices) + " vertices; the file holds at most " +
                   std::to_string(most));
  }
}

Eigen::Matrix3Xd ReadPlyVertexData(const std::string& path, const PlyVertexHeader& h, std::istream& in) {
  Eigen::Matrix3Xd points(3, h.num_vertices);
  if (h.format == PlyFormat::kAscii) {
    std::vector<double> row(h.names.size());
    for (long long v = 0; v < h.num_vertices; ++v) {
      for (double& value : row) {
        if (!(in >> value)) Fail(path, "truncated at vertex " + std::to_string(v));
      }
      points.col(v) << row[h.x], row[h.y], row[h.z];
    }
    return points;
  }
  size_t stride = 0;
  std::vector<size_t> offsets;
  for (const std::string& t : h.types) {
    offsets.push_back(stride);
    stride += PlyTypeSize(t);
  }
  std::vector<char> data(stride * static_cast<size_t>(h.num_vertices));
  if (!in.read(data.data(), static_cast<std::streamsize>(data.size()))) Fail(path, "truncated vertex data");
  const bool swap = h.format == PlyFormat::kBinaryBig;
  for (long long v = 0; v < h.num_vertices; ++v) {
    const char* base = data.data() + v * stride;
    points.col(v) << ReadBinaryValue(base + offsets[h.x], h.types[h.x], swap),
        ReadBinaryValue(base + offsets[h.y], h.types[h.y], swap),
        ReadBinaryValue(base + offsets[h.z], h.types[h.z], swap);
  }
  return points;
}

}  // namespace

Eigen::Matrix3Xd ReadPlyVertices(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) Fail(path, "cannot be opened (missing?)");
  const PlyVertexHeader header = ReadPlyVertexHeader(path, in);
  CheckPlyVertexCount(path, header, in);
  const Eigen::Matrix3Xd points = ReadPlyVertexData(path, header, in);
  for (Eigen::Index v = 0; v < points.cols(); ++v) {
    if (!points.col(v).allFinite()) Fail(path, "vertex " + std::to_string(v) + " is not finite");
  }
  return points;
}

}  // namespace polyfit
