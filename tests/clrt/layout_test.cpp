// The device compiler lays out every struct of rc_types.h exactly like the host compiler: the
// kernel in cl/layout_probe.cl writes sizeof, alignment and every field offset as the device sees
// them, and the test compares them with the host's; both expand RC_LAYOUT_ENTRIES (rc_layout.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <regex>
#include <string>
#include <vector>

#include "clrt/device.h"
#include "rayclass/clrt/context.h"
#include "rc_layout.h"

namespace rayclass::clrt {
namespace {

using testing::kProbeOptions;
using testing::TestContext;

struct Entry {
    std::string label;  // "RcRayInfo.kind", or "RcRay sizeof" / "RcRay alignof"
    uint32_t value;
};

// The host's side of cl/layout_probe.cl: the same list, expanded with the host's sizeof,
// alignof and offsetof.
std::vector<Entry> HostLayout() {
    std::vector<Entry> e;
#define RC_STRUCT(type)                                     \
    e.push_back({#type " sizeof", uint32_t(sizeof(type))}); \
    e.push_back({#type " alignof", uint32_t(alignof(type))});
#define RC_FIELD(type, field) e.push_back({#type "." #field, uint32_t(offsetof(type, field))});
    RC_LAYOUT_ENTRIES(RC_STRUCT, RC_FIELD)
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

// The comparison is only as good as its list: RC_LAYOUT_ENTRIES must name every field of every
// struct in rc_types.h, in declaration order, so a field added to the header alone fails here.
TEST(StructLayout, ListNamesEveryDeclaredField) {
    std::vector<std::string> listed;
    for (const auto& e : HostLayout()) {
        if (e.label.find('.') != std::string::npos) listed.push_back(e.label);
    }
    const std::vector<std::string> declared =
        DeclaredFields(AssembleProgramSource({"shared/rc_types.h"}));
    // 11 structs with 62 fields when this was written: a parser that finds nothing must not pass.
    ASSERT_GE(declared.size(), 62u);
    EXPECT_EQ(Missing(declared, listed), std::vector<std::string>{})
        << "fields of rc_types.h that RC_LAYOUT_ENTRIES does not list";
    EXPECT_EQ(Missing(listed, declared), std::vector<std::string>{})
        << "listed fields that rc_types.h does not declare";
    EXPECT_EQ(listed, declared) << "same fields, different order";
}

}  // namespace
}  // namespace rayclass::clrt
