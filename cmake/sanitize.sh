#!/usr/bin/env bash
# The sanitizer configuration: builds build-<name>/ with POLYFIT_SANITIZE
# and runs the whole CTest suite under it, failing on the first report.
#   bash cmake/sanitize.sh                  # address;undefined (build-asan)
#   bash cmake/sanitize.sh thread           # ThreadSanitizer (build-tsan), on the
#                                           # tests whose code runs threads
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
# ThreadSanitizer: the tests whose code runs threads (ParallelFor, the
# batch fit, the rasterizer, the PolySfT window, the drape solver, the
# trainer's samples), built alone.
thread_tests=(jet_fit_test fit_mesh_test batch_fit_test soft_rasterizer_test polysft_test polysft_stress_test
              drape_solver_test drape_simulation_test onefit_trainer_test)
if [ "$sanitizers" = thread ]; then
  cmake --build "$dir" -j2 --target "${thread_tests[@]}"
else
  cmake --build "$dir" -j2
fi
# halt_on_error: the first report fails the test. Leaks in third-party
# code are suppressed in cmake/lsan.supp, each with its reason.
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:abort_on_error=1:detect_stack_use_after_return=1"
export LSAN_OPTIONS="suppressions=$PWD/cmake/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/cmake/tsan.supp"
if [ "$sanitizers" = thread ]; then
  ctest --test-dir "$dir" --output-on-failure -j2 -R "^($(IFS='|'; echo "${thread_tests[*]}"))\$"
else
  ctest --test-dir "$dir" --output-on-failure -j2
fi
