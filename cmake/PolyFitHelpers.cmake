# Compile options shared by every PolyFit target.
function(polyfit_target_options target)
  target_compile_options(${target} PRIVATE
    $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wno-unused-parameter>
    # GCC 12 false positives inside Eigen's AVX-512 intrinsics.
    $<$<CXX_COMPILER_ID:GNU>:-Wno-maybe-uninitialized -Wno-array-bounds -Wno-stringop-overread -Wno-uninitialized>)
  if(POLYFIT_NATIVE)
    target_compile_options(${target} PRIVATE $<$<CXX_COMPILER_ID:GNU,Clang>:-march=native>)
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
