#!/usr/bin/env bash
# The fuzzing configuration: builds build-fuzz/ with clang, libFuzzer and
# address;undefined, then fuzzes every target of tests/fuzz from its corpus.
#   bash cmake/fuzz.sh                 # each target for 10 s (the CTest smoke)
#   bash cmake/fuzz.sh 1000000         # each target for a million executions
#   bash cmake/fuzz.sh 1000000 bvh_fuzzer mhclo_fuzzer
# New inputs go to build-fuzz/tests/fuzz/new_<target>/, findings to
# build-fuzz/findings/<target>/ (crash-*, timeout-*, oom-*): copy one into
# tests/fuzz/corpus/<target>/ once fixed, as a regression.
set -euo pipefail
cd "$(dirname "$0")/.."
runs="${1:-}"
shift || true
if ! command -v clang++ > /dev/null || [ ! -e "$(clang++ -print-file-name=libclang_rt.fuzzer-x86_64.a 2>/dev/null)" ]; then
  echo "cmake/fuzz.sh needs clang and libFuzzer: apt-get install clang libclang-rt-14-dev" >&2
  exit 2
fi
generator=()
[ -f build-fuzz/CMakeCache.txt ] || generator=(-G Ninja)
CXX=clang++ cmake -S . -B build-fuzz "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DPOLYFIT_FUZZ=ON \
      -DPOLYFIT_BUILD_BENCHMARKS=OFF -DPOLYFIT_BUILD_EXAMPLES=OFF -DPOLYFIT_BUILD_PYTHON=OFF -DPOLYFIT_BUILD_MPI=OFF \
      ${POLYFIT_CMAKE_ARGS:-}
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  # Targets with a tracked corpus, and those whose seeds CMake writes.
  mapfile -t targets < <(ls tests/fuzz/corpus build-fuzz/tests/fuzz/generated | grep -v -e '^$' -e ':$' | sort -u)
fi
cmake --build build-fuzz -j2 --target "${targets[@]}"
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:abort_on_error=1"
export LSAN_OPTIONS="suppressions=$PWD/cmake/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
if [ -z "$runs" ]; then
  ctest --test-dir build-fuzz -L fuzz --output-on-failure
  exit
fi
status=0
for t in "${targets[@]}"; do
  new=build-fuzz/tests/fuzz/new_$t findings=build-fuzz/findings/$t
  mkdir -p "$new" "$findings"
  dict=()
  [ -f "tests/fuzz/dict/$t.dict" ] && dict=(-dict="tests/fuzz/dict/$t.dict")
  log=build-fuzz/findings/$t.log
  # Real clips as further seeds, read where they are (as the CTest does),
  # and the seeds tests/fuzz/CMakeLists.txt writes.
  seeds=()
  [ "$t" = bvh_fuzzer ] && [ -d ../shared/data/drape/motion ] && seeds=(../shared/data/drape/motion)
  [ -d "tests/fuzz/corpus/$t" ] && seeds+=("tests/fuzz/corpus/$t")
  [ -d "build-fuzz/tests/fuzz/generated/$t" ] && seeds+=("build-fuzz/tests/fuzz/generated/$t")
  if build-fuzz/bin/$t -runs="$runs" -timeout=1 -rss_limit_mb=2048 -malloc_limit_mb=512 -print_final_stats=1 \
      -artifact_prefix="$findings/" "${dict[@]}" "$new" "${seeds[@]}" > "$log" 2>&1; then
    result=clean
  else
    result="FINDING in $findings (see $log)"
    status=1
  fi
  execs=$(grep -o "number_of_executed_units: [0-9]*" "$log" | grep -o "[0-9]*$" || true)
  cov=$(grep -o "cov: [0-9]*" "$log" | tail -1 | grep -o "[0-9]*$" || true)
  echo "$t: ${execs:-?} executions, coverage ${cov:-?} edges, $result"
done
exit $status
