#include "polyfit/mesh/obj_reader.h"

#include <cmath>
#include <string_view>
#include <vector>

#include "polyfit/mesh/mesh_io.h"
#include "polyfit/mesh/text_reading.h"
#include "polyfit/util/parse_number.h"

namespace polyfit {
namespace {

// One OBJ index (1-based, or negative from the end) as a 0-based one in
// [0, count); -1 when it is not.
long long ResolveIndex(std::string_view text, size_t count) {
  double value = 0.0;
  if (!ParseNumber(text, &value) || value != std::floor(value)) return -1;
  const double index = value < 0.0 ? static_cast<double>(count) + value : value - 1.0;
  return index >= 0.0 && index < static_cast<double>(count) ? static_cast<long long>(index) : -1;
}

class ObjParser {
 public:
  explicit ObjParser(const std::string& path) : path_(path) {}

  void Line(std::string_view line, int number) {
    number_ = number;
    SplitWords(line.substr(0, line.find('#')), &words_);
    if (words_.empty()) return;
    if (words_[0] == "v") {
      soup_.positions.emplace_back(Number(1, "a vertex needs three numbers"), Number(2, "a vertex needs three numbers"),
                                   Number(3, "a vertex needs three numbers"));
    } else if (words_[0] == "vt") {
      texcoords_.emplace_back(Number(1, "a texture coordinate needs two numbers"),
                              Number(2, "a texture coordinate needs two numbers"));
    } else if (words_[0] == "f") {
      Face();
    }
  }

  PolygonSoup Finish() {
    if (!all_textured_) soup_.corner_texcoords.clear();
    return std::move(soup_);
  }

 private:
  [[noreturn]] void Bad(const std::string& what) const {
    throw MeshIoError(path_ + ": line " + std::to_string(number_) + ": " + what);
  }

  double Number(size_t word, const char* missing) const {
    double value = 0.0;
    if (word >= words_.size()) Bad(missing);
    if (!ParseNumber(words_[word], &value)) Bad("'" + std::string(words_[word].substr(0, 40)) + "' is not a number");
    if (!std::isfinite(value)) Bad("a non-finite value");
    return value;
  }

  void Face() {
    corners_.clear();
    corner_uv_.clear();
    bool textured = true;
    for (size_t w = 1; w < words_.size(); ++w) {
      const std::string_view corner = words_[w];
      const size_t slash = corner.find('/');
      const long long v = ResolveIndex(corner.substr(0, slash), soup_.positions.size());
      if (v < 0) Bad("vertex index out of range in '" + std::string(corner.substr(0, 40)) + "'");
      corners_.push_back(static_cast<int>(v));
      std::string_view uv = slash == std::string_view::npos ? std::string_view() : corner.substr(slash + 1);
      uv = uv.substr(0, uv.find('/'));
      if (uv.empty()) {
        textured = false;
        continue;
      }
      const long long t = ResolveIndex(uv, texcoords_.size());
      if (t < 0) Bad("texture index out of range in '" + std::string(corner.substr(0, 40)) + "'");
      corner_uv_.push_back(texcoords_[t]);
    }
    if (corners_.size() < 3) Bad("a face needs at least three corners");
    all_textured_ = all_textured_ && textured;
    AppendPolygon(corners_, all_textured_ ? &corner_uv_ : nullptr, &soup_);
  }

  const std::string& path_;
  int number_ = 0;
  std::vector<std::string_view> words_;
  PolygonSoup soup_;
  std::vector<Eigen::Vector2d> texcoords_;
  std::vector<int> corners_;
  std::vector<Eigen::Vector2d> corner_uv_;
  bool all_textured_ = true;
};

}  // namespace

PolygonSoup ReadObj(const std::string& path) {
  const std::string text = ReadWholeFile(path);
  ObjParser parser(path);
  int number = 0;
  for (size_t begin = 0; begin < text.size();) {
    size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    parser.Line(std::string_view(text).substr(begin, end - begin), ++number);
    begin = end + 1;
  }
  return parser.Finish();
}

}  // namespace polyfit
