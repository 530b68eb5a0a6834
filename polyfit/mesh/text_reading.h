// What PolyFit's mesh readers (OFF, PLY, OBJ, and mesh_io's checks) share:
// errors that name the file, counts as text, whole files, words of a line.
#ifndef POLYFIT_MESH_TEXT_READING_H_
#define POLYFIT_MESH_TEXT_READING_H_

#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>
#include <vector>

#include "polyfit/mesh/mesh_io.h"

namespace polyfit {

[[noreturn]] inline void FailMeshRead(const std::string& path, const std::string& reason) {
  throw MeshIoError(path + ": " + reason);
}

// A count or index as a whole number of any size: a header may declare
// 1e24 (converting it to an integer first would overflow).
inline std::string CountText(double count) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.0f", count);
  return text;
}

inline std::string ReadWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) FailMeshRead(path, "cannot be opened for reading");
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// The words of `line`, separated by blanks (space, tab, CR, VT, FF).
inline void SplitWords(std::string_view line, std::vector<std::string_view>* words) {
  const auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; };
  words->clear();
  for (size_t i = 0; i < line.size();) {
    while (i < line.size() && blank(line[i])) ++i;
    size_t j = i;
    while (j < line.size() && !blank(line[j])) ++j;
    if (j > i) words->push_back(line.substr(i, j - i));
    i = j;
  }
}

}  // namespace polyfit

#endif  // POLYFIT_MESH_TEXT_READING_H_
