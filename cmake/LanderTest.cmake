# lander_add_tests(DIR <dir> NAME <prefix> LIBS <libs...> [DEFS <defs...>] [DEPENDS <targets>])
# Registers every <dir>/*_test.cpp. Files are grouped by CTest label, taken from the file
# name: *_render_test.cpp -> render, *_integration_test.cpp -> integration, else unit. Each
# group is one executable (<prefix>_<label>_tests; fewer executables build and link faster
# on a 2-core machine); every gtest case becomes one CTest test (gtest_discover_tests), run in
# its own process. <dir>/support/*.cpp is linked into every group of the folder.
function(lander_add_tests)
  cmake_parse_arguments(ARG "" "DIR;NAME" "LIBS;DEFS;DEPENDS" ${ARGN})
  file(GLOB test_sources CONFIGURE_DEPENDS "${ARG_DIR}/*_test.cpp")
  file(GLOB support_sources CONFIGURE_DEPENDS "${ARG_DIR}/support/*.cpp")
  # The synthetic camera of the vision tests is test support, not the system under test: under
  # the sanitizers it is compiled without them (its per-supersample loops were ~40 % of a
  # rendered test's time there); the detector and pose code it feeds stay instrumented.
  if(LANDER_SANITIZE)
    foreach(src IN LISTS support_sources)
      if(src MATCHES "/vision_synth\\.cpp$")
        set_source_files_properties("${src}" PROPERTIES
          COMPILE_OPTIONS "-fno-sanitize=all" SKIP_PRECOMPILE_HEADERS ON)
      endif()
    endforeach()
  endif()
  set(unit_sources "")
  set(render_sources "")
  set(integration_sources "")
  foreach(src IN LISTS test_sources)
    get_filename_component(name "${src}" NAME_WE)
    if(name MATCHES "_render_test$")
      list(APPEND render_sources "${src}")
    elseif(name MATCHES "_integration_test$")
      list(APPEND integration_sources "${src}")
    else()
      list(APPEND unit_sources "${src}")
    endif()
  endforeach()
  foreach(label unit render integration)
    if(NOT ${label}_sources)
      continue()
    endif()
    set(exe ${ARG_NAME}_${label}_tests)
    add_executable(${exe} ${${label}_sources} ${support_sources})
    target_link_libraries(${exe} PRIVATE ${ARG_LIBS} lander_flags GTest::gtest GTest::gtest_main)
    target_include_directories(${exe} PRIVATE "${CMAKE_SOURCE_DIR}/tests")
    # The controller's and the campaign's tests do not see OpenCV (the controller's boundary).
    if(ARG_NAME STREQUAL "controller" OR ARG_NAME STREQUAL "campaign")
      target_precompile_headers(${exe} PRIVATE <gtest/gtest.h> <cmath> ${LANDER_PCH_BASE})
    else()
      target_precompile_headers(${exe} PRIVATE <gtest/gtest.h> <cmath> ${LANDER_PCH_VISION})
    endif()
    if(ARG_DEFS)
      target_compile_definitions(${exe} PRIVATE ${ARG_DEFS})
    endif()
    if(ARG_DEPENDS)
      add_dependencies(${exe} ${ARG_DEPENDS})
    endif()
    gtest_discover_tests(${exe}
      PROPERTIES LABELS ${label}
      DISCOVERY_TIMEOUT 120
      DISCOVERY_MODE PRE_TEST)
  endforeach()
endfunction()
