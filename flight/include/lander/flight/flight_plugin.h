// Flight plugins: a shared library that creates a FlightSoftware (flight_software.h) from the
// run's flight configuration. `lander run SCENARIO --flight-plugin LIB.so`, or the scenario
// key `flight.plugin: PATH` (relative to the scenario file), loads it.
//
// The C ABI a plugin exports (the macro LANDER_FLIGHT_PLUGIN below writes all three):
//
//   int lander_flight_plugin_api_version(void);
//       kFlightSoftwareApiVersion of the headers the plugin was built against. A plugin whose
//       version differs from the simulator's is refused before anything else is called.
//   lander::flight::FlightSoftware* lander_flight_plugin_create(
//       const LanderFlightPluginArgs* args, char* error, size_t error_size);
//       A new flight software, or null with a message in `error` (NUL-terminated, truncated
//       to error_size). Must not throw.
//   void lander_flight_plugin_destroy(lander::flight::FlightSoftware* fs);
//       Deletes what create returned (memory allocated inside the plugin is freed there).
//
// The interface itself is C++ (flight_software.h): a plugin must be built with the same
// compiler family and standard library as the simulator (Debian 12's GCC 12 and libstdc++),
// which the API version alone cannot check. Build plugins with -fvisibility=hidden and, when
// they link the project's static libraries, -Wl,--exclude-libs,ALL (cmake/LanderPlugin.cmake
// does both), so that only the three entry points are exported.
#pragma once

#include <cstddef>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "lander/core/params_io.h"
#include "lander/flight/flight_software.h"

extern "C" {
// What the simulator passes to lander_flight_plugin_create.
struct LanderFlightPluginArgs {
  int api_version;                 ///< the simulator's kFlightSoftwareApiVersion
  const char* flight_yaml;         ///< the run's resolved flight configuration (YAML text of
                                   ///< flight.resolved.yaml: every key of flight_config.h)
  const char* plugin_config_yaml;  ///< the scenario's flight.plugin_config mapping (YAML
                                   ///< text; "{}" when absent)
  const char* plugin_path;         ///< the plugin file (absolute; relative paths in
                                   ///< plugin_config are best taken from its folder)
};
}

namespace lander::flight {

// A plugin that cannot be loaded or refuses to create its flight software: the message names
// the file and why (missing, not a shared library, wrong ABI version, no entry point, create
// failed). A bad input: `lander run` exits 2 and writes nothing.
class PluginError : public ConfigError {
 public:
  explicit PluginError(const std::string& message) : ConfigError(message) {}
};

// A plugin's flight software that threw while flying: the message names it and the method.
// A run-time failure: the run's outcome is "error" (exit 1).
class FlightSoftwareError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Where a flight software came from: flight_software.json, run.json and campaign.csv.
struct FlightSoftwareSource {
  std::string kind{"builtin"};  ///< builtin | plugin | python
  std::string plugin_path;      ///< the plugin file, or FILE.py:CLASS (absolute paths)
  std::string plugin_sha256;    ///< sha256 of that file, hex
};

// The sha256 of a file as lower-case hex; throws PluginError naming the file if unreadable.
std::string file_sha256(const std::string& path);

// Loads the plugin at `path` (dlopen, RTLD_NOW | RTLD_LOCAL), checks its API version and
// creates its flight software. The library stays loaded while the returned object lives.
// Throws PluginError.
std::unique_ptr<FlightSoftware> load_flight_plugin(const std::string& path, const std::string& flight_yaml,
                                                   const std::string& plugin_config_yaml);

}  // namespace lander::flight

// For plugin authors: defines the three entry points from a factory
//   std::unique_ptr<lander::flight::FlightSoftware> FACTORY(const LanderFlightPluginArgs& args)
// that may throw (the message reaches the user as the plugin's error).
#define LANDER_FLIGHT_PLUGIN(FACTORY)                                                                   \
  extern "C" __attribute__((visibility("default"))) int lander_flight_plugin_api_version(void) {        \
    return lander::flight::kFlightSoftwareApiVersion;                                                    \
  }                                                                                                     \
  extern "C" __attribute__((visibility("default"))) lander::flight::FlightSoftware*                     \
  lander_flight_plugin_create(const LanderFlightPluginArgs* args, char* error, size_t error_size) {      \
    try {                                                                                               \
      return FACTORY(*args).release();                                                                  \
    } catch (const std::exception& e) {                                                                 \
      if (error && error_size) {                                                                        \
        std::snprintf(error, error_size, "%s", e.what());                                               \
      }                                                                                                 \
    } catch (...) {                                                                                     \
      if (error && error_size) std::snprintf(error, error_size, "%s", "unknown exception");             \
    }                                                                                                   \
    return nullptr;                                                                                     \
  }                                                                                                     \
  extern "C" __attribute__((visibility("default"))) void lander_flight_plugin_destroy(                  \
      lander::flight::FlightSoftware* fs) {                                                             \
    delete fs;                                                                                          \
  }
