// Headless GL context. The backend library is opened at run time with dlopen (RTLD_GLOBAL),
// so a process holds only the backend it uses: MuJoCo 2.2.2 looks up GL entry points through
// whichever *GetProcAddress it finds, and two GL implementations in one process would mix.
#include "lander/sim/render/gl_context.h"

#include <dlfcn.h>

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/osmesa.h>

#include <cstring>
#include <mutex>
#include <vector>

namespace lander::sim {

GlBackend parse_gl_backend(const std::string& name) {
  if (name == "auto") return GlBackend::Auto;
  if (name == "egl") return GlBackend::Egl;
  if (name == "osmesa") return GlBackend::OsMesa;
  throw GlError("unknown GL backend '" + name + "' (expected auto, egl or osmesa)");
}

std::string to_string(GlBackend b) {
  switch (b) {
    case GlBackend::Auto: return "auto";
    case GlBackend::Egl: return "egl";
    case GlBackend::OsMesa: return "osmesa";
  }
  return "?";
}

namespace {

template <class F>
F sym(void* lib, const char* name) {
  return reinterpret_cast<F>(dlsym(lib, name));
}

bool g_context_alive = false;
std::mutex g_mutex;

}  // namespace

struct GlContext::Impl {
  GlBackend backend = GlBackend::Auto;
  std::string renderer;
  std::string platform;  // EGL: "device" (a GPU) or "surfaceless" (Mesa)
  // EGL: every device eglQueryDevicesEXT listed ("0: hardware /dev/dri/renderD128",
  // "1: software (EGL_MESA_device_software)") and the one the context is on.
  std::vector<std::string> devices;
  std::string device_used;
  void* lib = nullptr;
  // EGL
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext egl_context = EGL_NO_CONTEXT;
  // OSMesa
  OSMesaContext osmesa = nullptr;
  std::vector<unsigned char> osmesa_buffer;

  std::string try_egl();
  std::string try_osmesa(int width, int height);
  void query_renderer();
  void release();
  // Address of a GL entry point through the backend's *GetProcAddress.
  void* proc(const char* name) const {
    if (backend == GlBackend::Egl) {
      auto getProc = sym<PFNEGLGETPROCADDRESSPROC>(lib, "eglGetProcAddress");
      return getProc ? reinterpret_cast<void*>(getProc(name)) : nullptr;
    }
    using OsGetProc = void* (*)(const char*);
    auto getProc = sym<OsGetProc>(lib, "OSMesaGetProcAddress");
    return getProc ? getProc(name) : nullptr;
  }
};

// EGL: on a hardware device when one is present (EGL_EXT_platform_device: an NVIDIA or other
// GPU's EGL device; Mesa's software device, EGL_MESA_device_software, is not one), else on
// Mesa's surfaceless platform. No window system, no pbuffer; MuJoCo renders into its own
// offscreen framebuffer object.
std::string GlContext::Impl::try_egl() {
  lib = dlopen("libEGL.so.1", RTLD_NOW | RTLD_GLOBAL);
  if (!lib) return std::string("cannot load libEGL.so.1: ") + dlerror();
  auto getProc = sym<PFNEGLGETPROCADDRESSPROC>(lib, "eglGetProcAddress");
  auto getPlatformDisplay =
      getProc ? reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
                    getProc("eglGetPlatformDisplayEXT"))
              : nullptr;
  auto initialize = sym<PFNEGLINITIALIZEPROC>(lib, "eglInitialize");
  auto chooseConfig = sym<PFNEGLCHOOSECONFIGPROC>(lib, "eglChooseConfig");
  auto bindApi = sym<PFNEGLBINDAPIPROC>(lib, "eglBindAPI");
  auto createContext = sym<PFNEGLCREATECONTEXTPROC>(lib, "eglCreateContext");
  auto makeCurrent = sym<PFNEGLMAKECURRENTPROC>(lib, "eglMakeCurrent");
  auto getError = sym<PFNEGLGETERRORPROC>(lib, "eglGetError");
  if (!getPlatformDisplay || !initialize || !chooseConfig || !bindApi || !createContext ||
      !makeCurrent || !getError) {
    return "libEGL lacks eglGetPlatformDisplayEXT or core entry points";
  }
  EGLint major = 0, minor = 0;
  auto queryDevices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(getProc("eglQueryDevicesEXT"));
  auto queryDeviceString =
      reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(getProc("eglQueryDeviceStringEXT"));
  if (queryDevices && queryDeviceString) {
    EGLDeviceEXT devices[16];
    EGLint n_devices = 0;
    if (queryDevices(16, devices, &n_devices)) {
      for (EGLint i = 0; i < n_devices; ++i) {
        const char* ext = queryDeviceString(devices[i], EGL_EXTENSIONS);
        const bool software = ext && std::strstr(ext, "EGL_MESA_device_software");
        const char* drm = ext && std::strstr(ext, "EGL_EXT_device_drm")
                              ? queryDeviceString(devices[i], EGL_DRM_DEVICE_FILE_EXT)
                              : nullptr;
        const std::string name = std::to_string(i) + ": " +
                                 (software ? "software (EGL_MESA_device_software)" : "hardware") +
                                 (drm ? std::string(" ") + drm : std::string());
        this->devices.push_back(name);
        if (software || display != EGL_NO_DISPLAY) continue;  // llvmpipe: the surfaceless path
        EGLDisplay d = getPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
        if (d != EGL_NO_DISPLAY && initialize(d, &major, &minor)) {
          display = d;
          platform = "device";
          device_used = name;
        }
      }
    }
  }
  if (display == EGL_NO_DISPLAY) {
    display = getPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display == EGL_NO_DISPLAY) return "no EGL surfaceless display";
    if (!initialize(display, &major, &minor)) {
      return "eglInitialize failed (error 0x" + std::to_string(getError()) + ")";
    }
    platform = "surfaceless";
    device_used = "Mesa surfaceless platform (no hardware EGL device initialised)";
  }
  const EGLint config_attribs[] = {EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8,
                                   EGL_ALPHA_SIZE, 8, EGL_DEPTH_SIZE, 24, EGL_STENCIL_SIZE, 8,
                                   EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig config;
  EGLint n = 0;
  if (!chooseConfig(display, config_attribs, &config, 1, &n) || n < 1) {
    // The surfaceless platform may expose no configs; contexts without one are allowed
    // with EGL_KHR_no_config_context.
    config = nullptr;
  }
  if (!bindApi(EGL_OPENGL_API)) return "eglBindAPI(EGL_OPENGL_API) failed";
  egl_context = createContext(display, config, EGL_NO_CONTEXT, nullptr);
  if (egl_context == EGL_NO_CONTEXT) {
    return "eglCreateContext failed (error " + std::to_string(getError()) + ")";
  }
  if (!makeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, egl_context)) {
    return "eglMakeCurrent without surface failed (error " + std::to_string(getError()) + ")";
  }
  backend = GlBackend::Egl;
  return "";
}

std::string GlContext::Impl::try_osmesa(int width, int height) {
  lib = dlopen("libOSMesa.so.8", RTLD_NOW | RTLD_GLOBAL);
  if (!lib) lib = dlopen("libOSMesa.so", RTLD_NOW | RTLD_GLOBAL);
  if (!lib) return std::string("cannot load libOSMesa: ") + dlerror();
  using CreateExt = OSMesaContext (*)(GLenum, GLint, GLint, GLint, OSMesaContext);
  using MakeCurrent = GLboolean (*)(OSMesaContext, void*, GLenum, GLsizei, GLsizei);
  auto createExt = sym<CreateExt>(lib, "OSMesaCreateContextExt");
  auto makeCurrent = sym<MakeCurrent>(lib, "OSMesaMakeCurrent");
  if (!createExt || !makeCurrent) return "libOSMesa lacks OSMesaCreateContextExt";
  osmesa = createExt(OSMESA_RGBA, 24, 8, 8, nullptr);
  if (!osmesa) return "OSMesaCreateContextExt failed";
  osmesa_buffer.assign(static_cast<std::size_t>(width) * height * 4, 0);
  if (!makeCurrent(osmesa, osmesa_buffer.data(), GL_UNSIGNED_BYTE, width, height)) {
    return "OSMesaMakeCurrent failed";
  }
  backend = GlBackend::OsMesa;
  return "";
}

void GlContext::Impl::query_renderer() {
  using GetString = const unsigned char* (*)(unsigned int);
  auto getString = reinterpret_cast<GetString>(proc("glGetString"));
  const unsigned char* r = getString ? getString(0x1F01 /* GL_RENDERER */) : nullptr;
  renderer = r ? reinterpret_cast<const char*>(r) : "unknown renderer";
}

void GlContext::Impl::release() {
  if (backend == GlBackend::Egl && lib) {
    auto makeCurrent = sym<PFNEGLMAKECURRENTPROC>(lib, "eglMakeCurrent");
    auto destroy = sym<PFNEGLDESTROYCONTEXTPROC>(lib, "eglDestroyContext");
    auto terminate = sym<PFNEGLTERMINATEPROC>(lib, "eglTerminate");
    if (makeCurrent) makeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (destroy && egl_context != EGL_NO_CONTEXT) destroy(display, egl_context);
    if (terminate && display != EGL_NO_DISPLAY) terminate(display);
  } else if (backend == GlBackend::OsMesa && lib && osmesa) {
    auto destroy = sym<void (*)(OSMesaContext)>(lib, "OSMesaDestroyContext");
    if (destroy) destroy(osmesa);
  }
  // The library stays loaded: MuJoCo keeps the entry points it resolved.
}

GlContext::GlContext(GlBackend backend, int width, int height) : impl_(new Impl) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (g_context_alive) throw GlError("a GL context already exists in this process");
  std::string errors;
  if (backend == GlBackend::Auto || backend == GlBackend::Egl) {
    const std::string e = impl_->try_egl();
    if (e.empty()) {
      impl_->query_renderer();
      g_context_alive = true;
      return;
    }
    errors += "EGL: " + e;
    if (backend == GlBackend::Egl) throw GlError("cannot start the GL backend: " + errors);
    // The EGL library stays mapped but must not serve GL: unload it before trying OSMesa.
    if (impl_->lib) dlclose(impl_->lib);
    impl_->lib = nullptr;
  }
  const std::string e = impl_->try_osmesa(width, height);
  if (!e.empty()) {
    errors += (errors.empty() ? "" : "; ") + std::string("OSMesa: ") + e;
    throw GlError("cannot start any GL backend (" + errors + ")");
  }
  impl_->query_renderer();
  g_context_alive = true;
}

GlContext::~GlContext() {
  impl_->release();
  std::lock_guard<std::mutex> lock(g_mutex);
  g_context_alive = false;
}

GlBackend GlContext::backend() const { return impl_->backend; }


std::vector<std::string> GlContext::devices() const { return impl_->devices; }

void* GlContext::proc(const char* name) const { return impl_->proc(name); }

std::string GlContext::device_used() const {
  return impl_->backend == GlBackend::OsMesa ? "OSMesa (no EGL)" : impl_->device_used;
}

std::string GlContext::description() const {
  const std::string platform = impl_->platform.empty() ? "" : " " + impl_->platform;
  return to_string(impl_->backend) + platform + " (" + impl_->renderer + ")";
}

}  // namespace lander::sim
