#include "rayclass/raster/gl.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <memory>
#include <vector>

#if defined(__SANITIZE_ADDRESS__)
#include <dlfcn.h>
#include <link.h>
#endif

#include "rayclass/core/error.h"

namespace rayclass::raster {

namespace {

const char* EglErrorName(EGLint e) {
    switch (e) {
        case EGL_SUCCESS: return "EGL_SUCCESS";
        case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
        case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
        case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
        case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
        case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
        case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
        case EGL_BAD_CURRENT_SURFACE: return "EGL_BAD_CURRENT_SURFACE";
        case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
        case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
        case EGL_BAD_NATIVE_PIXMAP: return "EGL_BAD_NATIVE_PIXMAP";
        case EGL_BAD_NATIVE_WINDOW: return "EGL_BAD_NATIVE_WINDOW";
        case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
        case EGL_BAD_SURFACE: return "EGL_BAD_SURFACE";
        case EGL_CONTEXT_LOST: return "EGL_CONTEXT_LOST";
        default: return "unknown EGL error";
    }
}

[[noreturn]] void ThrowEgl(const std::string& step) {
    const EGLint e = eglGetError();
    throw GlError("OpenGL context: " + step + " failed with " + EglErrorName(e) + " (0x" +
                  [&] {
                      char buf[16];
                      std::snprintf(buf, sizeof buf, "%x", unsigned(e));
                      return std::string(buf);
                  }() +
                  ")");
}

const char* GlErrorName(GLenum e) {
    switch (e) {
        case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
        case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
        case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
        case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
        case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
        case GL_STACK_OVERFLOW: return "GL_STACK_OVERFLOW";
        case GL_STACK_UNDERFLOW: return "GL_STACK_UNDERFLOW";
        default: return "unknown GL error";
    }
}

// LeakSanitizer checks for leaks at exit, after EGL has unloaded the driver it opened (Mesa's
// DRI driver and the LLVM it links). Blocks the driver still held then lose the globals that
// pointed to them, so they count as leaks, and their stacks name no module that a suppression
// could match. Marking every object loaded so far RTLD_NODELETE keeps them mapped until the
// process ends, their globals among LeakSanitizer's roots; the handles stay open on purpose.
void KeepLoadedObjectsUntilExit() {
#if defined(__SANITIZE_ADDRESS__)
    std::vector<std::string> names;
    dl_iterate_phdr(
        [](dl_phdr_info* info, size_t, void* out) {
            if (info->dlpi_name && *info->dlpi_name)
                static_cast<std::vector<std::string>*>(out)->push_back(info->dlpi_name);
            return 0;
        },
        &names);
    for (const std::string& name : names)
        dlopen(name.c_str(), RTLD_LAZY | RTLD_NOLOAD | RTLD_NODELETE);
#endif
}

}  // namespace

GlContext::GlContext() {
    const char* clientExtensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!clientExtensions) ThrowEgl("eglQueryString(EGL_EXTENSIONS) (no EGL client extensions)");
    const std::string ext = clientExtensions;
    if (ext.find("EGL_EXT_platform_base") == std::string::npos ||
        ext.find("EGL_MESA_platform_surfaceless") == std::string::npos) {
        throw GlError(
            "OpenGL context: EGL lacks EGL_EXT_platform_base or EGL_MESA_platform_surfaceless "
            "(client extensions: " + ext + ")");
    }
    // eglGetPlatformDisplayEXT, not the EGL 1.5 core name: without a display the EGL version is
    // unknown to loaders, and the EXT entry point is always reachable through eglGetProcAddress.
    auto getPlatformDisplay = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (!getPlatformDisplay) ThrowEgl("eglGetProcAddress(eglGetPlatformDisplayEXT)");
    EGLDisplay dpy = getPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (dpy == EGL_NO_DISPLAY) ThrowEgl("eglGetPlatformDisplayEXT(surfaceless)");
    EGLint major = 0, minor = 0;
    if (!eglInitialize(dpy, &major, &minor)) ThrowEgl("eglInitialize");
    display_ = dpy;
    try {
        if (!eglBindAPI(EGL_OPENGL_API)) ThrowEgl("eglBindAPI(EGL_OPENGL_API)");
        const EGLint configAttribs[] = {EGL_SURFACE_TYPE, 0, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                                        EGL_NONE};
        EGLConfig config = nullptr;
        EGLint nConfigs = 0;
        if (!eglChooseConfig(dpy, configAttribs, &config, 1, &nConfigs)) {
            ThrowEgl("eglChooseConfig");
        }
        if (nConfigs == 0) throw GlError("OpenGL context: no EGL config renders OpenGL");
        const EGLint contextAttribs[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                                         EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                         EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
        EGLContext ctx = eglCreateContext(dpy, config, EGL_NO_CONTEXT, contextAttribs);
        if (ctx == EGL_NO_CONTEXT) ThrowEgl("eglCreateContext(OpenGL 4.5 core)");
        context_ = ctx;
        MakeCurrent();
        const auto str = [](GLenum name) {
            const auto* s = reinterpret_cast<const char*>(glGetString(name));
            return std::string(s ? s : "?");
        };
        renderer_ = str(GL_RENDERER);
        version_ = str(GL_VERSION);
        KeepLoadedObjectsUntilExit();
    } catch (...) {
        if (context_) eglDestroyContext(dpy, static_cast<EGLContext>(context_));
        eglTerminate(dpy);
        throw;
    }
}

GlContext::~GlContext() {
    auto dpy = static_cast<EGLDisplay>(display_);
    eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(dpy, static_cast<EGLContext>(context_));
    eglTerminate(dpy);
    eglReleaseThread();
}

void GlContext::MakeCurrent() const {
    if (!eglMakeCurrent(static_cast<EGLDisplay>(display_), EGL_NO_SURFACE, EGL_NO_SURFACE,
                        static_cast<EGLContext>(context_))) {
        ThrowEgl("eglMakeCurrent(surfaceless)");
    }
}

GlContext* GlContext::Shared(std::string* why) {
    static std::string error;
    static std::unique_ptr<GlContext> shared = []() -> std::unique_ptr<GlContext> {
        try {
            return std::make_unique<GlContext>();
        } catch (const Error& e) {
            error = e.what();
            return nullptr;
        }
    }();
    if (shared) shared->MakeCurrent();
    if (why) *why = error;
    return shared.get();
}

bool OnlySoftwareEglDevices() {
    const char* clientExtensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!clientExtensions ||
        std::string(clientExtensions).find("EGL_EXT_device_enumeration") == std::string::npos) {
        return false;
    }
    auto queryDevices =
        reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    auto queryString = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(
        eglGetProcAddress("eglQueryDeviceStringEXT"));
    if (!queryDevices || !queryString) return false;
    EGLint n = 0;
    if (!queryDevices(0, nullptr, &n) || n <= 0) return false;
    std::vector<EGLDeviceEXT> devices(static_cast<size_t>(n));
    if (!queryDevices(n, devices.data(), &n)) return false;
    for (EGLint i = 0; i < n; ++i) {
        const char* ext = queryString(devices[size_t(i)], EGL_EXTENSIONS);
        if (!ext || std::string(ext).find("EGL_MESA_device_software") == std::string::npos) {
            return false;
        }
    }
    return true;
}

bool IsSoftwareRenderer(const std::string& renderer) {
    for (const char* name : {"llvmpipe", "softpipe", "swrast"}) {
        if (renderer.find(name) != std::string::npos) return true;
    }
    return false;
}

void CheckGl(const char* what) {
    const GLenum e = glGetError();
    if (e == GL_NO_ERROR) return;
    while (glGetError() != GL_NO_ERROR) {
    }
    throw GlError(std::string("OpenGL: ") + what + " failed with " + GlErrorName(e));
}

namespace detail {
void DeleteBuffer(GLuint n) { glDeleteBuffers(1, &n); }
void DeleteTexture(GLuint n) { glDeleteTextures(1, &n); }
void DeleteFramebuffer(GLuint n) { glDeleteFramebuffers(1, &n); }
void DeleteVertexArray(GLuint n) { glDeleteVertexArrays(1, &n); }
void DeleteProgram(GLuint n) { glDeleteProgram(n); }
void DeleteShader(GLuint n) { glDeleteShader(n); }
void DeleteQuery(GLuint n) { glDeleteQueries(1, &n); }
}  // namespace detail

namespace {

GlShader CompileShader(const std::string& name, GLenum type, const std::string& source) {
    GlShader shader(glCreateShader(type));
    const char* text = source.c_str();
    glShaderSource(shader.get(), 1, &text, nullptr);
    glCompileShader(shader.get());
    GLint ok = 0;
    glGetShaderiv(shader.get(), GL_COMPILE_STATUS, &ok);
    if (!ok) {
        GLint len = 0;
        glGetShaderiv(shader.get(), GL_INFO_LOG_LENGTH, &len);
        std::vector<char> log(size_t(std::max(len, 1)));
        glGetShaderInfoLog(shader.get(), GLsizei(log.size()), nullptr, log.data());
        const char* stage = type == GL_VERTEX_SHADER     ? "vertex"
                            : type == GL_GEOMETRY_SHADER ? "geometry"
                                                         : "fragment";
        throw GlError("OpenGL: " + std::string(stage) + " shader of '" + name +
                      "' does not compile:\n" + log.data());
    }
    return shader;
}

}  // namespace

GlProgram LinkProgram(const std::string& name, const std::string& vertex,
                      const std::string& geometry, const std::string& fragment) {
    const GlShader vs = CompileShader(name, GL_VERTEX_SHADER, vertex);
    GlShader gs;
    if (!geometry.empty()) gs = CompileShader(name, GL_GEOMETRY_SHADER, geometry);
    const GlShader fs = CompileShader(name, GL_FRAGMENT_SHADER, fragment);
    GlProgram program(glCreateProgram());
    glAttachShader(program.get(), vs.get());
    if (gs) glAttachShader(program.get(), gs.get());
    glAttachShader(program.get(), fs.get());
    glLinkProgram(program.get());
    GLint ok = 0;
    glGetProgramiv(program.get(), GL_LINK_STATUS, &ok);
    if (!ok) {
        GLint len = 0;
        glGetProgramiv(program.get(), GL_INFO_LOG_LENGTH, &len);
        std::vector<char> log(size_t(std::max(len, 1)));
        glGetProgramInfoLog(program.get(), GLsizei(log.size()), nullptr, log.data());
        throw GlError("OpenGL: program '" + name + "' does not link:\n" + log.data());
    }
    CheckGl(("linking program " + name).c_str());
    return program;
}

}  // namespace rayclass::raster
