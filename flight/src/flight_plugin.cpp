// Loading flight plugins (flight_plugin.h): dlopen, the ABI check, and a wrapper that keeps the
// library loaded while its objects live and names the plugin and the method in every error.
#include "lander/flight/flight_plugin.h"

#include <dlfcn.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <utility>

#include <fmt/format.h>
#include <openssl/evp.h>

namespace lander::flight {

namespace {

using ApiVersionFn = int (*)();
using CreateFn = FlightSoftware* (*)(const LanderFlightPluginArgs*, char*, size_t);
using DestroyFn = void (*)(FlightSoftware*);

// The dlopen handle; closed when the last object of the plugin is gone.
class Library {
 public:
  explicit Library(const std::string& path) : path_(path) {
    // RTLD_LOCAL: the plugin's copies of the project's libraries do not replace ours.
    handle_ = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle_) {
      const char* why = dlerror();
      throw PluginError(fmt::format("flight plugin '{}': cannot load it as a shared library: {}", path,
                                    why ? why : "unknown dlopen error"));
    }
  }
  ~Library() {
    if (handle_) dlclose(handle_);
  }
  Library(const Library&) = delete;
  Library& operator=(const Library&) = delete;

  template <class Fn>
  Fn symbol(const char* name) const {
    dlerror();
    void* p = dlsym(handle_, name);
    if (!p) {
      throw PluginError(fmt::format("flight plugin '{}': no entry point '{}' (a plugin defines it with "
                                    "LANDER_FLIGHT_PLUGIN, lander/flight/flight_plugin.h)",
                                    path_, name));
    }
    return reinterpret_cast<Fn>(p);
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  void* handle_{nullptr};
};

// Runs one call into the plugin; an exception leaves it as a PluginError naming the plugin and
// the method.
template <class F>
auto guarded(const std::string& who, const char* method, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const FlightSoftwareError&) {
    throw;
  } catch (const std::exception& e) {
    throw FlightSoftwareError(fmt::format("flight software '{}' threw in {}: {}", who, method, e.what()));
  } catch (...) {
    throw FlightSoftwareError(fmt::format("flight software '{}' threw in {}: an unknown exception", who, method));
  }
}

// A plugin's frame job: the same calls, guarded; keeps the library loaded.
class PluginFrameJob final : public FrameJob {
 public:
  PluginFrameJob(std::unique_ptr<FrameJob> inner, std::shared_ptr<Library> lib, std::string who)
      : inner_(std::move(inner)), lib_(std::move(lib)), who_(std::move(who)) {}
  ~PluginFrameJob() override { inner_.reset(); }  // before the library may close
  void process() override { guarded(who_, "FrameJob::process", [&] { inner_->process(); }); }
  FrameReport report() const override { return guarded(who_, "FrameJob::report", [&] { return inner_->report(); }); }
  bool inject(const VisionFault& f) override { return guarded(who_, "FrameJob::inject", [&] { return inner_->inject(f); }); }
  std::unique_ptr<FrameJob> release() { return std::move(inner_); }

 private:
  std::unique_ptr<FrameJob> inner_;
  std::shared_ptr<Library> lib_;
  std::string who_;
};

// The plugin's flight software behind the seam: every call forwarded and guarded.
class PluginFlightSoftware final : public FlightSoftware {
 public:
  PluginFlightSoftware(FlightSoftware* inner, DestroyFn destroy, std::shared_ptr<Library> lib)
      : inner_(inner), destroy_(destroy), lib_(std::move(lib)) {
    try {
      info_ = guarded(lib_->path(), "info", [&] { return inner_->info(); });
    } catch (const FlightSoftwareError& e) {
      destroy_(inner_);
      throw PluginError(e.what());
    }
    who_ = info_.name.empty() ? lib_->path() : info_.name;
  }
  ~PluginFlightSoftware() override { destroy_(inner_); }
  PluginFlightSoftware(const PluginFlightSoftware&) = delete;
  PluginFlightSoftware& operator=(const PluginFlightSoftware&) = delete;

  FlightSoftwareInfo info() const override { return info_; }
  void on_baro(const BaroSample& b) override { guarded(who_, "on_baro", [&] { inner_->on_baro(b); }); }
  void on_gps(const GpsSample& g) override { guarded(who_, "on_gps", [&] { inner_->on_gps(g); }); }
  void on_ultrasonic(const UltrasonicSample& u) override {
    guarded(who_, "on_ultrasonic", [&] { inner_->on_ultrasonic(u); });
  }
  void on_mag(const MagSample& m) override { guarded(who_, "on_mag", [&] { inner_->on_mag(m); }); }
  void on_platform_telemetry(const GpsSample& g) override {
    guarded(who_, "on_platform_telemetry", [&] { inner_->on_platform_telemetry(g); });
  }
  std::optional<RotorSpeeds> on_imu(const ImuSample& s) override {
    return guarded(who_, "on_imu", [&] { return inner_->on_imu(s); });
  }
  std::unique_ptr<FrameJob> begin_frame(const CameraFrameIn& frame) override {
    std::unique_ptr<FrameJob> job = guarded(who_, "begin_frame", [&] { return inner_->begin_frame(frame); });
    if (!job) throw FlightSoftwareError(fmt::format("flight software '{}': begin_frame returned no job", who_));
    return std::make_unique<PluginFrameJob>(std::move(job), lib_, who_);
  }
  void deliver_frame(std::unique_ptr<FrameJob> job) override {
    std::unique_ptr<FrameJob> inner = static_cast<PluginFrameJob&>(*job).release();
    guarded(who_, "deliver_frame", [&] { inner_->deliver_frame(std::move(inner)); });
  }
  FlightStatus status() const override { return guarded(who_, "status", [&] { return inner_->status(); }); }
  FlightTelemetry telemetry() const override { return guarded(who_, "telemetry", [&] { return inner_->telemetry(); }); }
  FlightReport report() const override { return guarded(who_, "report", [&] { return inner_->report(); }); }

 private:
  FlightSoftware* inner_;
  DestroyFn destroy_;
  std::shared_ptr<Library> lib_;
  FlightSoftwareInfo info_;
  std::string who_;
};

}  // namespace

std::string file_sha256(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw PluginError(fmt::format("'{}': cannot read it", path));
  std::unique_ptr<EVP_MD_CTX, void (*)(EVP_MD_CTX*)> ctx(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  if (!ctx || EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr) != 1) throw PluginError("sha256: no digest context");
  std::array<char, 1 << 16> buf{};
  while (in) {
    in.read(buf.data(), buf.size());
    if (in.gcount() > 0) EVP_DigestUpdate(ctx.get(), buf.data(), static_cast<size_t>(in.gcount()));
  }
  if (in.bad()) throw PluginError(fmt::format("'{}': read error", path));
  std::array<unsigned char, EVP_MAX_MD_SIZE> md{};
  unsigned int n = 0;
  EVP_DigestFinal_ex(ctx.get(), md.data(), &n);
  std::string hex;
  for (unsigned int i = 0; i < n; ++i) hex += fmt::format("{:02x}", md[i]);
  return hex;
}

std::unique_ptr<FlightSoftware> load_flight_plugin(const std::string& path, const std::string& flight_yaml,
                                                   const std::string& plugin_config_yaml) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    throw PluginError(fmt::format("flight plugin '{}': no such file", path));
  }
  const std::string abs = fs::absolute(path).lexically_normal().string();
  auto lib = std::make_shared<Library>(abs);
  const int version = lib->symbol<ApiVersionFn>("lander_flight_plugin_api_version")();
  if (version != kFlightSoftwareApiVersion) {
    throw PluginError(fmt::format("flight plugin '{}' was built against flight-software API version {}; this "
                                  "simulator has version {}: rebuild the plugin against these headers",
                                  abs, version, kFlightSoftwareApiVersion));
  }
  const auto create = lib->symbol<CreateFn>("lander_flight_plugin_create");
  const auto destroy = lib->symbol<DestroyFn>("lander_flight_plugin_destroy");
  const LanderFlightPluginArgs args{kFlightSoftwareApiVersion, flight_yaml.c_str(), plugin_config_yaml.c_str(),
                                    abs.c_str()};
  std::array<char, 4096> error{};
  FlightSoftware* inner = create(&args, error.data(), error.size());
  if (!inner) {
    throw PluginError(fmt::format("flight plugin '{}' could not create its flight software: {}", abs,
                                  error[0] ? error.data() : "create returned null without a message"));
  }
  return std::make_unique<PluginFlightSoftware>(inner, destroy, std::move(lib));
}

}  // namespace lander::flight
