// Headless OpenGL for the raster pass: an EGL context on the surfaceless platform (Mesa llvmpipe
// here, any EGL driver elsewhere), OpenGL 4.5 core, and RAII handles for the GL objects the pass
// creates. Every failure is a rayclass::GlError saying which step failed and why.
//
// GL entry points come straight from glvnd's libOpenGL (GL_GLEXT_PROTOTYPES + glcorearb.h); no
// loader. One context per process is enough: it is made current on the creating thread.
#pragma once

#include <string>
#include <utility>

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

namespace rayclass::raster {

class GlContext {
public:
    // Opens the surfaceless EGL display and creates a GL 4.5 core context, made current. Throws
    // GlError naming the EGL step and error when that is impossible (no EGL, no driver, ...).
    GlContext();
    ~GlContext();
    GlContext(const GlContext&) = delete;
    GlContext& operator=(const GlContext&) = delete;

    void MakeCurrent() const;
    const std::string& Renderer() const { return renderer_; }  // GL_RENDERER
    const std::string& Version() const { return version_; }    // GL_VERSION

    // A context for the whole process, created on first use; nullptr (and *why set) when it
    // cannot be made. Later calls return the same result without retrying.
    static GlContext* Shared(std::string* why = nullptr);

private:
    void* display_ = nullptr;  // EGLDisplay
    void* context_ = nullptr;  // EGLContext
    std::string renderer_, version_;
};

// Whether a GL_RENDERER string names one of Mesa's CPU rasterizers (llvmpipe, softpipe,
// swrast). On these the raster eye-ray pass was slower than the kernel eye rays in every full
// render measured (README), so --eye-rays auto takes the kernel there.
bool IsSoftwareRenderer(const std::string& renderer);

// Whether EGL enumerates its devices (EGL_EXT_device_enumeration) and every one is a software
// rasterizer (EGL_MESA_device_software). Then any context would be a software one, which
// --eye-rays auto learns this way without eglInitialize (which loads the driver, a noticeable
// part of a small render).
// False when EGL cannot tell.
bool OnlySoftwareEglDevices();

// Throws GlError("<what>: <GL error name>") when glGetError reports an error.
void CheckGl(const char* what);

// A GL object name owning its deletion: Deleter is a function void(GLuint).
template <void (*Delete)(GLuint)>
class GlHandle {
public:
    GlHandle() = default;
    explicit GlHandle(GLuint name) : name_(name) {}
    ~GlHandle() { Reset(); }
    GlHandle(GlHandle&& o) noexcept : name_(std::exchange(o.name_, 0)) {}
    GlHandle& operator=(GlHandle&& o) noexcept {
        if (this != &o) {
            Reset();
            name_ = std::exchange(o.name_, 0);
        }
        return *this;
    }
    GlHandle(const GlHandle&) = delete;
    GlHandle& operator=(const GlHandle&) = delete;

    GLuint get() const { return name_; }
    explicit operator bool() const { return name_ != 0; }
    void Reset() {
        if (name_) Delete(name_);
        name_ = 0;
    }

private:
    GLuint name_ = 0;
};

namespace detail {
void DeleteBuffer(GLuint n);
void DeleteTexture(GLuint n);
void DeleteFramebuffer(GLuint n);
void DeleteVertexArray(GLuint n);
void DeleteProgram(GLuint n);
void DeleteShader(GLuint n);
void DeleteQuery(GLuint n);
}  // namespace detail

using GlBuffer = GlHandle<detail::DeleteBuffer>;
using GlTexture = GlHandle<detail::DeleteTexture>;
using GlFramebuffer = GlHandle<detail::DeleteFramebuffer>;
using GlVertexArray = GlHandle<detail::DeleteVertexArray>;
using GlProgram = GlHandle<detail::DeleteProgram>;
using GlShader = GlHandle<detail::DeleteShader>;
using GlQuery = GlHandle<detail::DeleteQuery>;

// Compiles and links a program from vertex, geometry (may be empty) and fragment sources; the
// GlError carries the compile or link log and `name`.
GlProgram LinkProgram(const std::string& name, const std::string& vertex,
                      const std::string& geometry, const std::string& fragment);

}  // namespace rayclass::raster
