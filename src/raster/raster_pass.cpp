#include "rayclass/raster/raster_pass.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>

#include "rayclass/core/error.h"
#include "shaders.h"

namespace rayclass::raster {

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

constexpr float kMarginPixels = 0.75f;  // > half a pixel diagonal (0.7071)

template <typename T>
GlBuffer UploadStorage(const std::vector<T>& data) {
    GLuint name = 0;
    glCreateBuffers(1, &name);
    GlBuffer buffer(name);
    // A zero-sized store is legal, but binding one is not: keep at least 16 bytes.
    const size_t bytes = std::max<size_t>(16, data.size() * sizeof(T));
    // The driver reads the whole store from src, so a short array goes through a padded copy.
    std::vector<char> padded;
    const void* src = data.data();
    if (data.size() * sizeof(T) < bytes) {
        padded.assign(bytes, 0);
        if (!data.empty()) std::memcpy(padded.data(), data.data(), data.size() * sizeof(T));
        src = padded.data();
    }
    glNamedBufferStorage(buffer.get(), GLsizeiptr(bytes), src, 0);
    CheckGl("uploading primitives (glNamedBufferStorage)");
    return buffer;
}

GlTexture MakeTexture(GLenum format, uint32_t width, uint32_t height) {
    GLuint name = 0;
    glCreateTextures(GL_TEXTURE_2D, 1, &name);
    GlTexture tex(name);
    glTextureStorage2D(tex.get(), 1, format, GLsizei(width), GLsizei(height));
    glTextureParameteri(tex.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(tex.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    CheckGl("creating a framebuffer texture");
    return tex;
}

// The patch boxes as the patch shaders read them (patch_shaders.cpp): per box (boxMin, closedU),
// (boxMax, closedV) and the 16 control points, in the float values the kernels get
// (render::AnalyticArray).
std::vector<rc_float4> PatchBoxArray(const scene::Scene& scene) {
    std::vector<rc_float4> out;
    out.reserve(scene.patchBoxes.size() * 18);
    for (const scene::PatchBox& box : scene.patchBoxes) {
        const glm::vec3 lo = box.bounds.lo, hi = box.bounds.hi;
        out.push_back({lo.x, lo.y, lo.z, box.closedU ? 1.0f : 0.0f});
        out.push_back({hi.x, hi.y, hi.z, box.closedV ? 1.0f : 0.0f});
        for (const glm::dvec4& p : box.p) {
            out.push_back({float(p.x), float(p.y), float(p.z), float(p.w)});
        }
    }
    return out;
}

// Distance from `eye` to the farthest corner of `bounds` (0 when it is empty).
double FarthestDistance(const Bounds3f& bounds, const glm::dvec3& eye) {
    double maxDist = 0;
    if (bounds.Empty()) return maxDist;
    for (int c = 0; c < 8; ++c) {
        const glm::dvec3 p((c & 1) ? bounds.hi.x : bounds.lo.x, (c & 2) ? bounds.hi.y : bounds.lo.y,
                           (c & 4) ? bounds.hi.z : bounds.lo.z);
        maxDist = std::max(maxDist, glm::length(p - eye));
    }
    return maxDist;
}

// The explicit scale, or 2^-k with every corner of the scene bounds nearer than 2^k (with a
// margin for float distances a little beyond the bounds).
double ResolveDepthScale(const RasterOptions& options, double maxDist) {
    if (options.depthScale > 0) return options.depthScale;
    int k = 0;
    std::frexp(std::max(maxDist * 1.001, 1e-30), &k);  // maxDist * 1.001 < 2^k
    return std::ldexp(1.0, -k);
}

std::string Short(double value) {
    std::ostringstream text;
    text << std::setprecision(3) << value;
    return text.str();
}

bool IsPowerOfTwo(double value) {
    int exponent = 0;
    return std::frexp(value, &exponent) == 0.5;
}

// A power of two as 2^k (exact), anything else as Short.
std::string ScaleText(double scale) {
    if (!IsPowerOfTwo(scale)) return Short(scale);
    int exponent = 0;
    std::frexp(scale, &exponent);
    return "2^" + std::to_string(exponent - 1);
}

}  // namespace

std::vector<std::string> DepthWarnings(const scene::Scene& scene, const glm::vec3& eye,
                                       const RasterOptions& options) {
    const double range = FarthestDistance(scene.Bounds(), glm::dvec3(eye));
    const double scale = ResolveDepthScale(options, range);
    std::vector<std::string> warnings;
    if (scale * range >= 1) {
        warnings.push_back("depth scale " + ScaleText(scale) + " loses hits farther than " +
                           Short(1 / scale) + " from the eye (the scene reaches " + Short(range) +
                           ")");
    }
    if (options.depthBits < 32) {
        const double step = 1 / (scale * (std::ldexp(1.0, options.depthBits) - 1));
        if (step > std::ldexp(range, -20)) {
            warnings.push_back(std::to_string(options.depthBits) + "-bit depth steps are " +
                               Short(step) + " world units at depth scale " + ScaleText(scale) +
                               " (over 2^-20 of the scene's depth range " + Short(range) +
                               "): surfaces closer than a step may swap ids");
        }
    } else if (!IsPowerOfTwo(scale)) {
        warnings.push_back("depth scale " + Short(scale) +
                           " is not a power of two: float depth rounds distances, so surfaces "
                           "within a float step may swap ids");
    }
    return warnings;
}

Hull ParseHull(const std::string& name) {
    if (const auto hull = render::FindChoice(kHulls, name)) return *hull;
    throw UsageError("unknown hull '" + name + "' (use sphere, box, billboard or auto)");
}

const char* HullName(Hull hull) { return render::NameOf(kHulls, hull).data(); }

RasterPass::RasterPass(GlContext& gl, const scene::Scene& scene, const RasterOptions& options)
    : gl_(gl), options_(options) {
    if (options_.depthBits != 16 && options_.depthBits != 24 && options_.depthBits != 32) {
        throw Error("raster pass: depth buffer of " + std::to_string(options_.depthBits) +
                    " bits (use 16, 24 or 32)");
    }
    options_.slabs = std::max<uint32_t>(1, options_.slabs);
    gl_.MakeCurrent();
    count_[kTriangles] = uint32_t(scene.triangles.size());
    count_[kSpheres] = uint32_t(scene.spheres.size());
    count_[kQuadrics] = uint32_t(scene.quadrics.size());
    count_[kPatchBoxes] = uint32_t(scene.patchBoxes.size());
    base_[kTriangles] = 0;
    base_[kSpheres] = scene.SphereBase();
    base_[kQuadrics] = scene.QuadricBase();
    base_[kPatchBoxes] = scene.PatchBoxBase();
    bounds_ = scene.Bounds();
    primitives_[kTriangles] = UploadStorage(render::DeviceArray(scene.triangles));
    primitives_[kSpheres] = UploadStorage(render::DeviceArray(scene.spheres));
    primitives_[kQuadrics] = UploadStorage(render::DeviceArray(scene.quadrics));
    primitives_[kPatchBoxes] = UploadStorage(PatchBoxArray(scene));
    if (options_.slabs > 1) {
        // Bounding spheres for sorting primitives front to back.
        for (const auto& t : scene.triangles) {
            const glm::vec3 c = (t.p[0] + t.p[1] + t.p[2]) / 3.0f;
            float r = 0;
            for (const auto& p : t.p) r = std::max(r, glm::length(p - c));
            sphereHulls_[kTriangles].push_back({c, r});
        }
        sphereHulls_[kSpheres] = scene.spheres;
        for (const auto& q : scene.quadrics) {
            sphereHulls_[kQuadrics].push_back(
                {(q.boxMin + q.boxMax) * 0.5f, 0.5f * glm::length(q.boxMax - q.boxMin)});
        }
        for (const auto& b : scene.patchBoxes) {
            sphereHulls_[kPatchBoxes].push_back(
                {(b.bounds.lo + b.bounds.hi) * 0.5f, 0.5f * glm::length(b.bounds.Size())});
        }
    }
    GLuint name = 0;
    glCreateVertexArrays(1, &name);
    vao_ = GlVertexArray(name);
    if (options_.countFragments) {
        glCreateBuffers(1, &name);
        counters_ = GlBuffer(name);
        glNamedBufferStorage(counters_.get(), 3 * sizeof(GLuint), nullptr,
                             GL_DYNAMIC_STORAGE_BIT | GL_MAP_READ_BIT);
    }
    CheckGl("creating the raster pass");
}

RasterPass::~RasterPass() { gl_.MakeCurrent(); }

GLuint RasterPass::Program(Kind kind, Hull hull, bool slabPass) {
    const auto key = std::make_tuple(int(kind), kind == kTriangles ? 0 : int(hull), slabPass);
    auto it = programs_.find(key);
    if (it != programs_.end()) return it->second.get();
    const int hullIndex = hull == Hull::Sphere ? 0 : hull == Hull::Box ? 1 : 2;
    static const char* kKindNames[] = {"triangles", "spheres", "quadrics", "patch boxes"};
    const std::string name = std::string(kKindNames[kind]) +
                             (kind == kTriangles ? "" : std::string("/") + HullName(hull));
    GlProgram program =
        LinkProgram(name, shaders::Vertex(kind, slabPass), shaders::Geometry(kind, hullIndex),
                    shaders::Fragment(kind, options_.countFragments, slabPass));
    return programs_.emplace(key, std::move(program)).first->second.get();
}

void RasterPass::EnsureFramebuffer(uint32_t width, uint32_t height) {
    if (fbo_ && width == width_ && height == height_) return;
    width_ = width;
    height_ = height;
    idTex_ = MakeTexture(GL_R32UI, width, height);
    distTex_ = MakeTexture(GL_R32F, width, height);
    uvTex_ = MakeTexture(GL_RG32F, width, height);
    const GLenum depthFormat = options_.depthBits == 32   ? GL_DEPTH_COMPONENT32F
                               : options_.depthBits == 24 ? GL_DEPTH_COMPONENT24
                                                          : GL_DEPTH_COMPONENT16;
    depthTex_ = MakeTexture(depthFormat, width, height);
    GLuint name = 0;
    glCreateFramebuffers(1, &name);
    fbo_ = GlFramebuffer(name);
    glNamedFramebufferTexture(fbo_.get(), GL_COLOR_ATTACHMENT0, idTex_.get(), 0);
    glNamedFramebufferTexture(fbo_.get(), GL_COLOR_ATTACHMENT1, distTex_.get(), 0);
    glNamedFramebufferTexture(fbo_.get(), GL_COLOR_ATTACHMENT2, uvTex_.get(), 0);
    glNamedFramebufferTexture(fbo_.get(), GL_DEPTH_ATTACHMENT, depthTex_.get(), 0);
    const GLenum buffers[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
    glNamedFramebufferDrawBuffers(fbo_.get(), 3, buffers);
    const GLenum status = glCheckNamedFramebufferStatus(fbo_.get(), GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
        throw GlError("OpenGL: raster framebuffer " + std::to_string(width) + "x" +
                      std::to_string(height) + " is incomplete (status 0x" +
                      [&] {
                          char buf[16];
                          std::snprintf(buf, sizeof buf, "%x", status);
                          return std::string(buf);
                      }() +
                      ")");
    }
    if (options_.slabs > 1) prevDepthTex_ = MakeTexture(depthFormat, width, height);
    CheckGl("creating the raster framebuffer");
}

void RasterPass::PrepareSlabs(const RcCamera& camera) {
    // Every primitive by the nearest distance its bounding sphere allows, split into groups of
    // equal size; inside a group each kind keeps id order (ties between equal distances then go
    // to the lower id, as in the other query paths, unless they straddle two groups).
    const glm::vec3 eye(camera.position.x, camera.position.y, camera.position.z);
    struct Entry {
        float near;
        uint8_t kind;
        uint32_t local;
    };
    std::vector<Entry> all;
    for (int k = 0; k < kKinds; ++k) {
        for (uint32_t i = 0; i < count_[k]; ++i) {
            const auto& s = sphereHulls_[k][i];
            all.push_back({std::max(0.0f, glm::length(s.center - eye) - s.radius), uint8_t(k), i});
        }
    }
    std::stable_sort(all.begin(), all.end(),
                     [](const Entry& a, const Entry& b) { return a.near < b.near; });
    const uint32_t slabs = options_.slabs;
    slabRanges_.assign(slabs, std::vector<std::pair<uint32_t, uint32_t>>(kKinds, {0, 0}));
    std::vector<uint32_t> order[kKinds];
    for (uint32_t s = 0; s < slabs; ++s) {
        const size_t first = all.size() * s / slabs, last = all.size() * (s + 1) / slabs;
        std::vector<uint32_t> members[kKinds];
        for (size_t e = first; e < last; ++e) members[all[e].kind].push_back(all[e].local);
        for (int k = 0; k < kKinds; ++k) {
            std::sort(members[k].begin(), members[k].end());
            slabRanges_[s][k] = {uint32_t(order[k].size()), uint32_t(members[k].size())};
            order[k].insert(order[k].end(), members[k].begin(), members[k].end());
        }
    }
    for (int k = 0; k < kKinds; ++k) slabOrder_[k] = UploadStorage(order[k]);
}

std::vector<RcHit> RasterPass::Render(const RcCamera& camera, RasterStats* stats) {
    const auto tStart = Clock::now();
    gl_.MakeCurrent();
    EnsureFramebuffer(camera.width, camera.height);
    const Programs programs = SetUpPrograms(camera);
    ClearTargets();
    const auto tDraw = Clock::now();
    const double uploadS = SecondsSince(tStart);
    Draw(programs);
    const double drawS = SecondsSince(tDraw);
    const auto tRead = Clock::now();
    std::vector<RcHit> hits = ReadHits();
    const double readbackS = SecondsSince(tRead);
    if (stats) {
        stats->uploadS = uploadS;
        stats->drawS = drawS;
        stats->readbackS = readbackS;
        stats->depthScale = depthScale_;
        if (options_.countFragments) {
            GLuint counts[3] = {0, 0, 0};
            glGetNamedBufferSubData(counters_.get(), 0, sizeof counts, counts);
            stats->fragments = counts[0];
            stats->tested = counts[1];
            stats->exactHits = counts[2];
        }
        stats->totalS = SecondsSince(tStart);
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    return hits;
}

RasterPass::Programs RasterPass::SetUpPrograms(const RcCamera& camera) {
    const glm::dvec3 eye(camera.position.x, camera.position.y, camera.position.z);
    const double maxDist = FarthestDistance(bounds_, eye);
    depthScale_ = ResolveDepthScale(options_, maxDist);
    const double diagonal = bounds_.Empty() ? 0.0 : double(bounds_.Diagonal());
    const float zNear = float(std::max(1e-4 * std::max(diagonal, maxDist), 1e-12));
    if (options_.slabs > 1) PrepareSlabs(camera);

    const bool slabPass = options_.slabs > 1;
    const Hull hulls[kKinds] = {
        Hull::Sphere,
        options_.hull == Hull::Auto ? Hull::Sphere : options_.hull,
        options_.hull == Hull::Auto ? Hull::Box : options_.hull,
        options_.hull == Hull::Auto ? Hull::Box : options_.hull,
    };
    Programs programs;
    for (int k = 0; k < kKinds; ++k) {
        programs[k] = count_[k] ? Program(Kind(k), hulls[k], slabPass) : 0;
        const GLuint p = programs[k];
        if (!p) continue;
        auto loc = [&](const char* n) { return glGetUniformLocation(p, n); };
        glProgramUniform3f(p, loc("uEye"), camera.position.x, camera.position.y, camera.position.z);
        glProgramUniform3f(p, loc("uForward"), camera.forward.x, camera.forward.y,
                           camera.forward.z);
        glProgramUniform3f(p, loc("uRight"), camera.right.x, camera.right.y, camera.right.z);
        glProgramUniform3f(p, loc("uUp"), camera.up.x, camera.up.y, camera.up.z);
        glProgramUniform2f(p, loc("uTanHalfFov"), camera.tanHalfFovX, camera.tanHalfFovY);
        glProgramUniform2ui(p, loc("uSize"), camera.width, camera.height);
        glProgramUniform1f(p, loc("uDepthScale"), float(depthScale_));
        glProgramUniform1f(p, loc("uZNear"), zNear);
        glProgramUniform1f(p, loc("uMargin"), kMarginPixels);
        glProgramUniform1ui(p, loc("uBase"), base_[k]);
        if (slabPass) glProgramUniform1i(p, loc("uPrevDepth"), 0);
    }
    CheckGl("setting the camera uniforms");
    return programs;
}

void RasterPass::ClearTargets() {
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_.get());
    glViewport(0, 0, GLsizei(width_), GLsizei(height_));
    glDisable(GL_CULL_FACE);  // the box hull culls its back faces itself
    glDisable(GL_BLEND);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    const GLuint missId[4] = {RC_NO_HIT, 0, 0, 0};
    const GLfloat missDist[4] = {std::numeric_limits<float>::infinity(), 0, 0, 0};
    const GLfloat zeroUV[4] = {0, 0, 0, 0};
    const GLfloat farDepth = 1.0f;
    glClearBufferuiv(GL_COLOR, 0, missId);
    glClearBufferfv(GL_COLOR, 1, missDist);
    glClearBufferfv(GL_COLOR, 2, zeroUV);
    glClearBufferfv(GL_DEPTH, 0, &farDepth);
    if (options_.countFragments) {
        const GLuint zeros[3] = {0, 0, 0};
        glNamedBufferSubData(counters_.get(), 0, sizeof zeros, zeros);
        glBindBufferBase(GL_ATOMIC_COUNTER_BUFFER, 0, counters_.get());
    }
    glBindVertexArray(vao_.get());
    glFinish();
    CheckGl("clearing the raster framebuffer");
}

void RasterPass::Draw(const Programs& programs) {
    const bool slabPass = options_.slabs > 1;
    const uint32_t nSlabs = slabPass ? options_.slabs : 1;
    for (uint32_t s = 0; s < nSlabs; ++s) {
        if (slabPass) {
            // The nearest hits so far, for the fragment shaders' early skip.
            glCopyImageSubData(depthTex_.get(), GL_TEXTURE_2D, 0, 0, 0, 0, prevDepthTex_.get(),
                               GL_TEXTURE_2D, 0, 0, 0, 0, GLsizei(width_), GLsizei(height_), 1);
            glBindTextureUnit(0, prevDepthTex_.get());
        }
        for (int k = 0; k < kKinds; ++k) {
            if (!programs[k]) continue;
            uint32_t first = 0, n = count_[k];
            if (slabPass) {
                std::tie(first, n) = slabRanges_[s][k];
                glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, slabOrder_[k].get());
            }
            if (n == 0) continue;
            glUseProgram(programs[k]);
            glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, primitives_[k].get());
            glDrawArrays(GL_POINTS, GLint(first), GLsizei(n));
        }
    }
    glFinish();
    CheckGl("drawing the raster pass");
}

std::vector<RcHit> RasterPass::ReadHits() {
    const size_t nPixels = size_t(width_) * height_;
    std::vector<GLuint> ids(nPixels);
    std::vector<GLfloat> dist(nPixels);
    std::vector<GLfloat> uv(2 * nPixels);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glReadPixels(0, 0, GLsizei(width_), GLsizei(height_), GL_RED_INTEGER, GL_UNSIGNED_INT,
                 ids.data());
    glReadBuffer(GL_COLOR_ATTACHMENT1);
    glReadPixels(0, 0, GLsizei(width_), GLsizei(height_), GL_RED, GL_FLOAT, dist.data());
    glReadBuffer(GL_COLOR_ATTACHMENT2);
    glReadPixels(0, 0, GLsizei(width_), GLsizei(height_), GL_RG, GL_FLOAT, uv.data());
    CheckGl("reading back the raster framebuffer");
    std::vector<RcHit> hits(nPixels);
    for (size_t i = 0; i < nPixels; ++i) {
        hits[i] = {dist[i], ids[i], uv[2 * i], uv[2 * i + 1]};
    }
    return hits;
}

std::vector<RcHit> RasterEyeHits::FindHits(const scene::Scene& scene,
                                           const render::CameraBasis& camera,
                                           render::RenderStats& stats) {
    const auto t0 = Clock::now();
    RasterPass pass(gl_, scene, options_);
    stats.timeS["raster_setup"] = SecondsSince(t0);
    RasterStats rs;
    // The pass draws the whole image, whatever the camera's window: a crop keeps the hits of its
    // pixels, which are then the whole render's.
    std::vector<RcHit> hits = pass.Render(camera.ToDevice(), &rs);
    stats.timeS["raster_draw"] = rs.drawS;
    stats.timeS["raster_readback"] = rs.readbackS;
    stats.timeS["raster_total"] = rs.totalS;
    const image::PixelRect& w = camera.window;
    if (w == image::PixelRect{0, 0, camera.width, camera.height}) return hits;
    std::vector<RcHit> crop;
    crop.reserve(w.PixelCount());
    for (uint32_t y = w.y0; y < w.y1; ++y) {
        const auto row = hits.begin() + ptrdiff_t(size_t(y) * camera.width);
        crop.insert(crop.end(), row + w.x0, row + w.x1);
    }
    return crop;
}

}  // namespace rayclass::raster
