#include "polyfit/mesh/mesh_io.h"

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include "polyfit/mesh/obj_reader.h"
#include "polyfit/mesh/off_reader.h"
#include "polyfit/mesh/ply_reader.h"
#include "polyfit/mesh/text_reading.h"
#include "polyfit/util/atomic_file.h"
#include "polyfit/util/file_extension.h"

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

// A binary STL's facet count checked against the file's size before assimp
// allocates for it: assimp 5.2 allocates what a header declares, so 2^28
// facets declared in a 200-byte file would take gigabytes (found by
// tests/fuzz/mesh_stl_fuzzer). OFF and PLY are read by our own readers,
// which check their counts themselves.
void CheckStlFacetCount(const std::string& path) {
  if (LowercaseExtension(path) != ".stl") return;
  std::ifstream in(path, std::ios::binary);
  in.seekg(0, std::ios::end);
  const double size = static_cast<double>(in.tellg());
  in.seekg(0);
  char solid[5] = {};
  in.read(solid, 5);
  if (std::string(solid, 5) == "solid" || size < 84.0) return;  // ASCII STL
  // 80 bytes of header, a facet count, 50 bytes a facet.
  std::uint32_t facets = 0;
  in.seekg(80);
  in.read(reinterpret_cast<char*>(&facets), sizeof(facets));
  if (in && 84.0 + 50.0 * facets > size) {
    FailMeshRead(path, "the header declares " + std::to_string(facets) + " facets, more than its " + CountText(size) +
                           " bytes can hold");
  }
}

}  // namespace

namespace {

// The file exists, is a file, and is not empty; its declared sizes fit.
void CheckMeshFile(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) FailMeshRead(path, "no such file");
  if (fs::is_directory(path, ec)) FailMeshRead(path, "is a directory, not a mesh file");
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) FailMeshRead(path, "cannot be opened for reading");
    if (probe.peek() == std::ifstream::traits_type::eof()) FailMeshRead(path, "is empty");
  }
  CheckStlFacetCount(path);
}

// The meshes of an assimp scene (PreTransformVertices: in one frame) as
// soups; assimp has already triangulated polygons and dropped points and
// lines.
std::vector<PolygonSoup> SoupsOfScene(const std::string& path, const aiScene* scene) {
  std::vector<PolygonSoup> soups(scene->mNumMeshes);
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    PolygonSoup& soup = soups[m];
    soup.positions.reserve(mesh->mNumVertices);
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& a = mesh->mVertices[v];
      soup.positions.emplace_back(a.x, a.y, a.z);
    }
    const bool has_uv = mesh->HasTextureCoords(0);
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;
      for (int c = 0; c < 3; ++c) {
        if (face.mIndices[c] >= mesh->mNumVertices) {
          FailMeshRead(path,
                       "mesh " + std::to_string(m) + " face " + std::to_string(f) + " refers to a vertex out of range");
        }
        if (has_uv) {
          const aiVector3D& t = mesh->mTextureCoords[0][face.mIndices[c]];
          soup.corner_texcoords.emplace_back(t.x, t.y);
        }
      }
      soup.triangles.emplace_back(face.mIndices[0], face.mIndices[1], face.mIndices[2]);
    }
  }
  return soups;
}

// Welded triangles of every soup, texture coordinates per corner when any
// soup has them.
struct WeldedTriangles {
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector3i> faces;
  std::vector<Eigen::Vector2d> texcoords;
  bool any_texcoords = false;
  int dropped_degenerate = 0;
};

WeldedTriangles WeldSoups(const std::string& path, const std::vector<PolygonSoup>& soups) {
  WeldedTriangles w;
  for (const PolygonSoup& soup : soups) w.any_texcoords |= !soup.corner_texcoords.empty();
  std::unordered_map<PositionKey, int, PositionKeyHash> welded;
  std::vector<int> remap;
  for (size_t m = 0; m < soups.size(); ++m) {
    const PolygonSoup& soup = soups[m];
    remap.resize(soup.positions.size());
    for (size_t v = 0; v < soup.positions.size(); ++v) {
      const Eigen::Vector3d& p = soup.positions[v];
      if (!p.allFinite()) {
        FailMeshRead(path,
                     "mesh " + std::to_string(m) + " vertex " + std::to_string(v) + " has a non-finite coordinate");
      }
      auto [it, inserted] = welded.emplace(KeyOf(p), static_cast<int>(w.positions.size()));
      if (inserted) w.positions.push_back(p);
      remap[v] = it->second;
    }
    for (size_t f = 0; f < soup.triangles.size(); ++f) {
      const Eigen::Vector3i idx(remap[soup.triangles[f][0]], remap[soup.triangles[f][1]], remap[soup.triangles[f][2]]);
      if (idx[0] == idx[1] || idx[1] == idx[2] || idx[0] == idx[2]) {
        ++w.dropped_degenerate;
        continue;
      }
      w.faces.push_back(idx);
      for (int c = 0; c < 3 && w.any_texcoords; ++c) {
        w.texcoords.push_back(soup.corner_texcoords.empty() ? Eigen::Vector2d::Zero()
                                                            : soup.corner_texcoords[3 * f + c]);
      }
    }
  }
  if (w.faces.empty()) {
    FailMeshRead(path, w.dropped_degenerate > 0 ? "every triangle is degenerate"
                                                : "holds no triangles (a point cloud or lines only?)");
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
  if (!problem.empty()) FailMeshRead(path, problem);
  return out;
}

}  // namespace

namespace {

// Every mesh of a file in a format we do not read ourselves; errors assimp
// logged without failing go to *messages.
std::vector<PolygonSoup> ReadWithAssimp(const std::string& path, std::string* messages) {
  InstallErrorCollector();
  assimp_errors.clear();
  Assimp::Importer importer;
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const aiScene* scene = nullptr;
  try {
    scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType |
                                        aiProcess_PreTransformVertices);
  } catch (const std::exception& e) {
    FailMeshRead(path, std::string("malformed: ") + e.what());
  }
  if (scene == nullptr) {
    std::string reason = importer.GetErrorString();
    if (reason.empty()) reason = "assimp could not read it";
    // assimp's words when every primitive was a point or a line.
    if (reason.find("No output meshes") != std::string::npos || reason.find("no faces") != std::string::npos) {
      FailMeshRead(path, "holds no triangles (a point cloud or lines only?): " + reason);
    }
    FailMeshRead(path, "unreadable: " + reason);
  }
  *messages = Trimmed(assimp_errors);
  if (messages->find("out of range") != std::string::npos || messages->find("nvalid") != std::string::npos) {
    FailMeshRead(path, "malformed: " + *messages);
  }
  return SoupsOfScene(path, scene);
}

}  // namespace

TriangleMesh ReadTriangleMesh(const std::string& path, MeshReadSummary* summary) {
  CheckMeshFile(path);
  std::string messages;
  const std::vector<PolygonSoup> soups = LooksLikePly(path)                   ? std::vector<PolygonSoup>{ReadPly(path)}
                                         : LooksLikeOff(path)                 ? std::vector<PolygonSoup>{ReadOff(path)}
                                         : LowercaseExtension(path) == ".obj" ? std::vector<PolygonSoup>{ReadObj(path)}
                                                                              : ReadWithAssimp(path, &messages);
  const WeldedTriangles welded = WeldSoups(path, soups);
  const TriangleMesh out = CompactMesh(path, welded);
  if (summary != nullptr) {
    summary->num_dropped_degenerate_faces = welded.dropped_degenerate;
    summary->num_dropped_unreferenced_vertices = static_cast<int>(welded.positions.size()) - out.num_vertices();
    summary->num_meshes = static_cast<int>(soups.size());
    summary->num_skipped_points_and_lines = 0;
    for (const PolygonSoup& soup : soups) summary->num_skipped_points_and_lines += soup.num_points_and_lines;
    summary->loader_messages = messages;
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
