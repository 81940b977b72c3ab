// Deliberately bad flight plugins for tests/tools/flight_plugin_integration_test.cpp, one per
// BAD_KIND (tests/tools/plugins/CMakeLists.txt builds each):
//   version  reports another API version       null   create returns null with a message
//   throw    throws in on_imu after 0.5 s       segv   dereferences null in on_imu after 0.5 s
//   hang     never returns from on_imu after 0.5 s (sleeps: no CPU)
// Apart from its fault each flies nothing (rotors at hover speed) and sees nothing.
#include <chrono>
#include <memory>
#include <stdexcept>
#include <thread>

#include "lander/flight/flight_plugin.h"

#define KIND_version 1
#define KIND_null 2
#define KIND_throw 3
#define KIND_segv 4
#define KIND_hang 5
#define CAT(a, b) a##b
#define KIND(k) CAT(KIND_, k)

namespace {

using namespace lander::flight;

constexpr double kFaultAfterS = 0.5;

class NoJob final : public FrameJob {
 public:
  void process() override {}
  FrameReport report() const override {
    FrameReport r;
    r.reason = "not_looking";
    return r;
  }
};

class BadFlight final : public FlightSoftware {
 public:
  FlightSoftwareInfo info() const override { return {"bad_plugin", "0"}; }
  void on_baro(const lander::BaroSample&) override {}
  void on_gps(const lander::GpsSample&) override {}
  void on_ultrasonic(const lander::UltrasonicSample&) override {}
  void on_mag(const lander::MagSample&) override {}
  void on_platform_telemetry(const lander::GpsSample&) override {}
  std::optional<RotorSpeeds> on_imu(const lander::ImuSample& s) override {
    if (s.t_s >= kFaultAfterS) fault();
    return std::nullopt;  // the simulator keeps the hover command
  }
  std::unique_ptr<FrameJob> begin_frame(const CameraFrameIn&) override { return std::make_unique<NoJob>(); }
  void deliver_frame(std::unique_ptr<FrameJob>) override {}
  FlightStatus status() const override { return {}; }
  FlightTelemetry telemetry() const override { return {}; }
  FlightReport report() const override { return {}; }

 private:
  static void fault() {
#if KIND(BAD_KIND) == KIND_throw
    throw std::runtime_error("deliberate failure in the bad plugin");
#elif KIND(BAD_KIND) == KIND_segv
    volatile int* p = nullptr;
    *p = 1;
#elif KIND(BAD_KIND) == KIND_hang
    for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
#endif
  }
};

std::unique_ptr<FlightSoftware> create(const LanderFlightPluginArgs&) {
#if KIND(BAD_KIND) == KIND_null
  throw std::runtime_error("the bad plugin refuses to fly: plugin_config says no");
#endif
  return std::make_unique<BadFlight>();
}

}  // namespace

#if KIND(BAD_KIND) == KIND_version
extern "C" __attribute__((visibility("default"))) int lander_flight_plugin_api_version(void) { return 999; }
extern "C" __attribute__((visibility("default"))) FlightSoftware* lander_flight_plugin_create(const LanderFlightPluginArgs*,
                                                                                             char*, size_t) {
  return nullptr;
}
extern "C" __attribute__((visibility("default"))) void lander_flight_plugin_destroy(FlightSoftware*) {}
#else
LANDER_FLIGHT_PLUGIN(create)
#endif
