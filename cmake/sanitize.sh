#!/usr/bin/env bash
# The sanitizer configuration: builds build-<name>/ with POLYFIT_SANITIZE
# and runs the whole CTest suite under it, failing on the first report.
#   bash cmake/sanitize.sh                  # address;undefined (build-asan)
#   bash cmake/sanitize.sh thread           # ThreadSanitizer (build-tsan)
# Extra CMake arguments through POLYFIT_CMAKE_ARGS, as cmake/setup.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
sanitizers="${1:-address;undefined}"
case "$sanitizers" in
  thread) dir=build-tsan ;;
  *) dir=build-asan ;;
esac
generator=()
[ -f "$dir/CMakeCache.txt" ] || generator=(-G Ninja)
cmake -S . -B "$dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release "-DPOLYFIT_SANITIZE=$sanitizers" \
      -DPOLYFIT_BUILD_BENCHMARKS=OFF ${POLYFIT_CMAKE_ARGS:-}
cmake --build "$dir" -j2
# halt_on_error: the first report fails the test. Leaks in third-party
# code are suppressed in cmake/lsan.supp, each with its reason.
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:abort_on_error=1:detect_stack_use_after_return=1"
export LSAN_OPTIONS="suppressions=$PWD/cmake/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1"
ctest --test-dir "$dir" --output-on-failure -j2
