# Install and export, one export set per component, so that
#   find_package(PolyFit CONFIG REQUIRED COMPONENTS cost_functions)
# needs only Ceres and Eigen, and COMPONENTS polyfit adds what the core needs.
include(CMakePackageConfigHelpers)

set(POLYFIT_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/PolyFit)

install(TARGETS polyfit_jet cost_functions EXPORT PolyFitCostFunctionsTargets)
install(TARGETS polyfit EXPORT PolyFitCoreTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})

install(DIRECTORY polyfit/jet DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/polyfit
        FILES_MATCHING PATTERN "*.h" PATTERN "*_test*" EXCLUDE)
install(DIRECTORY cost_functions DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        FILES_MATCHING PATTERN "*.h" PATTERN "*_test*" EXCLUDE)
# cgal_surface_mesh.h is internal to CGAL-heavy units (CGAL is not exported).
foreach(dir patch synthetic eval util mesh cluster model pipeline)
  install(DIRECTORY polyfit/${dir} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/polyfit
          FILES_MATCHING PATTERN "*.h" PATTERN "cgal_surface_mesh.h" EXCLUDE)
endforeach()

install(EXPORT PolyFitCostFunctionsTargets NAMESPACE PolyFit::
        FILE PolyFitCostFunctionsTargets.cmake DESTINATION ${POLYFIT_CMAKE_DIR})
install(EXPORT PolyFitCoreTargets NAMESPACE PolyFit::
        FILE PolyFitCoreTargets.cmake DESTINATION ${POLYFIT_CMAKE_DIR})

configure_package_config_file(cmake/PolyFitConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/PolyFitConfig.cmake
  INSTALL_DESTINATION ${POLYFIT_CMAKE_DIR})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/PolyFitConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/PolyFitConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/PolyFitConfigVersion.cmake
        DESTINATION ${POLYFIT_CMAKE_DIR})
