// Headless OpenGL context for MuJoCo's renderer: EGL (Mesa surfaceless platform) by default,
// OSMesa as fallback, chosen at run time. All GL/EGL/OSMesa specifics stay in gl_context.cpp.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace lander::sim {

class GlError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class GlBackend { Auto, Egl, OsMesa };

// Parses "auto", "egl" or "osmesa"; throws GlError naming the value otherwise.
GlBackend parse_gl_backend(const std::string& name);
std::string to_string(GlBackend b);

// One GL context, current on the creating thread for its lifetime. Only one may exist per
// process (MuJoCo resolves GL entry points once, from the backend that is loaded).
class GlContext {
 public:
  // Auto tries EGL then OSMesa. Throws GlError naming every backend tried and why it failed.
  // `width`/`height` size the OSMesa default framebuffer (EGL renders only offscreen).
  explicit GlContext(GlBackend backend = GlBackend::Auto, int width = 1280, int height = 720);
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  GlBackend backend() const;
  std::string description() const;  // backend plus GL_RENDERER string
  // EGL: the devices eglQueryDevicesEXT lists ("0: hardware /dev/dri/renderD128", "1:
  // software (EGL_MESA_device_software)"), empty under OSMesa or without the extension;
  // the one in use (a hardware device is preferred to Mesa's surfaceless platform).
  std::vector<std::string> devices() const;
  std::string device_used() const;
  // Address of a GL entry point (the backend's *GetProcAddress); null if it has none.
  void* proc(const char* name) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lander::sim
