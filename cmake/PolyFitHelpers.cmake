# Compile options shared by every PolyFit target.
function(polyfit_target_options target)
  target_compile_options(${target} PRIVATE
    $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wno-unused-parameter>
    # GCC 12 false positives inside Eigen's AVX-512 intrinsics.
    $<$<CXX_COMPILER_ID:GNU>:-Wno-maybe-uninitialized -Wno-array-bounds -Wno-stringop-overread -Wno-uninitialized>)
  if(POLYFIT_NATIVE)
    target_compile_options(${target} PRIVATE $<$<CXX_COMPILER_ID:GNU,Clang>:-march=native>)
    # Ceres is linked statically and built for baseline x86-64: Eigen asks
    # that every translation unit agree on heap alignment, which AVX would
    # raise to 32 or 64 bytes here. Eigen's blocked dense kernels are still
    # shared (weak) symbols compiled for two instruction sets: code linked
    # with Ceres avoids Eigen's dense decompositions (drape_solver.cc).
    # The allocation is such a symbol too: under AVX-512 Eigen's default
    # alignment stays 64 bytes whatever EIGEN_MAX_ALIGN_BYTES says, so a
    # translation unit that emits aligned_malloc out of line emits the
    # hand-aligned one, and where the linker keeps it Ceres' inlined free
    # fails on it (onefit_trainer_test, Ceres' Eigen sparse Cholesky:
    # "double free or corruption"). EIGEN_MALLOC_ALREADY_ALIGNED=1 would
    # agree with Ceres but leaves our arrays 16-byte aligned, and then
    # AVX-512 kernels crashed and sums changed with the addresses (training
    # no longer bit-for-bit deterministic): not set.
    target_compile_definitions(${target} PRIVATE EIGEN_MAX_ALIGN_BYTES=16)
  endif()
endfunction()

# polyfit_test(NAME SOURCE [LIBS ...]): one GoogleTest executable beside its
# code, registered with CTest.
function(polyfit_test name source)
  cmake_parse_arguments(ARG "" "" "LIBS" ${ARGN})
  add_executable(${name} ${source})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main)
  polyfit_target_options(${name})
  add_test(NAME ${name} COMMAND ${name})
endfunction()

# polyfit_use_mpi(TARGET TEST NAME FILE): TARGET (a command line) shares its
# work over MPI ranks when started by mpirun (POLYFIT_WITH_MPI), and the
# pytest FILE runs it on a few ranks under CTest.
function(polyfit_use_mpi target)
  cmake_parse_arguments(ARG "" "TEST;FILE" "" ${ARGN})
  target_link_libraries(${target} PRIVATE MPI::MPI_CXX)
  target_compile_definitions(${target} PRIVATE POLYFIT_WITH_MPI)
  if(POLYFIT_BUILD_TESTS)
    polyfit_python_test(${ARG_TEST} ${ARG_FILE} ENV MPIEXEC=${MPIEXEC_EXECUTABLE})
  endif()
endfunction()
