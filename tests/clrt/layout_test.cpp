// The device compiler lays out every struct of rc_types.h exactly like the host compiler: the
// kernel in cl/layout_probe.cl writes sizeof, alignment and every field offset as the device sees
// them, and the test compares them with the host's.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "clrt/device.h"
#include "rayclass/clrt/context.h"
#include "rc_types.h"

namespace rayclass::clrt {
namespace {

using testing::kProbeOptions;
using testing::TestContext;

struct Entry {
    std::string label;  // "RcRayInfo.kind", or "RcRay sizeof" / "RcRay alignof"
    uint32_t value;
};

// The host's side of cl/layout_probe.cl, value for value in the same order.
std::vector<Entry> HostLayout() {
    std::vector<Entry> e;
#define RC_STRUCT(type)                                     \
    e.push_back({#type " sizeof", uint32_t(sizeof(type))}); \
    e.push_back({#type " alignof", uint32_t(alignof(type))})
#define RC_FIELD(type, field) e.push_back({#type "." #field, uint32_t(offsetof(type, field))})
    RC_STRUCT(RcTriangle);
    RC_FIELD(RcTriangle, v0);
    RC_FIELD(RcTriangle, v1);
    RC_FIELD(RcTriangle, v2);

    RC_STRUCT(RcTriangleShading);
    RC_FIELD(RcTriangleShading, n0);
    RC_FIELD(RcTriangleShading, n1);
    RC_FIELD(RcTriangleShading, n2);
    RC_FIELD(RcTriangleShading, material);
    RC_FIELD(RcTriangleShading, object);
    RC_FIELD(RcTriangleShading, hasNormals);
    RC_FIELD(RcTriangleShading, pad);

    RC_STRUCT(RcSphere);
    RC_FIELD(RcSphere, centerRadius);
    RC_FIELD(RcSphere, material);
    RC_FIELD(RcSphere, object);
    RC_FIELD(RcSphere, pad0);
    RC_FIELD(RcSphere, pad1);

    RC_STRUCT(RcQuadric);
    RC_FIELD(RcQuadric, c0);
    RC_FIELD(RcQuadric, c1);
    RC_FIELD(RcQuadric, c2);
    RC_FIELD(RcQuadric, boxMin);
    RC_FIELD(RcQuadric, boxMax);
    RC_FIELD(RcQuadric, material);
    RC_FIELD(RcQuadric, object);
    RC_FIELD(RcQuadric, pad0);
    RC_FIELD(RcQuadric, pad1);

    RC_STRUCT(RcMaterial);
    RC_FIELD(RcMaterial, kd);
    RC_FIELD(RcMaterial, ks);
    RC_FIELD(RcMaterial, kr);
    RC_FIELD(RcMaterial, kt);
    RC_FIELD(RcMaterial, emission);
    RC_FIELD(RcMaterial, shininess);
    RC_FIELD(RcMaterial, ior);
    RC_FIELD(RcMaterial, fresnel);
    RC_FIELD(RcMaterial, pad);

    RC_STRUCT(RcLight);
    RC_FIELD(RcLight, position);
    RC_FIELD(RcLight, intensity);

    RC_STRUCT(RcCamera);
    RC_FIELD(RcCamera, position);
    RC_FIELD(RcCamera, forward);
    RC_FIELD(RcCamera, right);
    RC_FIELD(RcCamera, up);
    RC_FIELD(RcCamera, tanHalfFovX);
    RC_FIELD(RcCamera, tanHalfFovY);
    RC_FIELD(RcCamera, width);
    RC_FIELD(RcCamera, height);

    RC_STRUCT(RcRay);
    RC_FIELD(RcRay, origin);
    RC_FIELD(RcRay, direction);

    RC_STRUCT(RcRayInfo);
    RC_FIELD(RcRayInfo, weight);
    RC_FIELD(RcRayInfo, depth);
    RC_FIELD(RcRayInfo, kind);
    RC_FIELD(RcRayInfo, pad0);
    RC_FIELD(RcRayInfo, pad1);

    RC_STRUCT(RcHit);
    RC_FIELD(RcHit, t);
    RC_FIELD(RcHit, prim);
    RC_FIELD(RcHit, u);
    RC_FIELD(RcHit, v);

    RC_STRUCT(RcRenderParams);
    RC_FIELD(RcRenderParams, nTriangles);
    RC_FIELD(RcRenderParams, nSpheres);
    RC_FIELD(RcRenderParams, nQuadrics);
    RC_FIELD(RcRenderParams, nLights);
    RC_FIELD(RcRenderParams, maxDepth);
    RC_FIELD(RcRenderParams, minWeight);
    RC_FIELD(RcRenderParams, pad0);
    RC_FIELD(RcRenderParams, pad1);
    RC_FIELD(RcRenderParams, ambient);
    RC_FIELD(RcRenderParams, background);
    RC_STRUCT(RcLeaf);
    RC_FIELD(RcLeaf, rayBegin);
    RC_FIELD(RcLeaf, rayCount);
    RC_FIELD(RcLeaf, candBegin);
    RC_FIELD(RcLeaf, candCount);
    RC_FIELD(RcLeaf, face);
    RC_FIELD(RcLeaf, node);
    RC_FIELD(RcLeaf, pad0);
    RC_FIELD(RcLeaf, pad1);
    RC_STRUCT(RcCandidate);
    RC_FIELD(RcCandidate, prim);
    RC_FIELD(RcCandidate, nearX);
    RC_STRUCT(RcTriangleBlock16);
    RC_FIELD(RcTriangleBlock16, v0x);
    RC_FIELD(RcTriangleBlock16, v0y);
    RC_FIELD(RcTriangleBlock16, v0z);
    RC_FIELD(RcTriangleBlock16, e1x);
    RC_FIELD(RcTriangleBlock16, e1y);
    RC_FIELD(RcTriangleBlock16, e1z);
    RC_FIELD(RcTriangleBlock16, e2x);
    RC_FIELD(RcTriangleBlock16, e2y);
    RC_FIELD(RcTriangleBlock16, e2z);
    RC_FIELD(RcTriangleBlock16, prim);
    RC_FIELD(RcTriangleBlock16, otherMask);
    RC_FIELD(RcTriangleBlock16, count);
    RC_FIELD(RcTriangleBlock16, nearX);
    RC_FIELD(RcTriangleBlock16, pad);
    RC_STRUCT(RcBvh8Node);
    RC_FIELD(RcBvh8Node, loX);
    RC_FIELD(RcBvh8Node, loY);
    RC_FIELD(RcBvh8Node, loZ);
    RC_FIELD(RcBvh8Node, hiX);
    RC_FIELD(RcBvh8Node, hiY);
    RC_FIELD(RcBvh8Node, hiZ);
    RC_FIELD(RcBvh8Node, child);
    RC_FIELD(RcBvh8Node, nChildren);
    RC_FIELD(RcBvh8Node, pad);
#undef RC_STRUCT
#undef RC_FIELD
    return e;
}

std::vector<uint32_t> DeviceLayout() {
    auto& ctx = TestContext();
    const cl::Program program = ctx.BuildProgram({"layout_probe.cl"}, kProbeOptions);
    cl::Kernel kernel(program, "rc_layout_probe");
    const size_t capacity = 1024;
    cl::Buffer out(ctx.context(), CL_MEM_WRITE_ONLY, capacity * sizeof(uint32_t));
    kernel.setArg(0, out);
    ctx.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(1));
    auto values = testing::Download<uint32_t>(out, capacity);
    if (values[0] >= capacity) return {};
    values.resize(values[0] + 1);
    values.erase(values.begin());
    return values;
}

// "Struct.field" for every field declared in rc_types.h's typedef'd structs, in order.
std::vector<std::string> DeclaredFields(const std::string& header) {
    static const std::regex kStruct(R"(typedef struct (\w+) \{([^}]*)\} \1;)");
    static const std::regex kComment(R"(/\*[^*]*\*+([^/*][^*]*\*+)*/)");
    static const std::regex kDecl(R"(^\s*(\w+)\s+([\w\s,\[\]]+)$)");
    std::vector<std::string> fields;
    for (std::sregex_iterator it(header.begin(), header.end(), kStruct), end; it != end; ++it) {
        const std::string name = (*it)[1];
        const std::string body = std::regex_replace(std::string((*it)[2]), kComment, "");
        size_t start = 0;
        for (size_t semi; (semi = body.find(';', start)) != std::string::npos; start = semi + 1) {
            std::smatch decl;
            const std::string text = body.substr(start, semi - start);
            if (!std::regex_match(text, decl, kDecl)) {
                fields.push_back(name + ".<unparsed: " + text + ">");
                continue;
            }
            // Names, not array sizes: "v0x[16]" declares v0x.
            static const std::regex kName(R"(\b[A-Za-z_]\w*)");
            const std::string names = decl[2];
            for (std::sregex_iterator n(names.begin(), names.end(), kName); n != end; ++n) {
                fields.push_back(name + "." + n->str());
            }
        }
    }
    return fields;
}

// The labels of cl/layout_probe.cl's values, read from its source: RC_STRUCT(T) writes
// "T sizeof" and "T alignof", RC_FIELD(T, f) writes "T.f".
std::vector<std::string> ProbeLabels() {
    const std::string source = AssembleProgramSource({"layout_probe.cl"});
    static const std::regex kUse(R"(^\s*RC_(STRUCT|FIELD)\((\w+)(?:, (\w+))?\);)");
    std::vector<std::string> labels;
    std::istringstream in(source);
    for (std::string line; std::getline(in, line);) {
        std::smatch m;
        if (!std::regex_search(line, m, kUse)) continue;
        if (m[1] == "STRUCT") {
            labels.push_back(m[2].str() + " sizeof");
            labels.push_back(m[2].str() + " alignof");
        } else {
            labels.push_back(m[2].str() + "." + m[3].str());
        }
    }
    return labels;
}

std::vector<std::string> Missing(const std::vector<std::string>& from,
                                 const std::vector<std::string>& in) {
    std::vector<std::string> missing;
    for (const auto& s : from) {
        if (std::find(in.begin(), in.end(), s) == in.end()) missing.push_back(s);
    }
    return missing;
}

TEST(StructLayout, DeviceMatchesHostForEveryStructAndField) {
    const std::vector<Entry> host = HostLayout();
    const std::vector<uint32_t> device = DeviceLayout();
    for (size_t i = 0; i < std::min(host.size(), device.size()); ++i) {
        EXPECT_EQ(device[i], host[i].value) << host[i].label << " (device vs host)";
    }
    EXPECT_EQ(device.size(), host.size())
        << "cl/layout_probe.cl and HostLayout() write different numbers of values";
}

// The comparison is only as good as its lists: the probe kernel and HostLayout() must list the
// same values in the same order, and every field of every struct in rc_types.h, so a field added
// to the header (or to one list only) fails here.
TEST(StructLayout, ProbeListsEveryDeclaredFieldLikeTheHost) {
    std::vector<std::string> hostLabels, hostFields;
    for (const auto& e : HostLayout()) {
        hostLabels.push_back(e.label);
        if (e.label.find('.') != std::string::npos) hostFields.push_back(e.label);
    }
    EXPECT_EQ(ProbeLabels(), hostLabels);

    const std::vector<std::string> declared =
        DeclaredFields(AssembleProgramSource({"shared/rc_types.h"}));
    // 11 structs with 62 fields when this was written: a parser that finds nothing must not pass.
    ASSERT_GE(declared.size(), 62u);
    EXPECT_EQ(Missing(declared, hostFields), std::vector<std::string>{})
        << "fields of rc_types.h that the probe does not check";
    EXPECT_EQ(Missing(hostFields, declared), std::vector<std::string>{})
        << "probed fields that rc_types.h does not declare";
    EXPECT_EQ(hostFields, declared) << "same fields, different order";
}

}  // namespace
}  // namespace rayclass::clrt
