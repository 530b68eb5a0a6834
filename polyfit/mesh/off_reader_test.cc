#include "polyfit/mesh/off_reader.h"

#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "polyfit/mesh/mesh_io.h"
#include "polyfit/mesh/mesh_reader_test_fixture.h"

namespace polyfit {
namespace {

class OffReaderTest : public MeshReaderTest {
 protected:
  std::string Error(const std::string& name, const std::string& text) const { return ErrorOf(ReadOff, name, text); }
};

TEST_F(OffReaderTest, CountsOnTheKeywordLineCommentsAndCrlf) {
  const PolygonSoup soup =
      ReadOff(Write("q.off",
                    "OFF 4 1 0 # counts here\r\n\r\n# a comment\r\n0 0 0\r\n2 0 0\r\n2 1 0\r\n0 1.5e0 0\r\n"
                    "4 0 1 2 3\r\n"));
  ASSERT_EQ(soup.positions.size(), 4u);
  EXPECT_EQ(soup.positions[3], Eigen::Vector3d(0, 1.5, 0));
  ASSERT_EQ(soup.triangles.size(), 2u);  // a fan around corner 0
  EXPECT_EQ(soup.triangles[0], Eigen::Vector3i(0, 1, 2));
  EXPECT_EQ(soup.triangles[1], Eigen::Vector3i(0, 2, 3));
  EXPECT_TRUE(soup.corner_texcoords.empty());
}

TEST_F(OffReaderTest, KeywordIsOptionalForAnOffFile) {
  const PolygonSoup soup = ReadOff(Write("bare.off", "3 1\n0 0 0\n1 0 0\n0 1 0\n3 2 1 0\n"));
  ASSERT_EQ(soup.triangles.size(), 1u);
  EXPECT_EQ(soup.triangles[0], Eigen::Vector3i(2, 1, 0));
}

TEST_F(OffReaderTest, StcnoffVertexLinesCarryNormalsColoursAndTexcoords) {
  // x y z, normal, RGBA colour, s t; faces with a colour after the indices.
  const PolygonSoup soup = ReadOff(Write("t.off",
                                         "STCNOFF\n3 1 3\n"
                                         "0 0 0  0 0 1  1 0 0 1  0.25 0.5\n"
                                         "1 0 0  0 0 1  0 1 0 1  0.75 0.5\n"
                                         "0 1 0  0 0 1  0 0 1 1  0.25 1\n"
                                         "3 0 1 2  255 0 0\n"));
  ASSERT_EQ(soup.triangles.size(), 1u);
  ASSERT_EQ(soup.corner_texcoords.size(), 3u);
  EXPECT_EQ(soup.positions[1], Eigen::Vector3d(1, 0, 0));
  EXPECT_EQ(soup.corner_texcoords[0], Eigen::Vector2d(0.25, 0.5));
  EXPECT_EQ(soup.corner_texcoords[1], Eigen::Vector2d(0.75, 0.5));
  EXPECT_EQ(soup.corner_texcoords[2], Eigen::Vector2d(0.25, 1.0));
}

TEST_F(OffReaderTest, PointsAndLinesAreCountedNotTriangulated) {
  const PolygonSoup soup = ReadOff(Write("pl.off", "OFF\n3 3 0\n0 0 0\n1 0 0\n0 1 0\n1 0\n2 0 1\n3 0 1 2\n"));
  EXPECT_EQ(soup.triangles.size(), 1u);
  EXPECT_EQ(soup.num_points_and_lines, 2);
}

TEST_F(OffReaderTest, ErrorsNameTheFileAndTheLine) {
  struct Case {
    const char *text, *expected;
  };
  for (const Case& c : {
           Case{"4OFF\n1 0 0\n0 0 0 0\n", "only three-dimensional"},
           Case{"nOFF\n3\n1 0 0\n0 0 0\n", "only three-dimensional"},
           Case{"OFF BINARY\n", "binary OFF is not read"},
           Case{"OFF\n3 1\n", "the header declares 3 vertices and 1 faces, more than its 8 bytes"},
           Case{"OFF\n1e30 1 0\n0 0 0\n", "the header declares 1000000000000000019884624838656 vertices"},
           Case{"OFF\n-1 1 0\n0 0 0\n", "line 2: a count must be a whole number"},
           Case{"OFF\n3 x 0\n0 0 0\n", "line 2: 'x' is not a number"},
           Case{"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n", "line 6: a face index out of range"},
           Case{"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", "line 6: a face index out of range"},
           Case{"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n", "line 6: a face needs a corner count"},
           Case{"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n0\n", "line 6: a face needs a corner count"},
           Case{"OFF\n3 1 0\n0 0 0\n1 0 inf\n0 1 0\n3 0 1 2\n", "line 4: a non-finite value"},
           Case{"STOFF\n3 1 0\n0 0 0 1\n1 0 0 1 1\n0 1 0 1 1\n3 0 1 2\n", "line 3: a vertex needs three"},
           Case{"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n", "truncated: 3 of 3 vertices and 0 of 1 faces"},
       }) {
    const std::string error = Error("bad.off", c.text);
    EXPECT_NE(error.find("bad.off: "), std::string::npos) << c.text << " -> " << error;
    EXPECT_NE(error.find(c.expected), std::string::npos) << c.text << " -> " << error;
  }
}

TEST_F(OffReaderTest, AssimpBusErrorInputIsACleanError) {
  // tests/fuzz found this input crashing assimp's OFF reader (a bus error);
  // without a keyword, "2 5" are the counts and the file is short of them.
  const std::string error = Error("fuzz.off",
                                  "2 5\n3 3 1 5\n3 0 4 5 255\x02"
                                  "0 1  0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n");
  EXPECT_NE(error.find("fuzz.off: malformed: line 3"), std::string::npos) << error;
}

TEST_F(OffReaderTest, RecognisesOffByNameOrKeyword) {
  EXPECT_TRUE(LooksLikeOff(Write("a.OFF", "3 1\n")));
  EXPECT_TRUE(LooksLikeOff(Write("a.mesh", "# comment\nCOFF\n")));
  EXPECT_FALSE(LooksLikeOff(Write("b.mesh", "ply\n")));
  EXPECT_FALSE(LooksLikeOff(Write("c.mesh", "OFFICE\n")));
}

}  // namespace
}  // namespace polyfit
