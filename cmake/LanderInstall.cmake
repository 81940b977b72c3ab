# `cmake --install build --prefix P`: the flight software's headers and static libraries, so
# that a plugin builds out of tree with find_package(lander CONFIG) (CMAKE_PREFIX_PATH=P):
#   target_link_libraries(my_plugin PRIVATE lander::flight)   # seam, estimator, controller
#   lander_add_flight_plugin(my_plugin SOURCES ... LIBS lander::flight)
include(CMakePackageConfigHelpers)
foreach(lib core estimator controller flight flags)
  set_target_properties(lander_${lib} PROPERTIES EXPORT_NAME ${lib})  # lander::flight, ...
endforeach()
install(DIRECTORY core/include/ estimator/include/ controller/include/ flight/include/ DESTINATION include)
install(TARGETS lander_core lander_estimator lander_controller lander_flight lander_flags EXPORT landerTargets
        ARCHIVE DESTINATION lib INCLUDES DESTINATION include)
install(EXPORT landerTargets NAMESPACE lander:: DESTINATION lib/cmake/lander)
configure_package_config_file(cmake/landerConfig.cmake.in "${CMAKE_CURRENT_BINARY_DIR}/landerConfig.cmake"
                              INSTALL_DESTINATION lib/cmake/lander)
write_basic_package_version_file("${CMAKE_CURRENT_BINARY_DIR}/landerConfigVersion.cmake"
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES "${CMAKE_CURRENT_BINARY_DIR}/landerConfig.cmake" "${CMAKE_CURRENT_BINARY_DIR}/landerConfigVersion.cmake"
              cmake/LanderPlugin.cmake DESTINATION lib/cmake/lander)
