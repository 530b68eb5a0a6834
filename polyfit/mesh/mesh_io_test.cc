#include "polyfit/mesh/mesh_io.h"

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "polyfit/mesh/primitives.h"
#include "polyfit/util/scoped_temp_dir.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;

class MeshIoTest : public ::testing::Test {
 protected:
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  std::string Write(const std::string& name, const std::string& text) const {
    std::ofstream(Path(name)) << text;
    return Path(name);
  }
  // The message of the MeshIoError that reading `path` throws.
  static std::string ReadError(const std::string& path) {
    try {
      ReadTriangleMesh(path);
    } catch (const MeshIoError& e) {
      return e.what();
    }
    return "(no error)";
  }
  ScopedTempDir temp_{"polyfit_mesh_io"};
  const fs::path& dir_ = temp_.path();
};

TEST_F(MeshIoTest, PlyRoundTripKeepsGeometryAndTopology) {
  const TriangleMesh sphere = MakeIcosphere(2);
  WritePly(Path("s.ply"), sphere);
  const TriangleMesh back = ReadTriangleMesh(Path("s.ply"));
  ASSERT_EQ(back.num_vertices(), sphere.num_vertices());
  ASSERT_EQ(back.num_faces(), sphere.num_faces());
  // Compare the faces' corner positions (floats on disk): the order of
  // vertices is the reader's.
  double max_error = 0.0;
  for (int f = 0; f < sphere.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      max_error =
          std::max(max_error, (back.vertices.col(back.faces(c, f)) - sphere.vertices.col(sphere.faces(c, f))).norm());
    }
  }
  EXPECT_LT(max_error, 1e-6);
}

TEST_F(MeshIoTest, ObjRoundTripKeepsTextureCoordinatesAndWeldsSeams) {
  const TriangleMesh grid = MakeGrid(4, 3);
  WriteObj(Path("g.obj"), grid);
  MeshReadSummary summary;
  const TriangleMesh back = ReadTriangleMesh(Path("g.obj"), &summary);
  // assimp splits vertices per texture corner; welding joins them again.
  EXPECT_EQ(back.num_vertices(), grid.num_vertices());
  ASSERT_EQ(back.num_faces(), grid.num_faces());
  ASSERT_TRUE(back.has_texcoords());
  for (int f = 0; f < back.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d p = back.vertices.col(back.faces(c, f));
      // Texture coordinates follow the position on this grid: u = x + 0.5.
      EXPECT_NEAR(back.corner_texcoords(0, 3 * f + c), p.x() + 0.5, 1e-6);
      EXPECT_NEAR(back.corner_texcoords(1, 3 * f + c), p.y() + 0.5, 1e-6);
    }
  }
}

TEST_F(MeshIoTest, ReadsOffAndTriangulatesQuads) {
  const std::string path = Write("quad.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n");
  const TriangleMesh mesh = ReadTriangleMesh(path);
  EXPECT_EQ(mesh.num_vertices(), 4);
  EXPECT_EQ(mesh.num_faces(), 2);
  EXPECT_NEAR(SurfaceArea(mesh), 1.0, 1e-12);
}

TEST_F(MeshIoTest, ReadsStl) {
  const std::string path = Write("t.stl",
                                 "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 2 0 0\nvertex 0 1 0\n"
                                 "endloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 2 0 0\nvertex 2 1 0\n"
                                 "vertex 0 1 0\nendloop\nendfacet\nendsolid t\n");
  const TriangleMesh mesh = ReadTriangleMesh(path);
  EXPECT_EQ(mesh.num_faces(), 2);
  EXPECT_EQ(mesh.num_vertices(), 4);  // STL repeats corners; welded
  EXPECT_NEAR(SurfaceArea(mesh), 2.0, 1e-12);
}

TEST_F(MeshIoTest, ReadsGltfWithNodeTransform) {
  // One triangle: indices (uint16, 6 bytes + 2 padding) then positions.
  std::ofstream bin(Path("tri.bin"), std::ios::binary);
  const std::uint16_t indices[4] = {0, 1, 2, 0};
  const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  bin.write(reinterpret_cast<const char*>(indices), 8);
  bin.write(reinterpret_cast<const char*>(positions), 36);
  bin.close();
  const std::string path = Write("tri.gltf", R"({
    "asset": {"version": "2.0"},
    "scene": 0, "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0, "translation": [0, 0, 5]}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 1}, "indices": 0}]}],
    "buffers": [{"uri": "tri.bin", "byteLength": 44}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 6},
                    {"buffer": 0, "byteOffset": 8, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5123, "count": 3, "type": "SCALAR"},
                  {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3",
                   "min": [0, 0, 0], "max": [1, 1, 0]}]})");
  const TriangleMesh mesh = ReadTriangleMesh(path);
  ASSERT_EQ(mesh.num_faces(), 1);
  EXPECT_NEAR(SurfaceArea(mesh), 0.5, 1e-12);
  // The node's translation is applied.
  EXPECT_NEAR(mesh.vertices.row(2).mean(), 5.0, 1e-12);
}

TEST_F(MeshIoTest, MissingFileIsNamed) {
  const std::string error = ReadError(Path("nothing.obj"));
  EXPECT_NE(error.find("nothing.obj"), std::string::npos) << error;
  EXPECT_NE(error.find("no such file"), std::string::npos) << error;
}

TEST_F(MeshIoTest, EmptyFileIsNamed) {
  const std::string error = ReadError(Write("empty.obj", ""));
  EXPECT_NE(error.find("empty.obj: is empty"), std::string::npos) << error;
}

TEST_F(MeshIoTest, DirectoryIsNamed) {
  fs::create_directories(dir_ / "sub.obj");
  EXPECT_NE(ReadError(Path("sub.obj")).find("is a directory"), std::string::npos);
}

TEST_F(MeshIoTest, GarbageIsUnreadable) {
  const std::string error = ReadError(Write("garbage.ply", "this is not a mesh at all\n"));
  EXPECT_NE(error.find("garbage.ply"), std::string::npos) << error;
}

TEST_F(MeshIoTest, PointCloudHasNoTriangles) {
  const std::string path = Write("cloud.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                 "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n");
  const std::string error = ReadError(path);
  EXPECT_NE(error.find("cloud.ply"), std::string::npos) << error;
  EXPECT_NE(error.find("no triangles"), std::string::npos) << error;
}

TEST_F(MeshIoTest, NonFiniteCoordinateIsNamed) {
  const std::string path = Write("nan.off", "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n");
  const std::string error = ReadError(path);
  EXPECT_NE(error.find("nan.off"), std::string::npos) << error;
  EXPECT_TRUE(error.find("non-finite") != std::string::npos || error.find("unreadable") != std::string::npos) << error;
}

TEST_F(MeshIoTest, IndexOutOfRangeIsNamed) {
  const std::string path = Write("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
  const std::string error = ReadError(path);
  EXPECT_NE(error.find("range.off: malformed"), std::string::npos) << error;
  EXPECT_NE(error.find("out of range"), std::string::npos) << error;
}

TEST_F(MeshIoTest, TruncatedFileIsNamedNotACrash) {
  // Debian's assimp aborted on this one; our OFF reader says it is short.
  const std::string error = ReadError(Write("cut.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n"));
  EXPECT_NE(error.find("cut.off"), std::string::npos) << error;
}

TEST_F(MeshIoTest, ImpossibleDeclaredSizesAreRefusedBeforeAllocating) {
  // Found by tests/fuzz: assimp allocated what a header declares.
  for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
           {"huge.off", "OFF\n10000000 1 0\n0 0 0\n"},
           {"huge.ply",
            "ply\nformat ascii 1.0\nelement vertex 10000000\nproperty float x\nproperty float y\n"
            "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n"},
           {"huge.stl", std::string(80, ' ') + std::string("\xff\xff\xff\x0f", 4) + std::string(50, '\0')}}) {
    const std::string error = ReadError(Write(name, text));
    EXPECT_NE(error.find(name + ": the header declares"), std::string::npos) << error;
  }
}

TEST_F(MeshIoTest, MalformedOffAndPlyAreRefusedWithWhere) {
  // Found by tests/fuzz when assimp read these: it read past its buffers on
  // a face of no corners and looped on a PLY header without its end. Our
  // own readers name the line.
  struct Case {
    const char *name, *text, *expected;
  };
  for (const Case& c : {Case{"no_corners.off", "OFF\n# a comment\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n0\n",
                             "line 8: a face needs a corner count"},
                        Case{"short.off", "OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n", "a vertex needs three"},
                        Case{"cut.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n", "truncated: 2 of 3 vertices"},
                        Case{"open.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n0 0 0\n",
                             "line 5: unknown keyword '0' (a header ends with 'end_header')"}}) {
    const std::string error = ReadError(Write(c.name, c.text));
    EXPECT_NE(error.find(std::string(c.name) + ": "), std::string::npos) << error;
    EXPECT_NE(error.find(c.expected), std::string::npos) << error;
  }
}

TEST_F(MeshIoTest, DegenerateFacesAfterWeldingAreDropped) {
  // Two copies of vertex 0 make the second face a line once welded.
  const std::string path = Write("weld.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 0\n3 0 1 2\n3 0 3 1\n");
  MeshReadSummary summary;
  const TriangleMesh mesh = ReadTriangleMesh(path, &summary);
  EXPECT_EQ(mesh.num_faces(), 1);
  EXPECT_EQ(mesh.num_vertices(), 3);
  EXPECT_EQ(summary.num_dropped_degenerate_faces, 1);
}

TEST_F(MeshIoTest, FailedWriteLeavesNoFile) {
  const TriangleMesh sphere = MakeIcosphere(1);
  EXPECT_THROW(WritePly((dir_ / "missing_dir" / "s.ply").string(), sphere), MeshIoError);
  Eigen::Matrix<std::uint8_t, 3, Eigen::Dynamic> wrong(3, 2);
  EXPECT_THROW(WritePly(Path("colours.ply"), sphere, &wrong), MeshIoError);
  EXPECT_FALSE(fs::exists(Path("colours.ply")));
}

}  // namespace
}  // namespace polyfit
