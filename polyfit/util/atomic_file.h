// WriteFileAtomically(path, write): write(stream) fills a temporary file
// beside path, which then replaces path by rename, so readers never see a
// half-written file and a failure leaves nothing behind. Throws Error
// (kOutput) naming the file when anything fails.
#ifndef POLYFIT_UTIL_ATOMIC_FILE_H_
#define POLYFIT_UTIL_ATOMIC_FILE_H_

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>

#include "polyfit/util/status.h"

namespace polyfit {
namespace internal {

// Crash injection for the kill-safety tests (tests/kill_safety_test.py):
// with POLYFIT_KILL_AT_WRITE=N in the environment, the process kills itself
// (SIGKILL, no clean-up) when its Nth atomically written file is filled
// and not yet renamed, the worst moment for a crash. Unset: one load of a
// static per write.
inline void KillPointForTesting() {
  static const long kill_at = [] {
    const char* value = std::getenv("POLYFIT_KILL_AT_WRITE");
    return value ? std::atol(value) : 0L;
  }();
  if (kill_at <= 0) return;
  static std::atomic<long> writes{0};
  if (writes.fetch_add(1) + 1 == kill_at) std::raise(SIGKILL);
}

}  // namespace internal

template <typename WriteFn>
void WriteFileAtomically(const std::string& path, WriteFn&& write) {
  namespace fs = std::filesystem;
  static std::atomic<unsigned> counter{0};
  const std::string temp = path + ".tmp" +
                           std::to_string(std::hash<std::thread::id>{}(std::this_thread::get_id()) % 100000) + "_" +
                           std::to_string(counter.fetch_add(1));
  auto remove_temp = [&temp] {
    std::error_code ec;
    fs::remove(temp, ec);
  };
  try {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) throw Error(ErrorKind::kOutput, path + ": cannot be opened for writing");
    write(out);
    out.flush();
    if (!out) throw Error(ErrorKind::kOutput, path + ": writing failed (disk full?)");
    out.close();
    internal::KillPointForTesting();
    std::error_code ec;
    fs::rename(temp, path, ec);
    if (ec) throw Error(ErrorKind::kOutput, path + ": cannot be replaced: " + ec.message());
  } catch (...) {
    remove_temp();
    throw;
  }
}

}  // namespace polyfit

#endif  // POLYFIT_UTIL_ATOMIC_FILE_H_
