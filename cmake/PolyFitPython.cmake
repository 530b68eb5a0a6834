# The Python package `polyfit` (pybind11): its compiled modules go to
# build/python/polyfit beside the package's __init__.py, so that
# PYTHONPATH=build/python imports it without installing. Built when an
# interpreter with NumPy and pybind11 is found (Debian: python3-dev
# python3-numpy pybind11-dev); otherwise skipped with a message.
option(POLYFIT_BUILD_PYTHON "Build the Python package polyfit (pybind11, NumPy)" ON)
set(POLYFIT_PYTHON_DIR ${CMAKE_BINARY_DIR}/python)
set(POLYFIT_PYTHON_INSTALL_DIR ${CMAKE_INSTALL_LIBDIR}/python3/dist-packages
    CACHE PATH "Where `make install` puts the package polyfit (relative to the prefix)")
set(POLYFIT_PYTHON OFF)

# The first python3 that imports NumPy, preferring one that also has
# pytest (for the tests): a pyenv or virtualenv interpreter first on PATH
# often has neither, Debian's /usr/bin/python3 has them once installed.
# pybind11 itself comes from CMake (pybind11-dev); its Python module
# (python3-pybind11, only recommended by pybind11-dev) is not needed.
function(polyfit_find_python_with_numpy out)
  find_program(path_python python3 NO_CACHE)
  foreach(imports "numpy, pytest" "numpy")
    foreach(candidate ${path_python} /usr/bin/python3)
      execute_process(COMMAND ${candidate} -c "import ${imports}" RESULT_VARIABLE failed OUTPUT_QUIET ERROR_QUIET)
      if(NOT failed)
        set(${out} ${candidate} PARENT_SCOPE)
        return()
      endif()
    endforeach()
  endforeach()
  set(${out} "" PARENT_SCOPE)
endfunction()

if(POLYFIT_BUILD_PYTHON)
  if(NOT Python3_EXECUTABLE)
    polyfit_find_python_with_numpy(found_python)
    if(found_python)
      set(Python3_EXECUTABLE ${found_python} CACHE FILEPATH "Python for the bindings and their tests")
    endif()
  endif()
  if(Python3_EXECUTABLE)
    find_package(Python3 COMPONENTS Interpreter Development.Module)
    find_package(pybind11 CONFIG QUIET)
  endif()
  if(Python3_FOUND AND pybind11_FOUND)
    set(POLYFIT_PYTHON ON)
    message(STATUS "Python package: ${Python3_EXECUTABLE}, pybind11 ${pybind11_VERSION}")
  else()
    message(STATUS "Python package skipped: no python3 with NumPy, or no pybind11 (apt-get install python3-dev "
                   "python3-numpy pybind11-dev)")
  endif()
endif()

# polyfit_python_module(NAME SOURCE LIBS ...): the compiled module
# polyfit.NAME.
function(polyfit_python_module name source)
  cmake_parse_arguments(ARG "" "" "LIBS" ${ARGN})
  set(target polyfit_python${name})
  # NO_EXTRAS: no link-time optimisation (minutes of linking on 2 cores).
  pybind11_add_module(${target} MODULE NO_EXTRAS ${source})
  set_target_properties(${target} PROPERTIES OUTPUT_NAME ${name}
                                             LIBRARY_OUTPUT_DIRECTORY ${POLYFIT_PYTHON_DIR}/polyfit)
  target_link_libraries(${target} PRIVATE ${ARG_LIBS} nlohmann_json::nlohmann_json)
  polyfit_target_options(${target})
  install(TARGETS ${target} LIBRARY DESTINATION ${POLYFIT_PYTHON_INSTALL_DIR}/polyfit)
endfunction()

# polyfit_python_test(NAME FILE [ENV VAR=VALUE...]): a pytest file run by
# CTest against the build tree's package. Tests needing ../shared/data look
# for it through POLYFIT_SHARED_DATA_DIR and skip with a message when it is
# absent.
function(polyfit_python_test name file)
  cmake_parse_arguments(ARG "" "" "ENV" ${ARGN})
  if(NOT POLYFIT_PYTHON)
    return()
  endif()
  execute_process(COMMAND ${Python3_EXECUTABLE} -c "import pytest" RESULT_VARIABLE no_pytest OUTPUT_QUIET ERROR_QUIET)
  if(no_pytest)
    message(STATUS "Python test ${name} skipped: no pytest for ${Python3_EXECUTABLE} (apt-get install python3-pytest)")
    return()
  endif()
  # Under the sanitizers the interpreter is not instrumented: their runtime
  # is preloaded, and leak detection left to the C++ tests (CPython keeps
  # its allocations to the end by design).
  set(sanitizer_env "")
  if(POLYFIT_SANITIZE)
    set(runtime libasan.so)
    if(POLYFIT_SANITIZE MATCHES "thread")
      set(runtime libtsan.so)
    endif()
    execute_process(COMMAND ${CMAKE_CXX_COMPILER} -print-file-name=${runtime} OUTPUT_VARIABLE preload
                    OUTPUT_STRIP_TRAILING_WHITESPACE)
    # libstdc++ too: the runtime's __cxa_throw interceptor must find it
    # loaded, and the interpreter does not link it.
    execute_process(COMMAND ${CMAKE_CXX_COMPILER} -print-file-name=libstdc++.so OUTPUT_VARIABLE libstdcxx
                    OUTPUT_STRIP_TRAILING_WHITESPACE)
    set(sanitizer_env "LD_PRELOAD=${preload} ${libstdcxx};ASAN_OPTIONS=detect_leaks=0:halt_on_error=1")
  endif()
  add_test(NAME ${name} COMMAND ${Python3_EXECUTABLE} -m pytest -q -p no:cacheprovider --import-mode=importlib ${file})
  set_tests_properties(${name} PROPERTIES ENVIRONMENT
    "PYTHONPATH=${POLYFIT_PYTHON_DIR};POLYFIT_BIN_DIR=${CMAKE_BINARY_DIR}/bin;POLYFIT_SHARED_DATA_DIR=${PROJECT_SOURCE_DIR}/../shared/data;POLYFIT_SOURCE_DIR=${PROJECT_SOURCE_DIR};${ARG_ENV};${sanitizer_env}")
endfunction()
