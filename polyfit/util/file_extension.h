// A file name's extension, for telling formats apart.
#ifndef POLYFIT_UTIL_FILE_EXTENSION_H_
#define POLYFIT_UTIL_FILE_EXTENSION_H_

#include <cctype>
#include <filesystem>
#include <string>

namespace polyfit {

// The extension with its dot, in lower case: "mesh.PLY" gives ".ply".
inline std::string LowercaseExtension(const std::filesystem::path& path) {
  std::string extension = path.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension;
}

}  // namespace polyfit

#endif  // POLYFIT_UTIL_FILE_EXTENSION_H_
