# lander_add_flight_plugin(<name> SOURCES <files...> [LIBS <libs...>])
# A flight plugin (lander/flight/flight_plugin.h): a MODULE library exporting only the three
# C entry points. The project's static libraries it links stay private to it
# (--exclude-libs), so its copies never interpose on the simulator's; every symbol must be
# resolved at link time (--no-undefined), so a missing library fails the build, not the run.
# Used in this tree and, after `cmake --install`, by out-of-tree plugins
# (find_package(lander) includes this file).
function(lander_add_flight_plugin name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  add_library(${name} MODULE ${ARG_SOURCES})
  set_target_properties(${name} PROPERTIES CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON
                                           PREFIX "lib")
  target_link_libraries(${name} PRIVATE ${ARG_LIBS})
  target_link_options(${name} PRIVATE -Wl,--exclude-libs,ALL)
  # (Under the sanitizers the runtime lives in the executable: a module's __asan_* symbols
  # resolve only at load time.)
  if(NOT LANDER_SANITIZE)
    target_link_options(${name} PRIVATE -Wl,--no-undefined)
  endif()
endfunction()
