# lander_add_tests(DIR <dir> LIBS <libs...> [DEFS <compile definitions...>] [DEPENDS <targets>])
# Registers every <dir>/*_test.cpp as one GoogleTest executable. The CTest label comes from
# the file name: *_render_test.cpp -> render, *_integration_test.cpp -> integration,
# anything else -> unit. Each gtest case becomes one CTest test (gtest_discover_tests).
function(lander_add_tests)
  cmake_parse_arguments(ARG "" "DIR" "LIBS;DEFS;DEPENDS" ${ARGN})
  file(GLOB test_sources CONFIGURE_DEPENDS "${ARG_DIR}/*_test.cpp")
  file(GLOB support_sources CONFIGURE_DEPENDS "${ARG_DIR}/support/*.cpp")
  foreach(src IN LISTS test_sources)
    get_filename_component(name "${src}" NAME_WE)
    if(name MATCHES "_render_test$")
      set(label render)
    elseif(name MATCHES "_integration_test$")
      set(label integration)
    else()
      set(label unit)
    endif()
    add_executable(${name} "${src}" ${support_sources})
    target_link_libraries(${name} PRIVATE ${ARG_LIBS} lander_flags GTest::gtest GTest::gtest_main)
    target_include_directories(${name} PRIVATE "${CMAKE_SOURCE_DIR}/tests")
    if(ARG_DEFS)
      target_compile_definitions(${name} PRIVATE ${ARG_DEFS})
    endif()
    if(ARG_DEPENDS)
      add_dependencies(${name} ${ARG_DEPENDS})
    endif()
    gtest_discover_tests(${name}
      PROPERTIES LABELS ${label}
      DISCOVERY_TIMEOUT 60
      DISCOVERY_MODE PRE_TEST)
  endforeach()
endfunction()
