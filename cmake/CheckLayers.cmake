# cmake -DROOT=<source dir> -P CheckLayers.cmake
# Fails when an include crosses the layers of docs/architecture.md:
# polyfit/jet and cost_functions use only themselves (and Ceres, Eigen);
# polyfit/ never includes sft/ or drape/; sft/ and drape/ never include
# each other. Tests (*_test.cc) may use any layer.
set(rules
  "polyfit/jet|cost_functions/|sft/|drape/|polyfit/(patch|synthetic|eval|util|mesh|cluster|model|pipeline|tools)/"
  "cost_functions|sft/|drape/|polyfit/(patch|synthetic|eval|util|mesh|cluster|model|pipeline|tools)/"
  "polyfit|sft/|drape/"
  "sft|drape/"
  "drape|sft/")
set(violations "")
foreach(rule ${rules})
  string(REPLACE "|" ";" parts "${rule}")
  list(GET parts 0 folder)
  list(REMOVE_AT parts 0)
  string(REPLACE ";" "|" forbidden "${parts}")
  file(GLOB_RECURSE sources "${ROOT}/${folder}/*.h" "${ROOT}/${folder}/*.cc")
  foreach(source ${sources})
    if(source MATCHES "_test\\.cc$" OR (folder STREQUAL "polyfit" AND source MATCHES "/polyfit/jet/"))
      continue()  # tests may use any layer; the jet rule above is stricter
    endif()
    file(STRINGS "${source}" includes REGEX "^#include \"")
    foreach(line ${includes})
      string(REGEX REPLACE "^#include \"([^\"]+)\".*" "\\1" header "${line}")
      if(header MATCHES "^(${forbidden})")
        file(RELATIVE_PATH relative "${ROOT}" "${source}")
        string(APPEND violations "  ${relative} includes ${header}\n")
      endif()
    endforeach()
  endforeach()
endforeach()
if(violations)
  message(FATAL_ERROR "Includes that cross the layers (docs/architecture.md):\n${violations}")
endif()
message(STATUS "layers: no include crosses them")
