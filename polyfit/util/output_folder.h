// What an earlier run left in an output folder, said before a new run
// replaces it. Every file PolyFit writes goes through WriteFileAtomically,
// so a killed run leaves complete files and, at most, the temporaries it
// was filling (name.tmp<thread>_<n>): those are removed here. A run's last
// file (`marker`, e.g. metrics.json) says whether it finished.
#ifndef POLYFIT_UTIL_OUTPUT_FOLDER_H_
#define POLYFIT_UTIL_OUTPUT_FOLDER_H_

#include <string>

namespace polyfit {

struct OutputFolderState {
  bool exists = false;
  bool finished = false;        // the marker is there
  int files = 0;                // complete files, in all subfolders
  int removed_temporaries = 0;  // half-written files of a killed run

  // One line for the log: empty for a folder that is absent or empty.
  std::string Describe(const std::string& dir, const std::string& marker) const;
};

// Looks through `dir` (recursively), removing WriteFileAtomically's
// temporaries. Throws Error (kOutput) naming a temporary it cannot remove.
OutputFolderState CleanOutputFolder(const std::string& dir, const std::string& marker);

// True for a WriteFileAtomically temporary's file name.
bool IsAtomicWriteTemporary(const std::string& file_name);

}  // namespace polyfit

#endif  // POLYFIT_UTIL_OUTPUT_FOLDER_H_
