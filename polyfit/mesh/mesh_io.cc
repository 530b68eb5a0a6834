#include "polyfit/mesh/mesh_io.h"

#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include "polyfit/util/atomic_file.h"

// Debian's assimp is built with its internal assertions on, and on some
// malformed files (a truncated OFF) an assertion fails and aborts the
// process. This definition takes the place of assimp's own (the dynamic
// linker binds the library's calls to the executable's symbol) and turns the
// failure into an exception that ReadTriangleMesh reports for the file.
namespace Assimp {
void aiAssertViolation(const char* expression, const char* file, int line) {
  throw std::runtime_error(std::string("assimp internal check failed (") + expression + ")");
}
}  // namespace Assimp

namespace polyfit {
namespace {

struct PositionKey {
  std::uint64_t bits[3];
  bool operator==(const PositionKey& o) const {
    return bits[0] == o.bits[0] && bits[1] == o.bits[1] && bits[2] == o.bits[2];
  }
};

struct PositionKeyHash {
  size_t operator()(const PositionKey& k) const {
    std::uint64_t h = k.bits[0] * 0x9E3779B97F4A7C15ull;
    h ^= k.bits[1] + 0x632BE59BD9B4E019ull + (h << 6) + (h >> 2);
    h ^= k.bits[2] + 0x94D049BB133111EBull + (h << 6) + (h >> 2);
    return static_cast<size_t>(h);
  }
};

PositionKey KeyOf(const Eigen::Vector3d& p) {
  PositionKey key;
  for (int i = 0; i < 3; ++i) {
    const double value = p[i] == 0.0 ? 0.0 : p[i];  // -0 and +0 weld
    std::memcpy(&key.bits[i], &value, sizeof(double));
  }
  return key;
}

// Some assimp loaders repair bad input and only log an error (an OFF face
// index out of range becomes the last vertex). Errors are collected per
// thread; those saying the data was out of range or invalid fail the read,
// the others (assimp also logs harmless oddities, such as blank lines at
// the end of an OFF file, as errors) are passed on in the summary.
thread_local std::string assimp_errors;

class ErrorCollector : public Assimp::LogStream {
 public:
  void write(const char* message) override {
    if (assimp_errors.size() < 4096) assimp_errors += message;
  }
};

void InstallErrorCollector() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (Assimp::DefaultLogger::isNullLogger()) {
      Assimp::DefaultLogger::create("", Assimp::Logger::NORMAL, 0);
    }
    Assimp::DefaultLogger::get()->attachStream(new ErrorCollector, Assimp::Logger::Err);
  });
}

std::string Trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

[[noreturn]] void Fail(const std::string& path, const std::string& reason) { throw MeshIoError(path + ": " + reason); }

template <typename WriteFn>
void WriteMeshFile(const std::string& path, WriteFn&& write) {
  try {
    WriteFileAtomically(path, write);
  } catch (const MeshIoError&) {
    throw;
  } catch (const std::exception& e) {
    throw MeshIoError(e.what());
  }
}

// The least bytes a PLY property takes per element: its binary size, or
// "0 " in ASCII; a list property its count (binary) or "0 ".
double PlyMinBytes(const std::vector<std::string>& words, bool ascii) {
  if (ascii) return 2.0;
  static const std::pair<const char*, int> kSizes[] = {{"char", 1},  {"uchar", 1},   {"int8", 1},   {"uint8", 1},
                                                       {"short", 2}, {"ushort", 2},  {"int16", 2},  {"uint16", 2},
                                                       {"int", 4},   {"uint", 4},    {"int32", 4},  {"uint32", 4},
                                                       {"float", 4}, {"float32", 4}, {"double", 8}, {"float64", 8}};
  const std::string& type = words.size() > 2 && words[1] == "list" ? words[2] : words.size() > 1 ? words[1] : "";
  for (const auto& [name, size] : kSizes) {
    if (type == name) return size;
  }
  return 1.0;
}

std::string CountText(double count) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.0f", count);
  return text;
}

// An ASCII OFF's vertex and face lines, after the counts, checked line by
// line before assimp reads them: its OFF reader read past its buffers on a
// face line of no corners and on vertex lines holding colours under a
// plain OFF header (found by tests/fuzz/mesh_off_fuzzer). Vertex lines
// need three finite numbers (more, colours, are allowed); face lines a
// corner count of at least one and that many indices of existing
// vertices.
void CheckOffBody(const std::string& path, std::istream* in, long long num_vertices, long long num_faces) {
  std::string line;
  long long vertices = 0, faces = 0;
  int number = 0;
  const auto bad = [&](const std::string& what) {
    Fail(path, "malformed: after the counts, line " + std::to_string(number) + ": " + what);
  };
  while ((vertices < num_vertices || faces < num_faces) && std::getline(*in, line)) {
    ++number;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream tokens(line);
    std::vector<double> values;
    for (std::string token; tokens >> token;) {
      char* end = nullptr;
      const double value = std::strtod(token.c_str(), &end);
      if (*end != '\0') bad("'" + token + "' is not a number");
      values.push_back(value);
    }
    if (values.empty()) continue;
    if (vertices < num_vertices) {
      if (values.size() < 3) bad("a vertex needs three coordinates");
      for (double v : values) {
        if (!std::isfinite(v)) bad("a non-finite value");
      }
      ++vertices;
      continue;
    }
    const double corners = values[0];
    if (!(corners >= 1.0) || corners != std::floor(corners) || corners + 1.0 > values.size()) {
      bad("a face needs a corner count of at least 1 and that many indices");
    }
    for (size_t k = 1; k <= static_cast<size_t>(corners); ++k) {
      if (!(values[k] >= 0.0 && values[k] < static_cast<double>(num_vertices)) || values[k] != std::floor(values[k])) {
        bad("a face index out of range");
      }
    }
    ++faces;
  }
  if (vertices < num_vertices || faces < num_faces) {
    Fail(path, "truncated: " + std::to_string(vertices) + " of " + std::to_string(num_vertices) + " vertices and " +
                   std::to_string(faces) + " of " + std::to_string(num_faces) + " faces");
  }
}

// Counts declared in a header (OFF, PLY, binary STL) checked against the
// file's size before assimp allocates for them: assimp 5.2 allocates what
// a header declares, so 10 million vertices declared in a 200-byte file
// would take gigabytes (found by tests/fuzz/mesh_*_fuzzer).
void CheckDeclaredSizes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  in.seekg(0, std::ios::end);
  const double size = static_cast<double>(in.tellg());
  in.seekg(0);
  std::string first;
  in >> first;
  const auto too_many = [&](double needed, const std::string& what) {
    if (needed > size) {
      Fail(path, "the header declares " + what + ", more than its " + CountText(size) + " bytes can hold");
    }
  };
  if (first == "ply") {
    in.seekg(0);
    std::string line;
    bool ascii = true;
    double needed = 0.0, element_count = 0.0, element_bytes = 0.0;
    bool ended = false;
    for (int lines = 0; std::getline(in, line) && lines < 10000; ++lines) {
      std::istringstream tokens(line);
      std::vector<std::string> words;
      for (std::string w; tokens >> w;) words.push_back(w);
      if (words.empty()) continue;
      if (words[0] == "format" && words.size() > 1) ascii = words[1] == "ascii";
      if (words[0] == "element" || words[0] == "end_header") {
        needed += element_count * element_bytes;
        element_count = words.size() > 2 && words[0] == "element" ? std::strtod(words[2].c_str(), nullptr) : 0.0;
        element_bytes = 0.0;
        if (!(element_count >= 0.0)) element_count = 0.0;
      }
      if (words[0] == "property") element_bytes += PlyMinBytes(words, ascii);
      if (words[0] == "end_header") {
        ended = true;
        break;
      }
    }
    // assimp 5.2 looped for seconds on a header without its end.
    if (!ended) Fail(path, "a PLY header without 'end_header'");
    too_many(needed, "elements");
  } else if (first.size() >= 3 && first.compare(first.size() - 3, 3, "OFF") == 0 && first[0] != 'n' &&
             first[0] != '4') {
    // The counts: the first line after the header that is not blank or a
    // comment.
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
      line.resize(std::min(line.size(), line.find('#')));
      if (line.find_first_not_of(" \t\r") != std::string::npos) break;
    }
    std::istringstream counts(line);
    double vertices = 0.0, faces = 0.0;
    if (counts >> vertices >> faces && vertices >= 0.0 && faces >= 0.0) {
      // "0 0 0\n" per vertex, "0\n" per face at the least.
      // Counts as text without converting them to an integer type first:
      // a header may declare 1e24 (found by tests/fuzz/mesh_stl_fuzzer).
      too_many(6.0 * vertices + 2.0 * faces, CountText(vertices) + " vertices and " + CountText(faces) + " faces");
      CheckOffBody(path, &in, static_cast<long long>(vertices), static_cast<long long>(faces));
    }
  } else if (first.rfind("solid", 0) != 0 && size >= 84.0) {
    // A binary STL: 80 bytes of header, a facet count, 50 bytes a facet.
    std::uint32_t facets = 0;
    in.seekg(80);
    in.read(reinterpret_cast<char*>(&facets), sizeof(facets));
    std::string extension = std::filesystem::path(path).extension().string();
    for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (in && extension == ".stl") too_many(84.0 + 50.0 * facets, std::to_string(facets) + " facets");
  }
}

}  // namespace

namespace {

// The file exists, is a file, and is not empty; its declared sizes fit.
void CheckMeshFile(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) Fail(path, "no such file");
  if (fs::is_directory(path, ec)) Fail(path, "is a directory, not a mesh file");
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) Fail(path, "cannot be opened for reading");
    if (probe.peek() == std::ifstream::traits_type::eof()) Fail(path, "is empty");
  }
  CheckDeclaredSizes(path);
}

// Welded triangles of every mesh of a scene (PreTransformVertices: in one
// frame), texture coordinates per corner when any mesh has them.
struct WeldedTriangles {
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector3i> faces;
  std::vector<Eigen::Vector2d> texcoords;
  bool any_texcoords = false;
  int dropped_degenerate = 0;
};

WeldedTriangles WeldScene(const std::string& path, const aiScene* scene) {
  WeldedTriangles w;
  std::vector<Eigen::Vector3d>& positions = w.positions;
  std::vector<Eigen::Vector3i>& faces = w.faces;
  std::vector<Eigen::Vector2d>& texcoords = w.texcoords;
  bool& any_texcoords = w.any_texcoords;
  int& dropped_degenerate = w.dropped_degenerate;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    any_texcoords |= scene->mMeshes[m]->HasTextureCoords(0);
  }
  std::unordered_map<PositionKey, int, PositionKeyHash> welded;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    std::vector<int> remap(mesh->mNumVertices);
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& a = mesh->mVertices[v];
      const Eigen::Vector3d p(a.x, a.y, a.z);
      if (!p.allFinite()) {
        Fail(path, "mesh " + std::to_string(m) + " vertex " + std::to_string(v) + " has a non-finite coordinate");
      }
      auto [it, inserted] = welded.emplace(KeyOf(p), static_cast<int>(positions.size()));
      if (inserted) positions.push_back(p);
      remap[v] = it->second;
    }
    const bool has_uv = mesh->HasTextureCoords(0);
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;
      int idx[3];
      for (int c = 0; c < 3; ++c) {
        if (face.mIndices[c] >= mesh->mNumVertices) {
          Fail(path, "mesh " + std::to_string(m) + " face " + std::to_string(f) + " refers to a vertex out of range");
        }
        idx[c] = remap[face.mIndices[c]];
      }
      if (idx[0] == idx[1] || idx[1] == idx[2] || idx[0] == idx[2]) {
        ++dropped_degenerate;
        continue;
      }
      faces.emplace_back(idx[0], idx[1], idx[2]);
      if (any_texcoords) {
        for (int c = 0; c < 3; ++c) {
          if (has_uv) {
            const aiVector3D& t = mesh->mTextureCoords[0][face.mIndices[c]];
            texcoords.emplace_back(t.x, t.y);
          } else {
            texcoords.emplace_back(0.0, 0.0);
          }
        }
      }
    }
  }
  if (faces.empty()) {
    Fail(path,
         dropped_degenerate > 0 ? "every triangle is degenerate" : "holds no triangles (a point cloud or lines only?)");
  }
  return w;
}

// The welded triangles without the vertices no face uses (welding and
// dropped faces can leave some), validated.
TriangleMesh CompactMesh(const std::string& path, const WeldedTriangles& w) {
  const std::vector<Eigen::Vector3d>& positions = w.positions;
  const std::vector<Eigen::Vector3i>& faces = w.faces;
  std::vector<int> used(positions.size(), -1);
  int num_used = 0;
  for (const Eigen::Vector3i& f : faces) {
    for (int c = 0; c < 3; ++c) {
      if (used[f[c]] < 0) used[f[c]] = num_used++;
    }
  }
  TriangleMesh out;
  out.vertices.resize(3, num_used);
  for (size_t v = 0; v < positions.size(); ++v) {
    if (used[v] >= 0) out.vertices.col(used[v]) = positions[v];
  }
  out.faces.resize(3, static_cast<Eigen::Index>(faces.size()));
  for (size_t f = 0; f < faces.size(); ++f) {
    for (int c = 0; c < 3; ++c) out.faces(c, f) = used[faces[f][c]];
  }
  if (w.any_texcoords) {
    out.corner_texcoords.resize(2, static_cast<Eigen::Index>(w.texcoords.size()));
    for (size_t i = 0; i < w.texcoords.size(); ++i) out.corner_texcoords.col(i) = w.texcoords[i];
  }
  const std::string problem = out.Validate();
  if (!problem.empty()) Fail(path, problem);
  return out;
}

}  // namespace

TriangleMesh ReadTriangleMesh(const std::string& path, MeshReadSummary* summary) {
  CheckMeshFile(path);
  InstallErrorCollector();
  assimp_errors.clear();
  Assimp::Importer importer;
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const aiScene* scene = nullptr;
  try {
    scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType |
                                        aiProcess_PreTransformVertices);
  } catch (const std::exception& e) {
    Fail(path, std::string("malformed: ") + e.what());
  }
  if (scene == nullptr) {
    std::string reason = importer.GetErrorString();
    if (reason.empty()) reason = "assimp could not read it";
    // assimp's words when every primitive was a point or a line.
    if (reason.find("No output meshes") != std::string::npos || reason.find("no faces") != std::string::npos) {
      Fail(path, "holds no triangles (a point cloud or lines only?): " + reason);
    }
    Fail(path, "unreadable: " + reason);
  }

  const std::string errors = Trimmed(assimp_errors);
  if (errors.find("out of range") != std::string::npos || errors.find("nvalid") != std::string::npos) {
    Fail(path, "malformed: " + errors);
  }
  const WeldedTriangles welded = WeldScene(path, scene);
  const TriangleMesh out = CompactMesh(path, welded);
  if (summary != nullptr) {
    summary->num_dropped_degenerate_faces = welded.dropped_degenerate;
    summary->num_dropped_unreferenced_vertices = static_cast<int>(welded.positions.size()) - out.num_vertices();
    summary->num_meshes = static_cast<int>(scene->mNumMeshes);
    summary->loader_messages = errors;
  }
  return out;
}

void WritePly(const std::string& path, const TriangleMesh& mesh,
              const Eigen::Matrix<std::uint8_t, 3, Eigen::Dynamic>* vertex_colors) {
  if (vertex_colors != nullptr && vertex_colors->cols() != mesh.vertices.cols()) {
    throw MeshIoError(path + ": " + std::to_string(vertex_colors->cols()) + " colours for " +
                      std::to_string(mesh.vertices.cols()) + " vertices");
  }
  WriteMeshFile(path, [&](std::ostream& out) {
    out << "ply\nformat binary_little_endian 1.0\ncomment written by PolyFit\n"
        << "element vertex " << mesh.vertices.cols() << "\n"
        << "property float x\nproperty float y\nproperty float z\n";
    if (vertex_colors != nullptr) {
      out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    }
    out << "element face " << mesh.faces.cols() << "\n"
        << "property list uchar int vertex_indices\nend_header\n";
    std::vector<char> buffer;
    buffer.reserve(static_cast<size_t>(mesh.vertices.cols()) * 15);
    auto put = [&buffer](const void* data, size_t size) {
      const char* bytes = static_cast<const char*>(data);
      buffer.insert(buffer.end(), bytes, bytes + size);
    };
    for (Eigen::Index v = 0; v < mesh.vertices.cols(); ++v) {
      for (int i = 0; i < 3; ++i) {
        const float x = static_cast<float>(mesh.vertices(i, v));
        put(&x, sizeof(x));
      }
      if (vertex_colors != nullptr) put(vertex_colors->col(v).data(), 3);
    }
    for (Eigen::Index f = 0; f < mesh.faces.cols(); ++f) {
      const std::uint8_t three = 3;
      put(&three, 1);
      for (int c = 0; c < 3; ++c) {
        const std::int32_t index = mesh.faces(c, f);
        put(&index, sizeof(index));
      }
    }
    out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
  });
}

void WriteObj(const std::string& path, const TriangleMesh& mesh) {
  WriteMeshFile(path, [&](std::ostream& out) {
    out.precision(9);
    out << "# written by PolyFit\n";
    for (Eigen::Index v = 0; v < mesh.vertices.cols(); ++v) {
      out << "v " << mesh.vertices(0, v) << ' ' << mesh.vertices(1, v) << ' ' << mesh.vertices(2, v) << '\n';
    }
    const bool uv = mesh.has_texcoords();
    if (uv) {
      for (Eigen::Index i = 0; i < mesh.corner_texcoords.cols(); ++i) {
        out << "vt " << mesh.corner_texcoords(0, i) << ' ' << mesh.corner_texcoords(1, i) << '\n';
      }
    }
    for (Eigen::Index f = 0; f < mesh.faces.cols(); ++f) {
      out << 'f';
      for (int c = 0; c < 3; ++c) {
        out << ' ' << mesh.faces(c, f) + 1;
        if (uv) out << '/' << 3 * f + c + 1;
      }
      out << '\n';
    }
  });
}

}  // namespace polyfit
