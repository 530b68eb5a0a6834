#include "polyfit/mesh/obj_reader.h"

#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "polyfit/mesh/mesh_io.h"
#include "polyfit/mesh/mesh_reader_test_fixture.h"

namespace polyfit {
namespace {

class ObjReaderTest : public MeshReaderTest {
 protected:
  std::string Error(const std::string& text) const { return ErrorOf(ReadObj, "bad.obj", text); }
};

TEST_F(ObjReaderTest, FacesOfEveryCornerFormWithMaterialsAndGroupsSkipped) {
  const PolygonSoup soup = ReadObj(Write("q.obj",
                                         "mtllib missing.mtl\r\no quad\nv 0 0 0\nv 2 0 0 1.0\nv 2 1 0\nv 0 1 0\n"
                                         "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\ng half\nusemtl none\ns off\n"
                                         "f 1/1/1 2/2/1 3/3/1   # a comment\nf -4/-4 -2/-2 -1/-1\nl 1 2\n"));
  ASSERT_EQ(soup.positions.size(), 4u);
  EXPECT_EQ(soup.positions[1], Eigen::Vector3d(2, 0, 0));
  ASSERT_EQ(soup.triangles.size(), 2u);
  EXPECT_EQ(soup.triangles[1], Eigen::Vector3i(0, 2, 3));  // negative indices count back
  ASSERT_EQ(soup.corner_texcoords.size(), 6u);
  EXPECT_EQ(soup.corner_texcoords[5], Eigen::Vector2d(0, 1));
}

TEST_F(ObjReaderTest, TextureCoordinatesOnlyWhenEveryFaceHasThem) {
  const PolygonSoup soup =
      ReadObj(Write("m.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1\nf 1//1 3//1 4//1\n"));
  EXPECT_EQ(soup.triangles.size(), 2u);
  EXPECT_TRUE(soup.corner_texcoords.empty());
}

TEST_F(ObjReaderTest, NoFacesIsAnEmptySoup) {
  const PolygonSoup soup = ReadObj(Write("p.obj", "v 0 0 0\nv 1 0 0\n"));
  EXPECT_EQ(soup.positions.size(), 2u);
  EXPECT_TRUE(soup.triangles.empty());
}

TEST_F(ObjReaderTest, ErrorsNameTheFileAndTheLine) {
  struct Case {
    const char *text, *expected;
  };
  for (const Case& c :
       {Case{"v 0 0\n", "line 1: a vertex needs three numbers"},
        Case{"v 0 0 0\nv 0 x 0\n", "line 2: 'x' is not a number"}, Case{"v 0 0 nan\n", "line 1: a non-finite value"},
        Case{"vt 0\n", "line 1: a texture coordinate needs two"},
        Case{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "line 4: vertex index out of range in '4'"},
        Case{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "line 4: vertex index out of range in '0'"},
        Case{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", "line 4: vertex index out of range"},
        Case{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2.5 3\n", "line 4: vertex index out of range"},
        Case{"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/2 2/1 3/1\n", "line 5: texture index out of range"},
        Case{"v 0 0 0\nv 1 0 0\nf 1 2\n", "line 3: a face needs at least three corners"}}) {
    const std::string error = Error(c.text);
    EXPECT_NE(error.find("bad.obj: "), std::string::npos) << c.text << " -> " << error;
    EXPECT_NE(error.find(c.expected), std::string::npos) << c.text << " -> " << error;
  }
}

}  // namespace
}  // namespace polyfit
