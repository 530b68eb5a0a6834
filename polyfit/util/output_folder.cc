#include "polyfit/util/output_folder.h"

#include <filesystem>
#include <regex>
#include <system_error>
#include <vector>

#include "polyfit/util/status.h"

namespace polyfit {

bool IsAtomicWriteTemporary(const std::string& file_name) {
  // WriteFileAtomically: path + ".tmp" + thread hash + "_" + counter.
  static const std::regex pattern(R"(.+\.tmp[0-9]+_[0-9]+)");
  return std::regex_match(file_name, pattern);
}

OutputFolderState CleanOutputFolder(const std::string& dir, const std::string& marker) {
  namespace fs = std::filesystem;
  OutputFolderState state;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return state;
  state.exists = true;
  state.finished = fs::is_regular_file(fs::path(dir) / marker, ec);
  std::vector<fs::path> temporaries;
  for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    if (IsAtomicWriteTemporary(it->path().filename().string())) {
      temporaries.push_back(it->path());
    } else {
      ++state.files;
    }
  }
  for (const fs::path& temporary : temporaries) {
    if (!fs::remove(temporary, ec) || ec) {
      throw Error(ErrorKind::kOutput, temporary.string() + ": a half-written file of an earlier run cannot be removed" +
                                          (ec ? ": " + ec.message() : std::string()));
    }
    ++state.removed_temporaries;
  }
  return state;
}

std::string OutputFolderState::Describe(const std::string& dir, const std::string& marker) const {
  if (!exists || (files == 0 && removed_temporaries == 0)) return {};
  std::string line = dir + ": ";
  line += finished ? "an earlier run finished here" : "an earlier run was interrupted here (no " + marker + ")";
  line += " and left " + std::to_string(files) + " complete file" + (files == 1 ? "" : "s");
  if (removed_temporaries > 0) {
    line += " and " + std::to_string(removed_temporaries) + " half-written one" +
            (removed_temporaries == 1 ? "" : "s") + ", removed";
  }
  return line + "; this run replaces its outputs";
}

}  // namespace polyfit
