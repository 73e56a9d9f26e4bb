// Hostile input for the OBJ/MTL parser and the scene loader: truncated files, binary garbage,
// non-finite and out-of-range numbers, absurd indices, huge statements, deep nesting, files that
// are not regular files. Every case either loads or throws a SceneError reading
// "FILE:LINE: PROBLEM" (or "FILE: PROBLEM" for the whole file); none crashes, hangs or needs
// memory out of proportion to its size. The memory and time bounds are asserted by running the
// input in a child process under an address-space limit and an alarm (the limit is skipped under
// AddressSanitizer, which reserves terabytes of address space; the sanitizer build checks the
// rest).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>
#include <string>

#include "rayclass/core/error.h"
#include "rayclass/scene/loader.h"
#include "rayclass/scene/obj.h"
#include "scene/test_files.h"

#if defined(__SANITIZE_ADDRESS__)
#define RAYCLASS_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define RAYCLASS_TEST_ASAN 1
#endif
#endif

namespace rayclass::scene {
namespace {

namespace fs = std::filesystem;
using testing::ErrorOf;
using testing::TempDir;

std::string SourceDir() {
    const char* dir = std::getenv("RAYCLASS_SOURCE_DIR");
    return dir ? dir : ".";
}

std::string ReadText(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

// What a hostile input may do: load, or fail with "FILE:LINE: PROBLEM" / "FILE: PROBLEM".
// Returns "" when that holds, else a description of what happened instead.
std::string CheckOutcome(const std::function<void()>& load, const std::string& file) {
    try {
        load();
        return "";
    } catch (const SceneError& e) {
        const std::string what = e.what();
        static const std::regex shape(R"(^(:\d+)?: \S.*$)");
        if (what.rfind(file, 0) != 0) return "message does not start with the file: " + what;
        if (!std::regex_match(what.substr(file.size()), shape)) return "malformed message: " + what;
        return "";
    } catch (const std::exception& e) {
        return std::string("unexpected exception: ") + e.what();
    }
}

// Runs `f` in a child process with at most `bytes` of address space (not under ASan) and
// `seconds` of time; returns the child's exit status, or 100 + the signal that ended it.
int RunBounded(const std::function<void()>& f, size_t bytes, unsigned seconds) {
    const pid_t pid = ::fork();
    if (pid == 0) {
#ifndef RAYCLASS_TEST_ASAN
        const rlimit limit{bytes, bytes};
        ::setrlimit(RLIMIT_AS, &limit);
#else
        (void)bytes;
#endif
        ::alarm(seconds);
        try {
            f();
        } catch (const SceneError&) {
            ::_exit(0);
        } catch (const std::bad_alloc&) {
            ::_exit(2);
        } catch (...) {
            ::_exit(3);
        }
        ::_exit(0);
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    if (WIFSIGNALED(status)) return 100 + WTERMSIG(status);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// The address-space limit of the bounded runs: the test binary itself maps some tens of MiB
// (more with OpenCL-free but glibc-arena-happy allocators), inputs are under 2 MiB.
constexpr size_t kBoundBytes = size_t(512) << 20;

// ---------------------------------------------------------------- truncated files

TEST(HostileObj, EveryPrefixOfTheCornellBoxLoadsOrFailsWithALine) {
    TempDir dir;
    const std::string obj = ReadText(SourceDir() + "/scenes/cornell_box.obj");
    const std::string mtl = ReadText(SourceDir() + "/scenes/cornell_box.mtl");
    ASSERT_GT(obj.size(), 1000u);
    ASSERT_GT(mtl.size(), 100u);
    const fs::path objFile = dir.path() / "box.obj";
    // Every byte prefix of the MTL, behind the full OBJ (through its mtllib).
    const auto mtlFile = dir.path() / "cornell_box.mtl";
    for (size_t n = 0; n <= mtl.size(); ++n) {
        const std::string cut = mtl.substr(0, n);
        const std::string problem =
            CheckOutcome([&] { ParseMtl(cut, mtlFile); }, mtlFile.string());
        ASSERT_EQ(problem, "") << "MTL prefix of " << n << " bytes";
    }
    dir.Write("cornell_box.mtl", mtl);
    for (size_t n = 0; n <= obj.size(); n += 7) {
        const std::string cut = obj.substr(0, n);
        const std::string problem =
            CheckOutcome([&] { ParseObj(cut, objFile); }, objFile.string());
        ASSERT_EQ(problem, "") << "OBJ prefix of " << n << " bytes";
    }
}

TEST(HostileScene, EveryPrefixOfTheCornellSceneFailsWithALine) {
    TempDir dir;
    const std::string json = ReadText(SourceDir() + "/scenes/cornell.json");
    dir.Write("cornell_box.obj", ReadText(SourceDir() + "/scenes/cornell_box.obj"));
    dir.Write("cornell_box.mtl", ReadText(SourceDir() + "/scenes/cornell_box.mtl"));
    ASSERT_GT(json.size(), 500u);
    int loaded = 0;
    for (size_t n = 0; n < json.size(); n += 3) {
        const auto file = dir.Write("s.json", json.substr(0, n));
        const std::string problem = CheckOutcome(
            [&] {
                LoadScene(file);
                ++loaded;
            },
            file.string());
        ASSERT_EQ(problem, "") << "prefix of " << n << " bytes";
    }
    // Only the whole file, its trailing newline cut, is a complete JSON value.
    EXPECT_LE(loaded, 1);
    // A prefix that ends inside the scene names a line of it, never line 0.
    const auto file = dir.Write("s.json", json.substr(0, json.size() / 2));
    EXPECT_NE(ErrorOf([&] { LoadScene(file); }).find(file.string() + ":"), std::string::npos);
    EXPECT_EQ(ErrorOf([&] { LoadScene(file); }).find(file.string() + ":0:"), std::string::npos);
}

// ---------------------------------------------------------------- binary garbage

std::string Garbage(std::mt19937& rng, size_t n, bool printable) {
    std::string s(n, '\0');
    // Printable garbage keeps the statement keywords and digits in play.
    const std::string alphabet = "vfnt/ -+.0123456789eE#\\\n\r\tgousemtlKdNsi{}[]\":,";
    for (char& c : s) {
        c = printable ? alphabet[rng() % alphabet.size()] : char(rng() & 0xff);
    }
    return s;
}

TEST(HostileObj, BinaryAndTokenGarbageNeverCrashes) {
    std::mt19937 rng(7);
    const fs::path file = "/nonexistent/g.obj";
    for (int i = 0; i < 400; ++i) {
        const std::string text = Garbage(rng, 64 + rng() % 4096, i % 2 == 0);
        ASSERT_EQ(CheckOutcome([&] { ParseObj(text, file); }, file.string()), "") << "case " << i;
        ASSERT_EQ(CheckOutcome([&] { ParseMtl(text, file); }, file.string()), "") << "case " << i;
    }
}

TEST(HostileScene, BinaryAndTokenGarbageNeverCrashes) {
    TempDir dir;
    std::mt19937 rng(11);
    for (int i = 0; i < 300; ++i) {
        std::string text = Garbage(rng, 16 + rng() % 2048, i % 2 == 0);
        if (i % 3 == 0) text = "{\"objects\": [" + text;  // past the first token
        const auto file = dir.Write("g.json", text);
        ASSERT_EQ(CheckOutcome([&] { LoadScene(file); }, file.string()), "") << "case " << i;
    }
}

// ---------------------------------------------------------------- numbers

bool Finite(const glm::vec3& p) {
    return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

TEST(HostileObj, NonFiniteAndOutOfRangeNumbersNameTheirLine) {
    const fs::path f = "x.obj";
    EXPECT_EQ(ErrorOf([&] { ParseObj("v 0 0 0\nv NaN 0 0\n", f); }),
              "x.obj:2: non-finite number 'NaN' in 'v' statement");
    EXPECT_EQ(ErrorOf([&] { ParseObj("v 0 0 infinity\n", f); }),
              "x.obj:1: non-finite number 'infinity' in 'v' statement");
    EXPECT_EQ(ErrorOf([&] { ParseObj("vn 0 0 -1e400\n", f); }),
              "x.obj:1: number '-1e400' out of range in 'vn' statement");
    EXPECT_EQ(ErrorOf([&] { ParseObj("vt 0x1p200\n", f); }),
              "x.obj:1: malformed number '0x1p200' in 'vt' statement");
    EXPECT_EQ(ErrorOf([&] { ParseMtl("newmtl a\nKd 0 nan 0\n", f); }),
              "x.obj:2: non-finite number 'nan' in 'Kd' statement");
    EXPECT_EQ(ErrorOf([&] { ParseMtl("newmtl a\nNs inf\n", f); }),
              "x.obj:2: non-finite number 'inf' in 'Ns' statement");
    EXPECT_EQ(ErrorOf([&] { ParseMtl("newmtl a\nillum 99999999999999999999\n", f); }),
              "x.obj:2: malformed number '99999999999999999999' in 'illum' statement");
    // A digit string far longer than any number.
    const std::string digits(100000, '9');
    EXPECT_EQ(ErrorOf([&] { ParseObj("v 0 0 " + digits + "\n", f); }),
              "x.obj:1: number '" + digits + "' out of range in 'v' statement");
}

TEST(HostileObj, IndicesBeyondEveryIntegerType) {
    const fs::path f = "x.obj";
    const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0 0\n";
    for (const std::string index :
         {"4", "-4", "2147483647", "2147483648", "-2147483648", "-2147483649", "4294967296",
          "4294967297", "-4294967297", "9223372036854775807", "-9223372036854775808",
          "9223372036854775808", "-9223372036854775809", "18446744073709551617"}) {
        EXPECT_EQ(ErrorOf([&] { ParseObj(tri + "f 1 2 " + index + "\n", f); }),
                  "x.obj:6: vertex index " + index + " out of range (3 vertices defined)");
        EXPECT_EQ(ErrorOf([&] { ParseObj(tri + "f 1/1 2/1 3/" + index + "\n", f); }),
                  "x.obj:6: texcoord index " + index + " out of range (1 texcoord defined)");
        EXPECT_EQ(ErrorOf([&] { ParseObj(tri + "f 1//1 2//1 3//" + index + "\n", f); }),
                  "x.obj:6: normal index " + index + " out of range (1 normal defined)");
    }
}

TEST(HostileScene, HugeCoordinatesAreRefusedWithTheirLine) {
    TempDir dir;
    dir.Write("t.obj", "v 0 0 0\nv 1 0 0\n# far\nv 0 2e12 0\nf 1 2 3\n");
    const auto load = [&](const std::string& json) {
        const auto file = dir.Write("s.json", json);
        const std::string what = ErrorOf([&] { LoadScene(file); });
        const std::string prefix = file.string() + ":";
        return what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what;
    };
    EXPECT_EQ(load("{\"objects\": [\n{\"type\": \"mesh\", \"file\": \"t.obj\"}]}"),
              "2: object 1: mesh '" + (dir.path() / "t.obj").string() +
                  "': vertex 3 (line 4) is out of range after the transform (magnitude above "
                  "1e+12)");
    dir.Write("u.obj", "v 0 0 0\nv 1 0 0\nv 0 1e6 0\nf 1 2 3\n");
    EXPECT_EQ(load("{\"objects\": [{\"type\": \"mesh\", \"file\": \"u.obj\",\n"
                   "\"transform\": {\"scale\": 1e36}}]}"),
              "2: object 1: mesh '" + (dir.path() / "u.obj").string() +
                  "': vertex 2 (line 2) is out of range after the transform (magnitude above "
                  "1e+12)");
    EXPECT_EQ(load("{\"objects\": [{\"type\": \"mesh\", \"file\": \"u.obj\",\n"
                   "\"transform\": {\"matrix\": [1e30,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}}]}"),
              "2: object 1: mesh '" + (dir.path() / "u.obj").string() +
                  "': vertex 2 (line 2) is out of range after the transform (magnitude above "
                  "1e+12)");
    EXPECT_EQ(load("{\"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0],\n"
                   "\"radius\": 3e38}]}"),
              "2: object 1: 'radius' is out of range (magnitude above 1e+12)");
    EXPECT_EQ(load("{\"objects\": [{\"type\": \"sphere\", \"center\": [0, -1e13, 0],"
                   " \"radius\": 1}]}"),
              "1: object 1: 'center' is out of range (magnitude above 1e+12)");
    EXPECT_EQ(load("{\"objects\": [{\"type\": \"quadric\", \"coefficients\": "
                   "[1,1,1,0,0,0,0,0,0,-1], \"box_min\": [-3e38, -1, -1], \"box_max\": [1, 1, "
                   "1]}]}"),
              "1: object 1: 'box_min' is out of range (magnitude above 1e+12)");
    EXPECT_EQ(load("{\"camera\": {\"position\": [3e38, 0, 0], \"look_at\": [0, 0, 0]}}"),
              "1: camera: 'position' is out of range (magnitude above 1e+12)");
    EXPECT_EQ(load("{\"lights\": [{\"position\": [0, 0, 1e20]}]}"),
              "1: light 1: 'position' is out of range (magnitude above 1e+12)");
    EXPECT_EQ(load("{\"ambient\": [1e39, 0, 0]}"),
              "1: scene: 'ambient' must be an array of 3 non-negative finite numbers");
    EXPECT_EQ(load("{\"camera\": {\"width\": 1e20}}"),
              "1: camera: 'width' must be an integer in 1..16384");
    EXPECT_EQ(load("{\"camera\": {\"height\": 18446744073709551616}}"),
              "1: camera: 'height' must be an integer in 1..16384");
    EXPECT_EQ(load("{\"ambient\": [NaN, 0, 0]}"),
              "1: syntax error while parsing value - invalid literal");
    // The bound itself is allowed, and huge directions only matter by their direction.
    const auto ok = dir.Write(
        "ok.json",
        "{\"camera\": {\"position\": [0, 0, 1e12], \"look_at\": [0, 0, 0], \"up\": [0, 3e38, "
        "0]}, \"objects\": [{\"type\": \"mesh\", \"file\": \"u.obj\", \"transform\": "
        "{\"rotate\": {\"axis\": [3e38, 3e38, 0], \"degrees\": 90}}}, {\"type\": \"sphere\", "
        "\"center\": [1e12, 0, 0], \"radius\": 1e12}]}");
    const Scene s = LoadScene(ok);
    for (const Triangle& t : s.triangles) {
        for (const glm::vec3& p : t.p) EXPECT_TRUE(Finite(p));
    }
    EXPECT_TRUE(Finite(s.camera.up));
}

TEST(HostileObj, BareObjWithAFarVertexNamesItsLine) {
    TempDir dir;
    const auto file = dir.Write("far.obj", "v 0 0 0\nv 1 0 0\n\nv 0 3e38 0\nf 1 2 3\n");
    EXPECT_EQ(ErrorOf([&] { LoadScene(file); }),
              file.string() + ":4: vertex 3 is out of range (magnitude above 1e+12)");
    // An unused far vertex is harmless.
    const auto unused = dir.Write("unused.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 3e38 0 0\nf 1 2 3\n");
    EXPECT_EQ(LoadScene(unused).triangles.size(), 1u);
}

TEST(HostileScene, ZeroAreaTrianglesAreCollapsedSoNoRayHitsThem) {
    TempDir dir;
    dir.Write("z.obj", "v 0 0 0\nv 1 2 3\nv 2 4 6\nv 0 1 0\nf 1 2 3\nf 1 1 4\nf 1 2 4\n");
    const Scene s = LoadScene(dir.Write("s.json", R"({"objects": [{"type": "mesh",
        "file": "z.obj"}]})"));
    ASSERT_EQ(s.triangles.size(), 3u);  // ids are kept
    for (int i = 0; i < 2; ++i) {
        EXPECT_EQ(s.triangles[i].p[1], s.triangles[i].p[0]) << i;
        EXPECT_EQ(s.triangles[i].p[2], s.triangles[i].p[0]) << i;
    }
    EXPECT_EQ(s.triangles[2].p[2], glm::vec3(0, 1, 0));
}

// ---------------------------------------------------------------- huge statements

TEST(HostileObj, HugeStatementsCostMemoryInProportionToTheirText) {
    // A 10^6-corner face (2 MB of text) is 999998 triangles; a 10^6-number 'v' and a line of
    // 10^5 continuations are errors; a claimed count in a comment drives nothing.
    std::string face = "v 0 0 0\nv 1 0 0\nv 0 1 0\n# 1000000000 vertices, 1000000000 faces\nf";
    for (int i = 0; i < 1000000; ++i) face += " 1";
    face += "\n";
    EXPECT_EQ(RunBounded(
                  [&] {
                      const ObjMesh m = ParseObj(face, "x.obj");
                      if (m.triangles.size() != 999998u) ::_exit(4);
                  },
                  kBoundBytes, 20),
              0);
    std::string numbers = "v";
    for (int i = 0; i < 1000000; ++i) numbers += " 1";
    EXPECT_EQ(ErrorOf([&] { ParseObj(numbers, "x.obj"); }),
              "x.obj:1: expected 3 to 6 numbers in 'v' statement, got 1000000");
    std::string continued = "v 1";
    for (int i = 0; i < 100000; ++i) continued += " \\\n";
    continued += "x\n";
    EXPECT_EQ(RunBounded([&] { ParseObj(continued, "x.obj"); }, kBoundBytes, 20), 0);
    EXPECT_EQ(ErrorOf([&] { ParseObj(continued, "x.obj"); }),
              "x.obj:1: malformed number 'x' in 'v' statement");
    // A name of a megabyte.
    const std::string name(1 << 20, 'm');
    EXPECT_EQ(ErrorOf([&] { ParseObj("usemtl " + name + "\n", "x.obj"); }),
              "x.obj:1: unknown material '" + name + "'");
}

TEST(HostileScene, DeepNestingAndLongArraysStayBounded) {
    TempDir dir;
    for (const std::string open : {"[", "{\"a\":", "{\"objects\":[{\"type\":\"mesh\",\"x\":"}) {
        std::string text;
        for (int i = 0; i < 200000; ++i) text += open;
        const auto file = dir.Write("deep.json", text);
        EXPECT_EQ(RunBounded([&] { LoadScene(file); }, kBoundBytes, 20), 0);
        EXPECT_NE(ErrorOf([&] { LoadScene(file); }).find(": nesting deeper than 64 levels"),
                  std::string::npos);
    }
    // 10^5 spheres load (linear), 10^6 numbers in a colour are an error on their line.
    std::string many = "{\"objects\": [";
    for (int i = 0; i < 100000; ++i) {
        many += std::string(i ? "," : "") + "{\"type\":\"sphere\",\"center\":[0,0,0],\"radius\":1}";
    }
    many += "]}";
    const auto spheres = dir.Write("many.json", many);
    EXPECT_EQ(RunBounded(
                  [&] {
                      if (LoadScene(spheres).spheres.size() != 100000u) ::_exit(4);
                  },
                  kBoundBytes, 60),
              0);
    std::string wide = "{\n\"ambient\": [";
    for (int i = 0; i < 1000000; ++i) wide += i ? ",0" : "0";
    wide += "]}";
    const auto widef = dir.Write("wide.json", wide);
    EXPECT_EQ(ErrorOf([&] { LoadScene(widef); }),
              widef.string() + ":2: scene: 'ambient' must be an array of 3 non-negative finite "
                               "numbers");
}

// ---------------------------------------------------------------- files that are not files

TEST(HostileFiles, SpecialFilesAreRefusedWithoutReadingThem) {
    TempDir dir;
    const fs::path fifo = dir.path() / "fifo.obj";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    const fs::path zero = dir.path() / "zero.obj";
    fs::create_symlink("/dev/zero", zero);
    const fs::path fifoJson = dir.path() / "fifo.json";
    ASSERT_EQ(::mkfifo(fifoJson.c_str(), 0600), 0);
    const fs::path zeroJson = dir.path() / "zero.json";
    fs::create_symlink("/dev/zero", zeroJson);
    // Before the fix: the FIFO blocked forever in open(), /dev/zero was read until memory ran out.
    for (const fs::path& f : {fifo, zero, fifoJson, zeroJson}) {
        EXPECT_EQ(RunBounded([&] { LoadScene(f); }, kBoundBytes, 10), 0) << f;
        EXPECT_EQ(ErrorOf([&] { LoadScene(f); }), f.string() + ": is not a regular file");
    }
    EXPECT_EQ(ErrorOf([&] { LoadObj(zero); }), zero.string() + ": is not a regular file");
    // Meshes and material libraries named by a scene or an OBJ.
    const auto scene = dir.Write("s.json", "{\"objects\": [\n{\"type\": \"mesh\", \"file\": "
                                           "\"fifo.obj\"}]}");
    EXPECT_EQ(ErrorOf([&] { LoadScene(scene); }),
              scene.string() + ":2: object 1: mesh '" + fifo.string() +
                  "': is not a regular file");
    fs::create_symlink("/dev/zero", dir.path() / "zero.mtl");
    const auto obj = dir.Write("m.obj", "v 0 0 0\nmtllib zero.mtl\n");
    EXPECT_EQ(ErrorOf([&] { LoadObj(obj); }),
              obj.string() + ":2: material library '" + (dir.path() / "zero.mtl").string() +
                  "': is not a regular file");
    fs::create_directories(dir.path() / "dir.mtl");
    const auto obj2 = dir.Write("n.obj", "mtllib dir.mtl\n");
    EXPECT_EQ(ErrorOf([&] { LoadObj(obj2); }),
              obj2.string() + ":1: material library '" + (dir.path() / "dir.mtl").string() +
                  "': is a directory");
    const auto scene2 = dir.Write("t.json", "{\"objects\": [{\"type\": \"mesh\", \"file\": "
                                            "\"\"}]}");
    EXPECT_EQ(ErrorOf([&] { LoadScene(scene2); }),
              scene2.string() + ":1: object 1: mesh '" + dir.path().string() +
                  "/': is a directory");
}

TEST(HostileFiles, FilesOverTwoGibibytesAreRefusedBeforeReading) {
    TempDir dir;
    // Sparse: no disk space used, and nothing is read.
    const fs::path big = dir.path() / "big.obj";
    { std::ofstream(big).put('v'); }
    fs::resize_file(big, (uint64_t(1) << 31) + 5);
    EXPECT_EQ(ErrorOf([&] { LoadObj(big); }),
              big.string() + ": file too large (2147483653 bytes, at most 2147483647)");
    const fs::path bigJson = dir.path() / "big.json";
    { std::ofstream(bigJson).put('{'); }
    fs::resize_file(bigJson, uint64_t(3) << 30);
    EXPECT_EQ(ErrorOf([&] { LoadScene(bigJson); }),
              bigJson.string() + ": file too large (3221225472 bytes, at most 2147483647)");
}

}  // namespace
}  // namespace rayclass::scene
