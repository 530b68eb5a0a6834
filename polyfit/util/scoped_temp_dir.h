// A fresh directory under the system's temporary directory, removed with
// everything in it when the object goes out of scope (tests, scratch work).
#ifndef POLYFIT_UTIL_SCOPED_TEMP_DIR_H_
#define POLYFIT_UTIL_SCOPED_TEMP_DIR_H_

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <string>

namespace polyfit {

class ScopedTempDir {
 public:
  explicit ScopedTempDir(const std::string& prefix = "polyfit") {
    static std::atomic<int> counter{0};
    path_ = std::filesystem::temp_directory_path() /
            (prefix + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~ScopedTempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ScopedTempDir(const ScopedTempDir&) = delete;
  ScopedTempDir& operator=(const ScopedTempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  // path / name, as a string.
  std::string File(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

}  // namespace polyfit

#endif  // POLYFIT_UTIL_SCOPED_TEMP_DIR_H_
