#include "rayclass/classify/params.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <utility>

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

SplitRule ParseSplitRule(const std::string& name, const std::string& value) {
    if (value == "midpoint") return SplitRule::kMidpoint;
    if (value == "median") return SplitRule::kMedian;
    Bad(name, value, "midpoint or median");
}

int ParseLightCells(const std::string& name, const std::string& value) {
    if (value == "auto") return -1;
    if (value == "off") return 0;
    const char* s = value.c_str();
    char* end = nullptr;
    const long v = std::strtol(s, &end, 10);
    if (value.empty() || *end != '\0' || !std::isdigit(static_cast<unsigned char>(s[0])) || v < 4 ||
        v > 256 || (v & (v - 1)) != 0) {
        Bad(name, value, "auto, off or a power of two from 4 to 256");
    }
    return int(v);
}

template <typename T>
ParamSetting Set(T Params::*member, T value) {
    return {ParamSetting::Field<T>{member, value}};
}

template <uint32_t Params::*member, uint32_t min>
ParamSetting Count(const std::string& name, const std::string& value) {
    return Set(member, ParseCount(name, value, min));
}

template <float Params::*member>
ParamSetting Fraction(const std::string& name, const std::string& value) {
    return Set(member, ParseFloat(name, value, 0.0f, 1.0f, false, "a number in [0, 1]"));
}

using Parser = ParamSetting (*)(const std::string& name, const std::string& value);

// Every parameter's name and parser, in the order ParamNames lists them.
const std::pair<const char*, Parser> kParsers[] = {
    {"min-rays", Count<&Params::minRays, 0>},
    {"min-candidates", Count<&Params::minCandidates, 0>},
    {"light-min-candidates", Count<&Params::lightMinCandidates, 0>},
    {"splits-per-list",
     [](const std::string& n, const std::string& v) {
         return Set(&Params::splitsPerList, int(std::min<uint32_t>(ParseCount(n, v, 1), 64)));
     }},
    {"split", [](const std::string& n,
                 const std::string& v) { return Set(&Params::splitRule, ParseSplitRule(n, v)); }},
    {"min-origin-fraction", Fraction<&Params::minOriginFraction>},
    {"min-dir-fraction", Fraction<&Params::minDirFraction>},
    {"dir-weight",
     [](const std::string& n, const std::string& v) {
         return Set(&Params::dirWeight, ParseFloat(n, v, 0.0f, 1e30f, true, "a number > 0"));
     }},
    {"threads",
     [](const std::string& n, const std::string& v) {
         return Set(&Params::threads, std::min<uint32_t>(ParseCount(n, v, 0), 256));
     }},
    {"task-rays", Count<&Params::taskRays, 0>},
    {"plan-rays", Count<&Params::planRays, 0>},
    {"light-cells",
     [](const std::string& n, const std::string& v) {
         return Set(&Params::lightCells, ParseLightCells(n, v));
     }},
    {"vertex-gather",
     [](const std::string& n, const std::string& v) {
         return Set(&Params::vertexGatherCost,
                    ParseFloat(n, v, 0.0f, 1e30f, false, "a number >= 0"));
     }},
};

}  // namespace

const char* ParamNames() {
    static const std::string names = [] {
        std::string list;
        for (const auto& [name, parse] : kParsers)
            list += (list.empty() ? "" : ", ") + std::string(name);
        return list;
    }();
    return names.c_str();
}

ParamSetting ParseParam(const std::string& name, const std::string& value) {
    for (const auto& [known, parse] : kParsers) {
        if (name == known) return parse(name, value);
    }
    throw UsageError("unknown classify parameter '" + name +
                     "'; valid names: " + std::string(ParamNames()));
}

void SetParam(Params& params, const std::string& name, const std::string& value) {
    ParseParam(name, value).ApplyTo(params);
}

}  // namespace rayclass::classify
