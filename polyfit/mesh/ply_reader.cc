#include "polyfit/mesh/ply_reader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string_view>
#include <vector>

#include "polyfit/mesh/mesh_io.h"
#include "polyfit/mesh/text_reading.h"
#include "polyfit/util/file_extension.h"
#include "polyfit/util/parse_number.h"

namespace polyfit {
namespace {

std::string NumberText(double value) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.17g", value);
  return text;
}

enum class PlyFormat { kAscii, kBinaryLittle, kBinaryBig };
enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

bool ParseType(std::string_view word, PlyType* type) {
  static const std::pair<const char*, PlyType> kNames[] = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const auto& [name, t] : kNames) {
    if (word == name) {
      *type = t;
      return true;
    }
  }
  return false;
}

size_t SizeOf(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
    case PlyType::kUint8: return 1;
    case PlyType::kInt16:
    case PlyType::kUint16: return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32: return 4;
    case PlyType::kFloat64: return 8;
  }
  return 1;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;  // of the value, or of a list's items
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  double count = 0.0;
  std::vector<PlyProperty> properties;

  int Find(std::string_view property) const {
    for (size_t i = 0; i < properties.size(); ++i) {
      if (properties[i].name == property) return static_cast<int>(i);
    }
    return -1;
  }
};

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  size_t data_begin = 0;  // the byte after end_header's line
};

void ParseHeaderLine(const std::string& path, int number, const std::vector<std::string_view>& words,
                     PlyHeader* header) {
  const auto bad = [&](const std::string& what) {
    FailMeshRead(path, "malformed header: line " + std::to_string(number) + ": " + what);
  };
  const std::string_view key = words[0];
  if (key == "format") {
    if (words.size() < 2) bad("a format line needs a format");
    if (words[1] == "ascii") {
      header->format = PlyFormat::kAscii;
    } else if (words[1] == "binary_little_endian") {
      header->format = PlyFormat::kBinaryLittle;
    } else if (words[1] == "binary_big_endian") {
      header->format = PlyFormat::kBinaryBig;
    } else {
      bad("unknown format '" + std::string(words[1]) + "'");
    }
  } else if (key == "element") {
    PlyElement element;
    if (words.size() < 3 || !ParseNumber(words[2], &element.count) || !(element.count >= 0.0) ||
        element.count != std::floor(element.count)) {
      bad("an element needs a name and a whole count");
    }
    element.name = std::string(words[1]);
    header->elements.push_back(std::move(element));
  } else if (key == "property") {
    if (header->elements.empty()) bad("a property before any element");
    PlyProperty property;
    property.is_list = words.size() > 1 && words[1] == "list";
    const size_t type_word = property.is_list ? 3 : 1;
    if (words.size() < type_word + 2) bad("a property needs a type and a name");
    if ((property.is_list && !ParseType(words[2], &property.count_type)) ||
        !ParseType(words[type_word], &property.type)) {
      bad("unknown property type");
    }
    if (property.is_list && (property.count_type == PlyType::kFloat32 || property.count_type == PlyType::kFloat64)) {
      bad("a list's count must have an integer type");
    }
    property.name = std::string(words[type_word + 1]);
    header->elements.back().properties.push_back(std::move(property));
  } else if (key != "comment" && key != "obj_info") {
    bad("unknown keyword '" + std::string(key) + "' (a header ends with 'end_header')");
  }
}

PlyHeader ReadHeader(const std::string& path, const std::string& bytes) {
  PlyHeader header;
  size_t begin = 0;
  bool format_seen = false;
  std::vector<std::string_view> words;
  for (int number = 1;; ++number) {
    const size_t end = bytes.find('\n', begin);
    if (end == std::string::npos) FailMeshRead(path, "a PLY header without 'end_header'");
    SplitWords(std::string_view(bytes).substr(begin, end - begin), &words);
    begin = end + 1;
    if (number == 1) {
      if (words.size() != 1 || words[0] != "ply") FailMeshRead(path, "not a PLY file (no 'ply' line)");
      continue;
    }
    if (words.empty()) continue;
    if (words[0] == "end_header") break;
    format_seen |= words[0] == "format";
    ParseHeaderLine(path, number, words, &header);
  }
  if (!format_seen) FailMeshRead(path, "malformed header: no format line");
  header.data_begin = begin;
  return header;
}

// Reads values of the body in order, bounded by the file's end; errors
// name the element being read.
class PlyData {
 public:
  PlyData(const std::string& path, const std::string& bytes, size_t begin, PlyFormat format)
      : path_(path), bytes_(bytes), next_(begin), format_(format) {}

  void Enter(const PlyElement& element, double index) {
    element_ = &element;
    index_ = index;
  }

  double Read(PlyType type) { return format_ == PlyFormat::kAscii ? ReadText() : ReadBinary(type); }

  // A list's item count: whole, at least 0, and no more than the rest of
  // the file can hold (so a bad count cannot make a caller allocate).
  size_t ReadCount(const PlyProperty& property) {
    const double count = Read(property.count_type);
    const size_t least = format_ == PlyFormat::kAscii ? 2 : SizeOf(property.type);
    if (!(count >= 0.0) || count != std::floor(count)) Malformed("a list count must be a whole number, at least 0");
    if (count * static_cast<double>(least) > static_cast<double>(remaining()) + (ascii() ? 1.0 : 0.0)) Truncated();
    return static_cast<size_t>(count);
  }

  size_t remaining() const { return bytes_.size() - next_; }
  bool ascii() const { return format_ == PlyFormat::kAscii; }

  [[noreturn]] void Malformed(const std::string& what) const {
    FailMeshRead(path_, "malformed: " + element_->name + " " + CountText(index_) + ": " + what);
  }
  [[noreturn]] void Truncated() const {
    FailMeshRead(path_,
                 "truncated: in " + element_->name + " " + CountText(index_) + " of " + CountText(element_->count));
  }

 private:
  double ReadText() {
    while (next_ < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[next_]))) ++next_;
    const size_t begin = next_;
    while (next_ < bytes_.size() && !std::isspace(static_cast<unsigned char>(bytes_[next_]))) ++next_;
    if (next_ == begin) Truncated();
    const std::string_view word(bytes_.data() + begin, next_ - begin);
    double value = 0.0;
    if (!ParseNumber(word, &value)) Malformed("'" + std::string(word.substr(0, 40)) + "' is not a number");
    return value;
  }

  double ReadBinary(PlyType type) {
    const size_t size = SizeOf(type);
    if (remaining() < size) Truncated();
    unsigned char b[8];
    std::memcpy(b, bytes_.data() + next_, size);
    next_ += size;
    if (format_ == PlyFormat::kBinaryBig) std::reverse(b, b + size);
    switch (type) {
      case PlyType::kInt8: return static_cast<std::int8_t>(b[0]);
      case PlyType::kUint8: return b[0];
      case PlyType::kInt16: return As<std::int16_t>(b);
      case PlyType::kUint16: return As<std::uint16_t>(b);
      case PlyType::kInt32: return As<std::int32_t>(b);
      case PlyType::kUint32: return As<std::uint32_t>(b);
      case PlyType::kFloat32: return As<float>(b);
      case PlyType::kFloat64: return As<double>(b);
    }
    return 0.0;
  }

  template <typename T>
  static double As(const unsigned char* b) {
    T value;
    std::memcpy(&value, b, sizeof(T));
    return static_cast<double>(value);
  }

  const std::string& path_;
  const std::string& bytes_;
  size_t next_;
  PlyFormat format_;
  const PlyElement* element_ = nullptr;
  double index_ = 0.0;
};

// An element's count against the bytes left, before anything is allocated
// for it: a binary element takes its scalars' and list counts' sizes at
// least, an ASCII one two bytes ("0 ") a property.
void CheckCount(const std::string& path, const PlyElement& element, const PlyData& data) {
  double least = 0.0;
  for (const PlyProperty& p : element.properties) {
    least += data.ascii() ? 2.0 : static_cast<double>(SizeOf(p.is_list ? p.count_type : p.type));
  }
  // An ASCII file's last value may lack its separator.
  if (element.count * least > static_cast<double>(data.remaining()) + (data.ascii() ? 1.0 : 0.0)) {
    FailMeshRead(path, "the header declares " + CountText(element.count) + " " + element.name +
                           " elements, more than its " + CountText(static_cast<double>(data.remaining())) +
                           " bytes of data can hold");
  }
}

// Reads past one element instance, calling visit(property index, value) for
// each scalar and visit_list(property index, values) for each list.
template <typename Scalar, typename List>
void ReadInstance(const PlyElement& element, PlyData* data, std::vector<double>* list_values, Scalar&& visit,
                  List&& visit_list) {
  for (size_t p = 0; p < element.properties.size(); ++p) {
    const PlyProperty& property = element.properties[p];
    if (!property.is_list) {
      visit(static_cast<int>(p), data->Read(property.type));
      continue;
    }
    const size_t count = data->ReadCount(property);
    list_values->resize(count);
    for (double& v : *list_values) v = data->Read(property.type);
    visit_list(static_cast<int>(p), *list_values);
  }
}

// The first pair of texture-coordinate properties the element has.
std::pair<int, int> FindTexcoordProperties(const PlyElement& vertex) {
  static const std::pair<const char*, const char*> kPairs[] = {
      {"u", "v"}, {"s", "t"}, {"texture_u", "texture_v"}, {"texture_s", "texture_t"}};
  for (const auto& [u, v] : kPairs) {
    if (vertex.Find(u) >= 0 && vertex.Find(v) >= 0) return {vertex.Find(u), vertex.Find(v)};
  }
  return {-1, -1};
}

struct PlyVertices {
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector2d> texcoords;  // per vertex, or empty
};

PlyVertices ReadVertices(const std::string& path, const PlyElement& element, PlyData* data) {
  const int x = element.Find("x"), y = element.Find("y"), z = element.Find("z");
  if (x < 0 || y < 0 || z < 0) FailMeshRead(path, "the vertex element lacks an x, y or z property");
  const std::pair<int, int> texcoord_properties = FindTexcoordProperties(element);
  const int u = texcoord_properties.first, v = texcoord_properties.second;  // captured: no structured binding
  PlyVertices out;
  out.positions.resize(static_cast<size_t>(element.count));
  if (u >= 0) out.texcoords.resize(out.positions.size());
  std::vector<double> list;
  for (size_t i = 0; i < out.positions.size(); ++i) {
    data->Enter(element, static_cast<double>(i));
    Eigen::Vector3d& p = out.positions[i];
    ReadInstance(
        element, data, &list,
        [&](int property, double value) {
          if (property == x) p.x() = value;
          if (property == y) p.y() = value;
          if (property == z) p.z() = value;
          if (property == u) out.texcoords[i].x() = value;
          if (property == v) out.texcoords[i].y() = value;
        },
        [](int, const std::vector<double>&) {});
  }
  return out;
}

// Faces as flat corner lists: corners[starts[f] .. starts[f + 1]).
struct PlyFaces {
  std::vector<int> corners;
  std::vector<size_t> starts{0};
  std::vector<Eigen::Vector2d> texcoords;  // per corner, where given
  std::vector<bool> textured;              // per face
};

PlyFaces ReadFaces(const std::string& path, const PlyElement& element, PlyData* data) {
  int indices = element.Find("vertex_indices");
  if (indices < 0) indices = element.Find("vertex_index");
  if (indices < 0 || !element.properties[indices].is_list)
    FailMeshRead(path, "the face element has no 'vertex_indices' list");
  const int texcoord = element.Find("texcoord");
  PlyFaces out;
  std::vector<double> list;
  for (double f = 0.0; f < element.count; ++f) {
    data->Enter(element, f);
    bool textured = false;
    const size_t begin = out.corners.size();
    ReadInstance(
        element, data, &list, [](int, double) {},
        [&](int property, const std::vector<double>& values) {
          if (property == indices) {
            if (values.empty()) data->Malformed("a face of no corners");
            for (double c : values) {
              if (!(c >= 0.0 && c < 2147483647.0) || c != std::floor(c)) {
                data->Malformed("vertex index " + NumberText(c) + " out of range");
              }
              out.corners.push_back(static_cast<int>(c));
            }
          } else if (property == texcoord) {
            textured = !values.empty();
            for (size_t k = 0; k + 1 < values.size(); k += 2) out.texcoords.emplace_back(values[k], values[k + 1]);
          }
        });
    const size_t num_corners = out.corners.size() - begin;
    if (textured && out.texcoords.size() != out.starts.back() + num_corners) {
      data->Malformed("a texcoord list needs two values a corner");
    }
    if (!textured) out.texcoords.resize(out.starts.back() + num_corners, Eigen::Vector2d::Zero());  // unused
    out.textured.push_back(textured);
    out.starts.push_back(out.corners.size());
  }
  return out;
}

// Polygons into triangles, indices checked against the vertex count (the
// vertex element may follow the face element).
PolygonSoup Assemble(const std::string& path, PlyVertices vertices, const PlyFaces& faces) {
  PolygonSoup soup;
  soup.positions = std::move(vertices.positions);
  const bool face_uv = std::find(faces.textured.begin(), faces.textured.end(), true) != faces.textured.end();
  const bool vertex_uv = !vertices.texcoords.empty();
  std::vector<int> corners;
  std::vector<Eigen::Vector2d> uv;
  for (size_t f = 0; f + 1 < faces.starts.size(); ++f) {
    corners.assign(faces.corners.begin() + faces.starts[f], faces.corners.begin() + faces.starts[f + 1]);
    uv.clear();
    for (size_t k = 0; k < corners.size(); ++k) {
      if (corners[k] >= static_cast<int>(soup.positions.size())) {
        FailMeshRead(path, "malformed: face " + std::to_string(f) + ": vertex index " + std::to_string(corners[k]) +
                               " out of range (" + std::to_string(soup.positions.size()) + " vertices)");
      }
      if (faces.textured[f]) {
        uv.push_back(faces.texcoords[faces.starts[f] + k]);
      } else if (face_uv || vertex_uv) {
        uv.push_back(vertex_uv ? vertices.texcoords[corners[k]] : Eigen::Vector2d::Zero());
      }
    }
    AppendPolygon(corners, face_uv || vertex_uv ? &uv : nullptr, &soup);
  }
  return soup;
}

}  // namespace

bool LooksLikePly(const std::string& path) {
  if (LowercaseExtension(path) == ".ply") return true;
  std::ifstream in(path, std::ios::binary);
  char magic[4] = {};
  in.read(magic, 4);
  return in && std::memcmp(magic, "ply", 3) == 0 && (magic[3] == '\n' || magic[3] == '\r');
}

PolygonSoup ReadPly(const std::string& path) {
  const std::string bytes = ReadWholeFile(path);
  const PlyHeader header = ReadHeader(path, bytes);
  PlyData data(path, bytes, header.data_begin, header.format);
  PlyVertices vertices;
  PlyFaces faces;
  bool vertices_read = false, faces_read = false;
  std::vector<double> list;
  for (const PlyElement& element : header.elements) {
    CheckCount(path, element, data);
    if (element.name == "vertex" && !vertices_read) {
      vertices = ReadVertices(path, element, &data);
      vertices_read = true;
    } else if (element.name == "face" && !faces_read) {
      faces = ReadFaces(path, element, &data);
      faces_read = true;
    } else if (!element.properties.empty()) {
      // An element without properties takes no bytes, whatever its count
      // (found by tests/fuzz: a count of 1e100 looped).
      for (double i = 0.0; i < element.count; ++i) {
        data.Enter(element, i);
        ReadInstance(
            element, &data, &list, [](int, double) {}, [](int, const std::vector<double>&) {});
      }
    }
    if (vertices_read && faces_read) break;  // what follows is not read
  }
  if (!vertices_read) FailMeshRead(path, "no vertex element");
  return Assemble(path, std::move(vertices), faces);
}

}  // namespace polyfit
