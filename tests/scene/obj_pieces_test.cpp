// ParseObj in pieces on several threads against one piece: seeded random OBJ files whose
// statements state-carry across every piece boundary (indices counted from the file's start,
// negative indices, the current group and material, line continuations, comments, CRLF, a
// library named twice) give the same mesh for 1 to 6 pieces, and files with one error give
// the same message: the first error of the file, on its line.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "rayclass/scene/obj.h"
#include "scene/test_files.h"

namespace rayclass::scene {
namespace {

using testing::ErrorOf;
using testing::TempDir;

constexpr const char* kLibrary =
    "newmtl red\nKd 1 0 0\nnewmtl green\nKd 0 1 0\nnewmtl red\nKd 0.5 0 0\n";
constexpr const char* kOtherLibrary = "newmtl blue\nKd 0 0 1\nillum 3\nKs 0.5 0.5 0.5\n";

// A random OBJ text of about `statements` statements; with `error`, one of them is broken.
// (Appended piece by piece: GCC 12 warns falsely about chained string concatenation.)
std::string RandomObj(std::mt19937& rng, int statements, bool error) {
    auto pick = [&](int n) { return int(rng() % uint32_t(n)); };
    std::string text;
    int v = 0, vn = 0, vt = 0;
    const int broken = error ? pick(statements) : -1;
    auto end = [&] { text.append(pick(5) == 0 ? "\r\n" : "\n"); };
    auto number = [&] {
        text.push_back(' ');
        text.append(std::to_string(pick(2001) - 1000)).push_back('.');
        text.append(std::to_string(pick(100)));
    };
    auto index = [&](int count) {
        const int i = pick(count);
        text.append(std::to_string(pick(2) ? i + 1 : i - count));  // absolute or relative
    };
    for (int s = 0; s < statements; ++s) {
        if (pick(9) == 0) text.append(pick(2) ? "  " : "\t");
        if (s == broken) {
            const char* bad[] = {
                "f 1 2",          "v 1 2",  "vn 0 nope 1", "f 1 0 2",  "f 1/1/1/1 2 3",
                "usemtl missing", "usemtl", "f 99999 1 2", "vt 1e999", "mtllib nowhere.mtl"};
            text.append(bad[pick(10)]);
            end();
            continue;
        }
        const int kind = pick(v < 3 ? 3 : 14);
        if (kind <= 1) {
            text.append("v");
            for (int k = 0; k < 3; ++k) number();
            ++v;
        } else if (kind == 2 && pick(2)) {
            text.append("vn 0 0 1");
            ++vn;
        } else if (kind == 2) {
            text.append("vt");
            number();
            ++vt;
        } else if (kind <= 7) {
            const int corners = 3 + pick(3);
            text.append("f");
            const bool withVt = vt > 0 && pick(2), withVn = vn > 0 && pick(2);
            for (int c = 0; c < corners; ++c) {
                text.push_back(' ');
                index(v);
                if (withVt || withVn) text.push_back('/');
                if (withVt) index(vt);
                if (withVn) {
                    text.push_back('/');
                    index(vn);
                }
                if (c == 1 && pick(6) == 0) {  // a continuation in mid-face
                    text.append(" \\");
                    end();
                }
            }
        } else if (kind == 8) {
            text.append(pick(2) ? "g group" : "o object").append(std::to_string(pick(50)));
        } else if (kind == 9) {
            const char* names[] = {"red", "green", "blue"};
            text.append("usemtl ").append(names[pick(3)]);
        } else if (kind == 10) {
            text.append(pick(2) ? "mtllib a.mtl" : "mtllib b.mtl a.mtl");
        } else if (kind == 11) {
            text.append("# a comment \\");  // a '\' inside a comment continues nothing
        } else if (kind == 12) {
            text.append(pick(2) ? "s off" : "l 1 2");
        }
        if (pick(11) == 0) text.append(" # trailing");
        end();
        if (pick(13) == 0) end();  // blank line
    }
    return text;
}

// A directory with the two libraries the random files name, and x.obj's path in it.
struct Libraries {
    TempDir dir;
    std::filesystem::path obj = dir.path() / "x.obj";
    Libraries() {
        dir.Write("a.mtl", kLibrary);
        dir.Write("b.mtl", kOtherLibrary);
    }
};

void ExpectSameMesh(const ObjMesh& a, const ObjMesh& b, const std::string& what) {
    auto same = [](const auto& x, const auto& y) {
        return x.size() == y.size() &&
               (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0);
    };
    EXPECT_TRUE(same(a.positions, b.positions)) << what;
    EXPECT_TRUE(same(a.normals, b.normals)) << what;
    EXPECT_TRUE(same(a.texcoords, b.texcoords)) << what;
    EXPECT_TRUE(same(a.triangles, b.triangles)) << what;
    EXPECT_EQ(a.groups, b.groups) << what;
    ASSERT_EQ(a.materials.size(), b.materials.size()) << what;
    for (size_t i = 0; i < a.materials.size(); ++i) {
        EXPECT_EQ(a.materials[i].name, b.materials[i].name) << what;
        EXPECT_EQ(a.materials[i].kd, b.materials[i].kd) << what;
        EXPECT_EQ(a.materials[i].kr, b.materials[i].kr) << what;
    }
}

TEST(ObjPieces, AnyNumberOfPiecesGivesTheSameMesh) {
    const Libraries libraries;
    const auto& file = libraries.obj;
    std::mt19937 rng(11);
    int triangles = 0;
    for (int round = 0; round < 60; ++round) {
        const std::string text = "mtllib a.mtl b.mtl\n" + RandomObj(rng, 20 + round * 7, false);
        const ObjMesh whole = ParseObj(text, file, 1);
        triangles += int(whole.triangles.size());
        for (size_t pieces = 2; pieces <= 6; ++pieces) {
            ExpectSameMesh(ParseObj(text, file, pieces), whole,
                           "round " + std::to_string(round) + ", " + std::to_string(pieces) +
                               " pieces:\n" + text);
        }
    }
    EXPECT_GT(triangles, 3000);  // the generator makes faces, not only errors
}

TEST(ObjPieces, AnyNumberOfPiecesReportsTheFirstError) {
    const Libraries libraries;
    const auto& file = libraries.obj;
    std::mt19937 rng(12);
    int errors = 0;
    for (int round = 0; round < 80; ++round) {
        std::string text = "mtllib a.mtl b.mtl\n" + RandomObj(rng, 30 + round * 3, true);
        if (round % 4 == 0) text += RandomObj(rng, 10, true);  // a second error, later
        const std::string whole = ErrorOf([&] { ParseObj(text, file, 1); });
        errors += whole != "no SceneError";
        for (size_t pieces = 2; pieces <= 6; ++pieces) {
            EXPECT_EQ(ErrorOf([&] { ParseObj(text, file, pieces); }), whole)
                << "round " << round << ", " << pieces << " pieces:\n"
                << text;
        }
    }
    EXPECT_GT(errors, 60);
}

// The default splits files of 8 MiB and more (on a machine of more than one core).
TEST(ObjPieces, LargeFilesSplitByDefaultGiveTheSameMesh) {
    const Libraries libraries;
    const auto& file = libraries.obj;
    std::mt19937 rng(13);
    std::string text;
    while (text.size() < (size_t(9) << 20)) text += RandomObj(rng, 2000, false);
    const ObjMesh whole = ParseObj(text, file, 1);
    ExpectSameMesh(ParseObj(text, file), whole, "9 MiB");
}

}  // namespace
}  // namespace rayclass::scene
