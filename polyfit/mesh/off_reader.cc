#include "polyfit/mesh/off_reader.h"

#include <cmath>
#include <fstream>
#include <string_view>
#include <vector>

#include "polyfit/mesh/mesh_io.h"
#include "polyfit/mesh/text_reading.h"
#include "polyfit/util/file_extension.h"
#include "polyfit/util/parse_number.h"

namespace polyfit {
namespace {

// What an OFF keyword's prefixes declare about each vertex line.
// (A colour, C, sits between the normal and the texture coordinates, which
// are read as the line's last two numbers: it needs no flag.)
struct OffVariant {
  bool texcoords = false;  // ST
  bool normals = false;    // N
};

// The prefixes of "OFF" in the order the format fixes (ST, C, N, 4, n);
// false when `word` is not an OFF keyword.
bool ParseKeyword(std::string_view word, OffVariant* variant, bool* other_dimension) {
  if (word.size() < 3 || word.substr(word.size() - 3) != "OFF") return false;
  std::string_view prefix = word.substr(0, word.size() - 3);
  const auto take = [&prefix](std::string_view p) {
    if (prefix.substr(0, p.size()) != p) return false;
    prefix.remove_prefix(p.size());
    return true;
  };
  variant->texcoords = take("ST");
  take("C");
  variant->normals = take("N");
  *other_dimension = take("4");
  *other_dimension |= take("n");
  return prefix.empty();
}

// The file's lines in order, each split into its words with '#' comments
// removed; blank lines are skipped and numbered all the same.
class OffLines {
 public:
  OffLines(const std::string& path, std::string text) : path_(path), text_(std::move(text)) {}

  bool NextWords(std::vector<std::string_view>* words) {
    words->clear();
    while (words->empty() && next_ < text_.size()) {
      size_t end = text_.find('\n', next_);
      if (end == std::string::npos) end = text_.size();
      const std::string_view line(text_.data() + next_, end - next_);
      next_ = end + 1;
      ++line_number_;
      SplitWords(line.substr(0, line.find('#')), words);
    }
    return !words->empty();
  }

  // The next non-blank line as numbers; false at the end of the file.
  bool NextNumbers(std::vector<double>* values) {
    if (!NextWords(&words_)) return false;
    values->clear();
    for (std::string_view word : words_) {
      double value = 0.0;
      if (!ParseNumber(word, &value)) Malformed("'" + std::string(word) + "' is not a number");
      if (!std::isfinite(value)) Malformed("a non-finite value");
      values->push_back(value);
    }
    return true;
  }

  [[noreturn]] void Malformed(const std::string& what) const {
    FailMeshRead(path_, "malformed: line " + std::to_string(line_number_) + ": " + what);
  }
  size_t size() const { return text_.size(); }

 private:
  const std::string& path_;
  const std::string text_;
  size_t next_ = 0;
  int line_number_ = 0;
  std::vector<std::string_view> words_;
};

// The keyword line, and the counts on it or on the next line.
void ReadHeader(const std::string& path, OffLines* lines, OffVariant* variant, double* num_vertices,
                double* num_faces) {
  std::vector<std::string_view> words;
  bool other_dimension = false;
  if (!lines->NextWords(&words)) FailMeshRead(path, "holds no OFF header");
  // The keyword is optional (Geomview's definition): without it, the first
  // line holds the counts.
  const bool keyword = ParseKeyword(words[0], variant, &other_dimension);
  if (other_dimension) FailMeshRead(path, "'" + std::string(words[0]) + "': only three-dimensional OFF is read");
  if (keyword && words.size() > 1 && words[1] == "BINARY") {
    FailMeshRead(path, "binary OFF is not read; convert it to ASCII OFF or PLY");
  }
  std::vector<double> counts;
  for (size_t i = keyword ? 1 : 0; i < words.size(); ++i) {
    double value = 0.0;
    if (!ParseNumber(words[i], &value)) lines->Malformed("'" + std::string(words[i]) + "' is not a count");
    counts.push_back(value);
  }
  if (counts.empty() && !lines->NextNumbers(&counts)) FailMeshRead(path, "truncated: no vertex and face counts");
  if (counts.size() < 2 || counts.size() > 3) lines->Malformed("expected the counts '#vertices #faces [#edges]'");
  for (double c : counts) {
    if (!(c >= 0.0) || c != std::floor(c)) lines->Malformed("a count must be a whole number, at least 0");
  }
  *num_vertices = counts[0];
  *num_faces = counts[1];
  // "0 0 0\n" a vertex and "0\n" a face at the least: counts are checked
  // against the file before anything is allocated for them.
  if (6.0 * counts[0] + 2.0 * counts[1] > static_cast<double>(lines->size())) {
    FailMeshRead(path, "the header declares " + CountText(counts[0]) + " vertices and " + CountText(counts[1]) +
                           " faces, more than its " + CountText(static_cast<double>(lines->size())) +
                           " bytes can hold");
  }
}

[[noreturn]] void Truncated(const std::string& path, int vertices, int num_vertices, int faces, int num_faces) {
  FailMeshRead(path, "truncated: " + std::to_string(vertices) + " of " + std::to_string(num_vertices) +
                         " vertices and " + std::to_string(faces) + " of " + std::to_string(num_faces) + " faces");
}

}  // namespace

bool LooksLikeOff(const std::string& path) {
  if (LowercaseExtension(path) == ".off") return true;
  std::ifstream in(path, std::ios::binary);
  std::string word;
  while (in >> word && word[0] == '#') in.ignore(1 << 20, '\n');
  OffVariant variant;
  bool other_dimension = false;
  return ParseKeyword(word, &variant, &other_dimension);
}

PolygonSoup ReadOff(const std::string& path) {
  OffLines lines(path, ReadWholeFile(path));
  OffVariant variant;
  double declared_vertices = 0.0, declared_faces = 0.0;
  ReadHeader(path, &lines, &variant, &declared_vertices, &declared_faces);
  const int num_vertices = static_cast<int>(declared_vertices), num_faces = static_cast<int>(declared_faces);

  PolygonSoup soup;
  soup.positions.reserve(num_vertices);
  std::vector<Eigen::Vector2d> vertex_texcoords;
  const size_t least = 3 + (variant.normals ? 3 : 0) + (variant.texcoords ? 2 : 0);
  std::vector<double> values;
  for (int v = 0; v < num_vertices; ++v) {
    if (!lines.NextNumbers(&values)) Truncated(path, v, num_vertices, 0, num_faces);
    if (values.size() < least) {
      lines.Malformed("a vertex needs three coordinates" +
                      std::string(least > 3 ? " and what the keyword declares" : ""));
    }
    soup.positions.emplace_back(values[0], values[1], values[2]);
    if (variant.texcoords) vertex_texcoords.emplace_back(values[values.size() - 2], values.back());
  }

  std::vector<int> corners;
  std::vector<Eigen::Vector2d> corner_uv;
  for (int f = 0; f < num_faces; ++f) {
    if (!lines.NextNumbers(&values)) Truncated(path, num_vertices, num_vertices, f, num_faces);
    const double count = values[0];
    if (!(count >= 1.0) || count != std::floor(count) || count + 1.0 > static_cast<double>(values.size())) {
      lines.Malformed("a face needs a corner count of at least 1 and that many indices");
    }
    corners.clear();
    corner_uv.clear();
    for (size_t k = 1; k <= static_cast<size_t>(count); ++k) {
      if (!(values[k] >= 0.0 && values[k] < declared_vertices) || values[k] != std::floor(values[k])) {
        lines.Malformed("a face index out of range (" + CountText(values[k]) + " of " + std::to_string(num_vertices) +
                        " vertices)");
      }
      corners.push_back(static_cast<int>(values[k]));
      if (variant.texcoords) corner_uv.push_back(vertex_texcoords[corners.back()]);
    }
    AppendPolygon(corners, variant.texcoords ? &corner_uv : nullptr, &soup);
  }
  return soup;
}

}  // namespace polyfit
