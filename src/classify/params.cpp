#include "rayclass/classify/params.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "rayclass/core/error.h"

namespace rayclass::classify {

Params Params::ForScene(const scene::Scene& scene) {
    Params p;
    const Bounds3f box = scene.Bounds();
    // Scaled by the larger of the diagonal and the largest coordinate, so that a scene far from
    // the origin still pads by many ulps; a scene of one point still gets a box with volume.
    float scale = 1.0f;
    if (!box.Empty()) {
        const glm::vec3 m = glm::max(glm::abs(box.lo), glm::abs(box.hi));
        scale = std::max({box.Diagonal(), m.x, m.y, m.z, 1e-6f});
    }
    p.padding = 2e-6f * scale;
    return p;
}

namespace {

[[noreturn]] void Bad(const std::string& name, const std::string& value, const char* expected) {
    throw UsageError("classify parameter " + name + "=" + value + ": expected " + expected);
}

uint32_t ParseCount(const std::string& name, const std::string& value, uint32_t min) {
    const char* s = value.c_str();
    char* end = nullptr;
    errno = 0;
    const unsigned long long v = std::strtoull(s, &end, 10);
    if (value.empty() || *end != '\0' || value[0] == '-' || value[0] == '+' || errno != 0 ||
        v > 0xFFFFFFFFull || v < min) {
        Bad(name, value, min == 0 ? "an integer >= 0" : "an integer >= 1");
    }
    return uint32_t(v);
}

float ParseFloat(const std::string& name, const std::string& value, float lo, float hi,
                 bool openLo, const char* expected) {
    const char* s = value.c_str();
    char* end = nullptr;
    errno = 0;
    const float v = std::strtof(s, &end);
    if (value.empty() || *end != '\0' || errno != 0 || !std::isfinite(v) || v > hi ||
        (openLo ? !(v > lo) : !(v >= lo))) {
        Bad(name, value, expected);
    }
    return v;
}

}  // namespace

const char* ParamNames() {
    return "min-rays, min-candidates, splits-per-list, split, min-origin-fraction, "
           "min-dir-fraction, dir-weight, threads, task-rays, plan-rays, light-cells, "
           "vertex-gather";
}

void SetParam(Params& params, const std::string& name, const std::string& value) {
    if (name == "min-rays") {
        params.minRays = ParseCount(name, value, 0);
    } else if (name == "min-candidates") {
        params.minCandidates = ParseCount(name, value, 0);
    } else if (name == "splits-per-list") {
        params.splitsPerList = int(std::min<uint32_t>(ParseCount(name, value, 1), 64));
    } else if (name == "split") {
        if (value == "midpoint") {
            params.splitRule = SplitRule::kMidpoint;
        } else if (value == "median") {
            params.splitRule = SplitRule::kMedian;
        } else {
            Bad(name, value, "midpoint or median");
        }
    } else if (name == "min-origin-fraction") {
        params.minOriginFraction =
            ParseFloat(name, value, 0.0f, 1.0f, false, "a number in [0, 1]");
    } else if (name == "min-dir-fraction") {
        params.minDirFraction = ParseFloat(name, value, 0.0f, 1.0f, false, "a number in [0, 1]");
    } else if (name == "dir-weight") {
        params.dirWeight = ParseFloat(name, value, 0.0f, 1e30f, true, "a number > 0");
    } else if (name == "task-rays") {
        params.taskRays = ParseCount(name, value, 0);
    } else if (name == "plan-rays") {
        params.planRays = ParseCount(name, value, 0);
    } else if (name == "light-cells") {
        if (value == "auto") {
            params.lightCells = -1;
        } else if (value == "off") {
            params.lightCells = 0;
        } else {
            const char* s = value.c_str();
            char* end = nullptr;
            const long v = std::strtol(s, &end, 10);
            if (value.empty() || *end != '\0' || !std::isdigit(static_cast<unsigned char>(s[0])) ||
                v < 4 || v > 256 || (v & (v - 1)) != 0) {
                Bad(name, value, "auto, off or a power of two from 4 to 256");
            }
            params.lightCells = int(v);
        }
    } else if (name == "vertex-gather") {
        params.vertexGatherCost = ParseFloat(name, value, 0.0f, 1e30f, false, "a number >= 0");
    } else if (name == "threads") {
        params.threads = std::min<uint32_t>(ParseCount(name, value, 0), 256);
    } else {
        throw UsageError("unknown classify parameter '" + name + "'; valid names: " +
                         std::string(ParamNames()));
    }
}

}  // namespace rayclass::classify
