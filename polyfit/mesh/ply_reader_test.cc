#include "polyfit/mesh/ply_reader.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "polyfit/mesh/mesh_io.h"
#include "polyfit/mesh/mesh_reader_test_fixture.h"

namespace polyfit {
namespace {

class PlyReaderTest : public MeshReaderTest {
 protected:
  std::string Error(const std::string& name, const std::string& text) const { return ErrorOf(ReadPly, name, text); }
};

// Appends `value` as the bytes of T, big-endian when `big`.
template <typename T>
void Put(T value, bool big, std::string* out) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if (big) std::reverse(bytes, bytes + sizeof(T));
  out->append(bytes, sizeof(T));
}

// A quad of mixed property types, with an element before the vertices and
// one between vertices and faces; positions (0,0,0) (2,0,0) (2,1,0) (0,1,0).
std::string BinaryQuad(bool big) {
  std::string ply = std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
                    " 1.0\ncomment mixed types\nelement camera 1\nproperty list uchar float view\n"
                    "element vertex 4\nproperty double x\nproperty float y\nproperty int8 nx\n"
                    "property list ushort int16 extra\nproperty uint16 z\n"
                    "element material 2\nproperty uchar red\n"
                    "element face 1\nproperty uint32 flags\nproperty list uchar int vertex_indices\nend_header\n";
  Put<std::uint8_t>(2, big, &ply);
  Put<float>(1.f, big, &ply);
  Put<float>(2.f, big, &ply);
  const double xy[4][2] = {{0, 0}, {2, 0}, {2, 1}, {0, 1}};
  for (const auto& p : xy) {
    Put<double>(p[0], big, &ply);
    Put<float>(static_cast<float>(p[1]), big, &ply);
    Put<std::int8_t>(-1, big, &ply);
    Put<std::uint16_t>(1, big, &ply);
    Put<std::int16_t>(7, big, &ply);
    Put<std::uint16_t>(0, big, &ply);
  }
  Put<std::uint8_t>(9, big, &ply);
  Put<std::uint8_t>(9, big, &ply);
  Put<std::uint32_t>(0, big, &ply);
  Put<std::uint8_t>(4, big, &ply);
  for (int c : {0, 1, 2, 3}) Put<std::int32_t>(c, big, &ply);
  return ply;
}

TEST_F(PlyReaderTest, BinaryBothEndiansWithOtherElementsAndProperties) {
  for (bool big : {false, true}) {
    const PolygonSoup soup = ReadPly(Write("quad.ply", BinaryQuad(big)));
    ASSERT_EQ(soup.positions.size(), 4u) << big;
    EXPECT_EQ(soup.positions[2], Eigen::Vector3d(2, 1, 0)) << big;
    ASSERT_EQ(soup.triangles.size(), 2u) << big;
    EXPECT_EQ(soup.triangles[1], Eigen::Vector3i(0, 2, 3)) << big;
  }
}

TEST_F(PlyReaderTest, AsciiWithVertexTexcoordsAndFacesBeforeVertices) {
  const PolygonSoup soup = ReadPly(Write("st.ply",
                                         "ply\r\nformat ascii 1.0\r\nelement face 1\r\n"
                                         "property list uchar int vertex_index\r\nelement vertex 3\r\n"
                                         "property float x\r\nproperty float y\r\nproperty float z\r\n"
                                         "property float s\r\nproperty float t\r\nend_header\r\n"
                                         "3 2 1 0\r\n0 0 0 0.1 0.2\r\n1 0 0 0.3 0.4\r\n0 1 0 0.5 0.6\r\n"));
  ASSERT_EQ(soup.triangles.size(), 1u);
  EXPECT_EQ(soup.triangles[0], Eigen::Vector3i(2, 1, 0));
  ASSERT_EQ(soup.corner_texcoords.size(), 3u);
  EXPECT_NEAR(soup.corner_texcoords[0].x(), 0.5, 1e-7);  // corner 0 is vertex 2
  EXPECT_NEAR(soup.corner_texcoords[2].y(), 0.2, 1e-7);
}

TEST_F(PlyReaderTest, FaceTexcoordListTakesPrecedenceOverVertexTexcoords) {
  const PolygonSoup soup = ReadPly(Write("ft.ply",
                                         "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                                         "property float y\nproperty float z\nproperty float u\nproperty float v\n"
                                         "element face 2\nproperty list uchar float texcoord\n"
                                         "property list uchar int vertex_indices\nend_header\n"
                                         "0 0 0 9 9\n1 0 0 9 9\n1 1 0 9 9\n0 1 0 9 9\n"
                                         "6 0 0 1 0 1 1 3 0 1 2\n0 3 0 2 3\n"));
  ASSERT_EQ(soup.corner_texcoords.size(), 6u);
  EXPECT_EQ(soup.corner_texcoords[2], Eigen::Vector2d(1, 1));
  EXPECT_EQ(soup.corner_texcoords[4], Eigen::Vector2d(9, 9));  // face 1 has none
}

TEST_F(PlyReaderTest, PointCloudHasPositionsAndNoTriangles) {
  const PolygonSoup soup = ReadPly(Write("cloud.ply",
                                         "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                                         "property float y\nproperty float z\nend_header\n1 2 3\n4 5 6\n"));
  ASSERT_EQ(soup.positions.size(), 2u);
  EXPECT_EQ(soup.positions[1], Eigen::Vector3d(4, 5, 6));
  EXPECT_TRUE(soup.triangles.empty());
}

TEST_F(PlyReaderTest, ErrorsNameTheFileAndWhere) {
  const std::string vertex3 =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  const std::string faces1 = "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string points = "0 0 0\n1 0 0\n0 1 0\n";
  struct Case {
    std::string text;
    const char* expected;
  };
  for (const Case& c : {
           Case{"ply\nformat ascii 1.0\nelement vertex 3\n", "without 'end_header'"},
           Case{"ply\nformat utf8 1.0\nend_header\n", "line 2: unknown format 'utf8'"},
           Case{"ply\nend_header\n", "no format line"},
           Case{"ply\nformat ascii 1.0\nelemental\nend_header\n", "line 3: unknown keyword 'elemental'"},
           Case{"ply\nformat ascii 1.0\nproperty float x\nend_header\n", "a property before any element"},
           Case{"ply\nformat ascii 1.0\nelement vertex 1\nproperty half x\nend_header\n", "unknown property type"},
           Case{"ply\nformat ascii 1.0\nelement face 1\nproperty list float int vertex_indices\nend_header\n",
                "a list's count must have an integer type"},
           Case{"ply\nformat ascii 1.0\nelement vertex 2.5\nend_header\n", "a whole count"},
           Case{vertex3 + "end_header\n0 0 0\n", "the header declares 3 vertex elements, more than its 6 bytes"},
           Case{vertex3 + faces1 + points + "3 0 1 3\n", "face 0: vertex index 3 out of range (3 vertices)"},
           Case{vertex3 + faces1 + points + "3 0 1 -2\n", "face 0: vertex index -2 out of range"},
           Case{vertex3 + faces1 + points + "3 0 1 1.5\n", "face 0: vertex index 1.5 out of range"},
           Case{vertex3 + faces1 + points + "0\n", "face 0: a face of no corners"},
           Case{vertex3 + faces1 + points + "3 0 1\n", "truncated: in face 0 of 1"},
           Case{vertex3 + faces1 + "0 0 0\n1 0 zero\n0 1 0\n3 0 1 2\n", "vertex 1: 'zero' is not a number"},
           Case{vertex3 + faces1 + points + "2.5 0 1 2\n", "face 0: a list count must be a whole number"},
           Case{"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n", "lacks an x, y or z"},
           Case{"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                "element face 1\nproperty list uchar int corners\nend_header\n0 0 0\n0\n",
                "no 'vertex_indices' list"},
           Case{"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                "property float z\nend_header\n\x01\x02\x03\x04\x05\x06\x07\x08\x09\x0a\x0b",
                "the header declares 1 vertex elements"},
           Case{"pl\n", "not a PLY file"},
       }) {
    const std::string error = Error("bad.ply", c.text);
    EXPECT_NE(error.find("bad.ply: "), std::string::npos) << c.text << " -> " << error;
    EXPECT_NE(error.find(c.expected), std::string::npos) << c.text << " -> " << error;
  }
}

TEST_F(PlyReaderTest, AHugeBinaryListCountIsTruncationNotAnAllocation) {
  std::string ply =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n";
  for (int i = 0; i < 3; ++i) Put<float>(0.f, false, &ply);
  Put<std::uint32_t>(0xFFFFFFF0u, false, &ply);
  Put<std::int32_t>(0, false, &ply);
  EXPECT_NE(Error("big.ply", ply).find("truncated: in face 0 of 1"), std::string::npos) << Error("big.ply", ply);
}

TEST_F(PlyReaderTest, AnElementWithoutPropertiesTakesNoTime) {
  // Found by tests/fuzz: 1e100 instances of nothing were read one by one.
  const PolygonSoup soup =
      ReadPly(Write("empty_element.ply", "ply\nformat ascii 1.0\nelement nothing 1" + std::string(100, '0') +
                                             "\nelement vertex 1\nproperty float x\nproperty float y\n"
                                             "property float z\nend_header\n1 2 3\n"));
  ASSERT_EQ(soup.positions.size(), 1u);
  EXPECT_EQ(soup.positions[0], Eigen::Vector3d(1, 2, 3));
}

TEST_F(PlyReaderTest, AssimpSegvInputIsACleanError) {
  // tests/fuzz found this header crashing assimp's PLY reader (a SEGV).
  const std::string error = Error("fuzz.ply",
                                  "ply\nformat ascii 1.0\ncomment seed\nelement vertex 4\nproperty float x\n"
                                  "property float y\nproperty f" +
                                      std::string(200, '\xa6') + "\n");
  EXPECT_NE(error.find("fuzz.ply: "), std::string::npos) << error;
}

}  // namespace
}  // namespace polyfit
