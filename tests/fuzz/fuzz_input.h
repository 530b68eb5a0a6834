// What every fuzz target shares. PolyFit's parsers read from paths, so an
// input is written to a scratch file named as the parser expects (under
// /dev/shm where it exists: no disk per execution), and parsed there.
//
// A parser passes on an input when it returns or throws a std::exception
// whose message names the file (or key) it rejects; a crash, a sanitizer
// report, an exception of another kind, an unnamed error, std::bad_alloc
// or std::length_error (a size taken from the input and allocated before
// it was checked) are findings, reported by abort() with the message.
#ifndef POLYFIT_TESTS_FUZZ_FUZZ_INPUT_H_
#define POLYFIT_TESTS_FUZZ_FUZZ_INPUT_H_

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <new>
#include <stdexcept>
#include <string>

namespace polyfit::fuzz {

// This process's scratch folder, removed at exit.
class Scratch {
 public:
  static Scratch& Get() {
    static Scratch scratch;
    return scratch;
  }
  const std::filesystem::path& dir() const { return dir_; }
  // Writes `size` bytes to dir/name (replacing it) and returns its path.
  std::string Write(const std::string& name, const uint8_t* data, size_t size) const {
    const std::string path = (dir_ / name).string();
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    if (!out) {
      std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
      std::abort();
    }
    return path;
  }
  std::string Write(const std::string& name, const std::string& text) const {
    return Write(name, reinterpret_cast<const uint8_t*>(text.data()), text.size());
  }

 private:
  Scratch() {
    const std::filesystem::path shm("/dev/shm");
    const std::filesystem::path root =
        std::filesystem::is_directory(shm) ? shm : std::filesystem::temp_directory_path();
    dir_ = root / ("polyfit_fuzz_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
  }
  ~Scratch() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  std::filesystem::path dir_;
};

[[noreturn]] inline void Finding(const char* what, const std::string& message) {
  std::fprintf(stderr, "fuzz finding: %s: %s\n", what, message.c_str());
  std::abort();
}

// Runs `parse`; see the file comment. `name` (a file name or key) must
// appear in a rejection's message; empty: any non-empty message.
template <class Parse>
void ExpectCleanRejection(Parse&& parse, const std::string& name) {
  try {
    parse();
  } catch (const std::bad_alloc& e) {
    Finding("an allocation sized by the input", e.what());
  } catch (const std::length_error& e) {
    Finding("a size taken from the input unchecked", e.what());
  } catch (const std::exception& e) {
    const std::string message = e.what();
    if (message.empty()) Finding("an error without a message", name);
    if (!name.empty() && message.find(name) == std::string::npos) {
      Finding("an error that does not name the input", "expected '" + name + "' in: " + message);
    }
  } catch (...) {
    Finding("an exception that is not a std::exception", name);
  }
}

}  // namespace polyfit::fuzz

#endif  // POLYFIT_TESTS_FUZZ_FUZZ_INPUT_H_
