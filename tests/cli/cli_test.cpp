// The rayclass executable as a user runs it (RAYCLASS_BINARY, started through the shell in a
// scratch directory): its exit statuses (0 success, 2 usage errors, 1 other failures), its exact
// messages, and the files it leaves behind: the outputs of a successful render and nothing else,
// nothing at all when a command fails, and a previous output untouched by a failed render.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numeric>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "rayclass/image/image.h"

namespace rayclass::cli {
namespace {

namespace fs = std::filesystem;

struct Result {
    int status = -1;  // exit status; -1 when the process did not exit normally
    std::string out, err;
};

std::string EnvOr(const char* name, const std::string& fallback) {
    const char* value = std::getenv(name);
    return value ? value : fallback;
}

std::string Binary() { return EnvOr("RAYCLASS_BINARY", "rayclass"); }
std::string Cornell() { return EnvOr("RAYCLASS_SOURCE_DIR", ".") + "/scenes/cornell.json"; }

std::string ShellQuoted(const std::string& s) {
    std::string q(1, '\'');
    for (char c : s) {
        if (c == '\'') {
            q.append("'\\''");
        } else {
            q.push_back(c);
        }
    }
    q.push_back('\'');
    return q;
}

std::string ReadText(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

void WriteText(const fs::path& file, const std::string& text) {
    std::ofstream(file, std::ios::binary) << text;
}

// A scratch directory per test: the command runs in work/, its stdout and stderr are captured
// beside it, so work/ holds exactly what the command and the test put there.
class Cli : public ::testing::Test {
  protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        root_ = fs::temp_directory_path() /
                ("rayclass-cli-" + std::string(info->name()) + "-" + std::to_string(getpid()));
        fs::remove_all(root_);
        fs::create_directories(root_ / "work");
    }
    void TearDown() override { fs::remove_all(root_); }

    fs::path Work(const std::string& name = "") const { return root_ / "work" / name; }

    // `shellPrefix` runs in the same shell before the binary (e.g. ulimit settings); `stdoutPath`
    // replaces the captured stdout (Result::out stays empty).
    Result Run(const std::vector<std::string>& args, const std::string& shellPrefix = "",
               const std::string& stdoutPath = "") const {
        // Built by appending: operator+ with short literals trips a false -Wrestrict in GCC 12
        // (bug 105329).
        std::string command = "cd ";
        command.append(ShellQuoted(Work().string())).append(" && ").append(shellPrefix);
        command.append(ShellQuoted(Binary()));
        for (const auto& a : args) command.append(" ").append(ShellQuoted(a));
        const std::string out = stdoutPath.empty() ? (root_ / "stdout").string() : stdoutPath;
        command.append(" >").append(ShellQuoted(out));
        command.append(" 2>").append(ShellQuoted((root_ / "stderr").string()));
        command.append(" </dev/null");
        const int raw = std::system(command.c_str());
        Result r;
        r.status = raw != -1 && WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
        r.out = ReadText(root_ / "stdout");
        r.err = ReadText(root_ / "stderr");
        return r;
    }

    // The names in work/, sorted.
    std::vector<std::string> Entries() const {
        std::vector<std::string> names;
        for (const auto& e : fs::directory_iterator(Work())) {
            names.push_back(e.path().filename().string());
        }
        std::sort(names.begin(), names.end());
        return names;
    }

    fs::path root_;
};

TEST_F(Cli, VersionPrintsTheProjectVersion) {
    const Result r = Run({"--version"});
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(r.out, "rayclass " RAYCLASS_VERSION "\n");
    EXPECT_EQ(r.err, "");
}

TEST_F(Cli, FullStandardOutputIsAnError) {
    // /dev/full fails every write with ENOSPC, as a file on a full disk does: results printed on
    // stdout (here compare --json) are lost, so the command must not exit 0.
    image::Image a(2, 1);
    a.rgb = {glm::vec3(1.0f), glm::vec3(0.5f)};
    image::WriteImage(a, Work("a.exr"));
    for (const std::vector<std::string>& args : {std::vector<std::string>{"--version"},
                                                 {"render", "--help"},
                                                 {"compare", "a.exr", "a.exr", "--json"}}) {
        const Result r = Run(args, "", "/dev/full");
        EXPECT_EQ(r.status, 1) << args[0];
        EXPECT_EQ(r.err,
                  "rayclass " + args[0] + ": error: standard output: No space left on device\n");
    }
}

TEST_F(Cli, HelpListsTheCommandsOnStdout) {
    for (const std::string flag : {"--help", "-h", "help"}) {
        const Result r = Run({flag});
        EXPECT_EQ(r.status, 0) << flag;
        EXPECT_EQ(r.out.rfind("usage: rayclass <command> [options]\n", 0), 0u) << r.out;
        for (const char* command : {"\n  render ", "\n  compare ", "\n  devices "}) {
            EXPECT_NE(r.out.find(command), std::string::npos) << flag << ": " << command;
        }
        EXPECT_EQ(r.err, "");
    }
}

TEST_F(Cli, RenderHelpDescribesEveryOption) {
    const Result r = Run({"render", "--help"});
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(r.out.rfind("usage: rayclass render SCENE -o OUT.{exr,png} [options]\n", 0), 0u);
    for (const char* option :
         {"-o, --output", "--width", "--height", "--aov", "--max-depth", "--min-weight", "--device",
          "--reference", "--stats", "--exposure", "--exr-compression", "--png-compression",
          "--batch-rays", "--cl-options", "--depth-bits", "--depth-scale", "-q, --quiet",
          "--patch-boxes", "RAYCLASS_CACHE_DIR"}) {
        EXPECT_NE(r.out.find(option), std::string::npos) << option;
    }
    EXPECT_EQ(r.err, "");
    EXPECT_EQ(Entries(), std::vector<std::string>{});
}

TEST_F(Cli, NoArgumentsPrintUsageOnStderr) {
    const Result r = Run({});
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(r.err.rfind("usage: rayclass <command> [options]\n", 0), 0u) << r.err;
}

TEST_F(Cli, UnknownCommandIsAUsageError) {
    const Result r = Run({"frobnicate"});
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err.rfind("rayclass: unknown command 'frobnicate'\n\nusage: rayclass <command>", 0),
              0u)
        << r.err;
}

TEST_F(Cli, DevicesListsACpuDevice) {
    const Result r = Run({"devices"});
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(r.err, "");
    // "0: NAME [cpu]" followed by its platform and version lines.
    EXPECT_TRUE(std::regex_search(r.out, std::regex(R"((^|\n)\d+: .+ \[cpu\]\n   platform: )")))
        << r.out;

    const Result extra = Run({"devices", "extra"});
    EXPECT_EQ(extra.status, 2);
    EXPECT_EQ(extra.err, "rayclass devices: unexpected argument 'extra'\n");
}

struct Failure {
    std::vector<std::string> args;  // after "render"; "SCENE" stands for scenes/cornell.json
    int status;
    std::string err;     // the exact stderr, or its beginning when prefixOnly
    std::string output;  // the output file the command names
    bool prefixOnly = false;
    std::string contains = {};  // a part of stderr after the prefix
};

class CliFailure : public Cli {
  protected:
    // Runs the failing command twice: in a directory without its output file it creates nothing,
    // and over a previous output file it leaves that file as it was. `inputs` are the files the
    // test put in work/ beforehand.
    void Expect(const Failure& f, std::vector<std::string> inputs = {}) {
        std::vector<std::string> args = {"render"};
        for (const auto& a : f.args) args.push_back(a == "SCENE" ? Cornell() : a);
        std::string line;
        for (const auto& a : f.args) line += " " + a;
        std::sort(inputs.begin(), inputs.end());

        Result r = Run(args);
        EXPECT_EQ(r.status, f.status) << line << "\n" << r.err;
        if (f.prefixOnly) {
            EXPECT_EQ(r.err.substr(0, f.err.size()), f.err) << line;
            EXPECT_NE(r.err.find(f.contains, f.err.size()), std::string::npos) << line << "\n"
                                                                               << r.err;
        } else {
            EXPECT_EQ(r.err, f.err) << line;
        }
        EXPECT_EQ(r.out, "") << line;
        EXPECT_EQ(Entries(), inputs) << line << ": a failed render left files behind";

        if (f.output.empty() || f.output.find('/') != std::string::npos) return;
        const std::string previous = "the previous " + f.output + "\n";
        WriteText(Work(f.output), previous);
        r = Run(args);
        EXPECT_EQ(r.status, f.status) << line;
        EXPECT_EQ(ReadText(Work(f.output)), previous) << line << ": the previous output changed";
        fs::remove(Work(f.output));
        EXPECT_EQ(Entries(), inputs) << line << ": a failed render left files behind";
    }
};

TEST_F(CliFailure, UsageErrorsExitWith2AndNameTheProblem) {
    const std::vector<Failure> failures = {
        {{"SCENE", "-o", "x.exr", "--bogus"},
         2,
         "rayclass render: unknown option '--bogus' (see 'rayclass render --help')\n",
         "x.exr"},
        {{}, 2, "rayclass render: no scene given (see 'rayclass render --help')\n", ""},
        {{"SCENE"}, 2, "rayclass render: no output given: -o OUT.exr or -o OUT.png\n", ""},
        {{"SCENE", "-o"}, 2, "rayclass render: -o needs a value\n", ""},
        {{"SCENE", "-o", "x.exr", "--width", "abc"},
         2,
         "rayclass render: --width expects a number in [1, 16384], not 'abc'\n",
         "x.exr"},
        {{"SCENE", "-o", "x.exr", "--width", "0"},
         2,
         "rayclass render: --width expects a number in [1, 16384], not '0'\n",
         "x.exr"},
        {{"SCENE", "-o", "x.exr", "--height", "16385"},
         2,
         "rayclass render: --height expects a number in [1, 16384], not '16385'\n",
         "x.exr"},
        {{"SCENE", "-o", "x.exr", "--width", "-64"},
         2,
         "rayclass render: --width expects a number in [1, 16384], not '-64'\n",
         "x.exr"},
        {{"SCENE", "-o", "x.exr", "--width", "64px"},
         2,
         "rayclass render: --width expects a number in [1, 16384], not '64px'\n",
         "x.exr"},
        {{"SCENE", "-o", "x.exr", "--aov", "depth,foo"},
         2,
         "rayclass render: unknown AOV 'foo' (use depth, id, normal)\n",
         "x.exr"},
        {{"SCENE", "-o", "x.png", "--aov", "depth"},
         2,
         "rayclass render: --aov needs an .exr output\n",
         "x.png"},
        {{"SCENE", "-o", "x.tiff"},
         2,
         "rayclass render: x.tiff: unsupported output format '.tiff' (use .exr or .png)\n",
         "x.tiff"},
        {{"SCENE", "-o", "x"},
         2,
         "rayclass render: x: unsupported output format '' (use .exr or .png)\n",
         "x"},
        {{"SCENE", "-o", "x.exr", "--accel", "octree"},
         2,
         "rayclass render: --accel must be classify, bvh, auto, brute, kdtree, grid or cones, not "
         "'octree'\n",
         "x.exr"},
        {{"SCENE", "-o", "x.exr", "--exr-compression", "dwaa"},
         2,
         "rayclass render: --exr-compression must be zip, piz or none, not 'dwaa'\n",
         "x.exr"},
        {{"SCENE", "-o", "x.png", "--exr-compression", "none"},
         2,
         "rayclass render: --exr-compression needs an .exr output\n",
         "x.png"},
        {{"SCENE", "-o", "x.png", "--png-compression", "best"},
         2,
         "rayclass render: --png-compression must be fast, small or none, not 'best'\n",
         "x.png"},
        {{"SCENE", "-o", "x.exr", "--png-compression", "small"},
         2,
         "rayclass render: --png-compression needs a .png output\n",
         "x.exr"},
        {{"SCENE", "-o", "x.exr", "--reference", "--ray-encoding", "polar16"},
         2,
         "rayclass render: --ray-encoding polar16 rounds the kernels' ray directions, which "
         "--reference does not run\n",
         "x.exr"},
        {{"SCENE", "-o", "x.exr", "--stats", "s.txt"},
         2,
         "rayclass render: --stats expects a .json file, not 's.txt'\n",
         "x.exr"},
        {{"SCENE", "SCENE", "-o", "x.exr"},
         2,
         "rayclass render: unexpected argument '" + Cornell() + "' (one scene per render)\n",
         "x.exr"},
    };
    for (const auto& f : failures) Expect(f);
}

TEST_F(CliFailure, UnusableScenesExitWith1AndNameTheFile) {
    // The loader's messages (docs/scene-format.md): FILE[:LINE]: PROBLEM, with FILE as given.
    WriteText(Work("broken.json"), "{\"objects\": [}\n");
    WriteText(Work("unknown.json"), "{\"objcts\": []}\n");
    WriteText(Work("scene.txt"), "{}\n");
    fs::create_directory(Work("dir.json"));
    fs::create_symlink("loop.json", Work("loop.json"));  // open() fails with ELOOP
    const std::vector<std::string> inputs = {"broken.json", "unknown.json", "scene.txt", "dir.json",
                                             "loop.json"};
    const std::vector<Failure> failures = {
        {{"missing.json", "-o", "x.exr"},
         1,
         "rayclass render: error: missing.json: missing file\n",
         "x.exr"},
        {{"broken.json", "-o", "x.exr"},
         1,
         "rayclass render: error: broken.json:1: syntax error while parsing value - unexpected "
         "'}'; expected '[', '{', or a literal\n",
         "x.exr"},
        {{"unknown.json", "-o", "x.png"},
         1,
         "rayclass render: error: unknown.json:1: scene: unknown key 'objcts'\n",
         "x.png"},
        {{"dir.json", "-o", "x.exr"},
         1,
         "rayclass render: error: dir.json: is a directory\n",
         "x.exr"},
        {{"loop.json", "-o", "x.exr"},
         1,
         "rayclass render: error: loop.json: cannot read file (Too many levels of symbolic "
         "links)\n",
         "x.exr"},
        {{"scene.txt", "-o", "x.exr"},
         1,
         "rayclass render: error: scene.txt: unknown scene file extension '.txt' (expected "
         ".json or .obj)\n",
         "x.exr"},
    };
    for (const auto& f : failures) Expect(f, inputs);
}

TEST_F(CliFailure, HostileInputExitsWith1WithoutHangingOrCrashing) {
    // Special files (a FIFO blocked open() forever, /dev/zero was read until memory ran out),
    // binary garbage, coordinates beyond the float-safe range (they used to render infinities).
    ASSERT_EQ(::mkfifo(Work("fifo.json").c_str(), 0600), 0);
    fs::create_symlink("/dev/zero", Work("zero.obj"));
    std::string garbage;
    for (int i = 0; i < 4096; ++i) garbage.push_back(char((i * 2654435761u) >> 24));
    WriteText(Work("garbage.obj"), "v 0 0 0\n" + garbage);
    WriteText(Work("garbage.json"), garbage);
    WriteText(Work("far.json"),
              "{\"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0],\n"
              "\"radius\": 3e38}]}\n");
    const std::vector<std::string> inputs = {"far.json", "fifo.json", "garbage.json", "garbage.obj",
                                             "zero.obj"};
    const std::vector<Failure> failures = {
        {{"fifo.json", "-o", "x.exr"},
         1,
         "rayclass render: error: fifo.json: is not a regular file\n",
         "x.exr"},
        {{"zero.obj", "-o", "x.exr"},
         1,
         "rayclass render: error: zero.obj: is not a regular file\n",
         "x.exr"},
        {{"garbage.obj", "-o", "x.exr"}, 1, "rayclass render: error: garbage.obj:", "x.exr", true},
        {{"garbage.json", "-o", "x.exr"},
         1,
         "rayclass render: error: garbage.json:1: ",
         "x.exr",
         true},
        {{"far.json", "-o", "x.exr"},
         1,
         "rayclass render: error: far.json:2: object 1: 'radius' is out of range (magnitude "
         "above 1e+12)\n",
         "x.exr"},
    };
    for (const auto& f : failures) Expect(f, inputs);
}

TEST_F(CliFailure, UnreadableSceneExitsWith1) {
    if (geteuid() == 0) GTEST_SKIP() << "root reads files regardless of their permissions";
    WriteText(Work("secret.json"), "{}\n");
    fs::permissions(Work("secret.json"), fs::perms::none);
    Expect({{"secret.json", "-o", "x.exr"},
            1,
            "rayclass render: error: secret.json: cannot read file (Permission denied)\n",
            "x.exr"},
           {"secret.json"});
}

TEST_F(CliFailure, FailuresAfterLoadingLeaveNoOutput) {
    const std::vector<Failure> failures = {
        {{"SCENE", "-o", "x.exr", "--width", "8", "--height", "8", "--device", "banana"},
         1,
         "rayclass render: error: --device must be cpu, gpu, auto or a device index, not "
         "'banana'\n",
         "x.exr"},
        // The device starts while the scene loads: its error comes after the scene's, and a bad
        // scene is reported whatever the device.
        {{"SCENE", "-o", "x.exr", "--width", "8", "--height", "8", "--device", "999"},
         1,
         "rayclass render: error: device index 999 out of range (",
         "x.exr",
         true},
        {{"missing.json", "-o", "x.exr", "--device", "999"},
         1,
         "rayclass render: error: missing.json: missing file\n",
         "x.exr"},
        {{"SCENE", "-o", "x.exr", "--width", "8", "--height", "8", "--cl-options",
          "-cl-no-such-option"},
         1,
         // Every source file is named, but their list grows with the kernels; the test pins
         // the first and the rest of the message.
         "rayclass render: error: building OpenCL program (camera.cl, ",
         "x.exr",
         true,
         ".cl) with options '-cl-std=CL1.2 -DRC_LOCAL_SIZE=64 -cl-no-such-option' failed "
         "with CL_INVALID_BUILD_OPTIONS (-43)\nbuild log:\n"},
        // The stats file cannot be written: the image must not be written either.
        {{"SCENE", "-o", "x.exr", "--width", "8", "--height", "8", "--stats", "nodir/s.json"},
         1,
         "rayclass render: error: nodir/s.json: cannot write\n",
         "x.exr"},
        {{"SCENE", "-o", "nodir/x.exr", "--width", "8", "--height", "8", "-q"},
         1,
         "rayclass render: error: nodir/x.exr: cannot write: No such file or directory\n",
         "nodir/x.exr"},
    };
    for (const auto& f : failures) Expect(f);

    // A directory where the stats file should go.
    fs::create_directory(Work("s.json"));
    Expect({{"SCENE", "-o", "x.exr", "--width", "8", "--height", "8", "--stats", "s.json"},
            1,
            "rayclass render: error: s.json: cannot write\n",
            "x.exr"},
           {"s.json"});
}

TEST_F(CliFailure, FullDiskExitsWith1AndKeepsThePreviousOutput) {
    // A full disk, simulated by a file-size limit: with SIGXFSZ ignored, write() fails with EFBIG
    // once a file would grow past it (1 or 2 KiB: ulimit -f counts 512- or 1024-byte blocks), as
    // it fails with ENOSPC on a full disk. The host reference renderer writes no kernel cache.
    const std::string limit = "trap '' XFSZ; ulimit -f 2; ";
    for (const std::string name : {"x.exr", "x.png"}) {
        const std::vector<std::string> args = {"render", Cornell(),  "--reference", "--width",
                                               "64",     "--height", "48",          "-q",
                                               "-o",     name};
        Result r = Run(args, limit);
        EXPECT_EQ(r.status, 1) << r.err;
        EXPECT_EQ(r.err, "rayclass render: error: " + name + ": cannot write: File too large\n");
        EXPECT_EQ(Entries(), std::vector<std::string>{}) << "a failed render left files behind";
        const std::string previous = "the previous " + name + "\n";
        WriteText(Work(name), previous);
        r = Run(args, limit);
        EXPECT_EQ(r.status, 1) << r.err;
        EXPECT_EQ(ReadText(Work(name)), previous) << "the previous output changed";
        EXPECT_EQ(Entries(), std::vector<std::string>{name}) << "a temporary was left behind";
        // Without the limit the same render succeeds: the limit was what failed it.
        r = Run(args);
        EXPECT_EQ(r.status, 0) << r.err;
        EXPECT_GT(fs::file_size(Work(name)), 2048u) << "the image must exceed the limit";
        fs::remove(Work(name));
    }
}

TEST_F(CliFailure, FullDiskWhileWritingTheStatsKeepsThePreviousImage) {
    // A 1x1 PNG (about 70 bytes) fits under a 200-byte limit (prlimit counts bytes); the stats
    // (about 450 bytes) do not. The image must not replace the previous one.
    const std::vector<std::string> args = {"render", Cornell(),  "--reference", "--width",
                                           "1",      "--height", "1",           "-q",
                                           "-o",     "x.png",    "--stats",     "s.json"};
    WriteText(Work("x.png"), "the previous x.png\n");
    Result r = Run(args, "trap '' XFSZ; prlimit --fsize=200 ");
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_EQ(r.err, "rayclass render: error: s.json: cannot write\n");
    EXPECT_EQ(ReadText(Work("x.png")), "the previous x.png\n") << "the previous image changed";
    EXPECT_EQ(Entries(), std::vector<std::string>{"x.png"}) << "a temporary was left behind";
    r = Run(args);
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_LT(fs::file_size(Work("x.png")), 200u);
    EXPECT_GT(fs::file_size(Work("s.json")), 200u);
}

uint64_t Sum(const nlohmann::json& generations, const char* key) {
    uint64_t total = 0;
    for (const auto& g : generations) total += g.at(key).get<uint64_t>();
    return total;
}

TEST_F(Cli, RenderWritesTheImageAndConsistentStatsAndNothingElse) {
    // The classification throughout, whose stats say the most (the default, auto, may move
    // generations to the BVH).
    const Result r = Run({"render", Cornell(), "--width", "64", "--height", "48", "-o", "x.exr",
                          "--aov", "depth,id,normal", "--stats", "s.json", "--accel", "classify"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(Entries(), (std::vector<std::string>{"s.json", "x.exr"}));

    const image::Image img = image::ReadImage(Work("x.exr"));
    EXPECT_EQ(img.width, 64u);
    EXPECT_EQ(img.height, 48u);
    EXPECT_EQ(img.depth.size(), 64u * 48u);
    EXPECT_EQ(img.id.size(), 64u * 48u);
    EXPECT_EQ(img.normal.size(), 64u * 48u);

    const auto stats = nlohmann::json::parse(ReadText(Work("s.json")));
    for (const char* key : {"width", "height", "device", "rays_total", "rays_by_kind",
                            "rays_by_generation", "intersection_tests", "mrays_per_s", "time_s"}) {
        EXPECT_TRUE(stats.contains(key)) << key;
    }
    EXPECT_EQ(stats["eye_rays_from_camera"], 64 * 48);
    EXPECT_EQ(stats.at("width"), 64);
    EXPECT_EQ(stats.at("height"), 48);
    EXPECT_TRUE(stats.at("device").is_string());
    EXPECT_FALSE(stats.at("device").get<std::string>().empty());

    const auto& kinds = stats.at("rays_by_kind");
    for (const char* kind : {"eye", "shadow", "reflection", "refraction"}) {
        EXPECT_TRUE(kinds.contains(kind)) << kind;
    }
    const uint64_t eye = kinds.at("eye"), shadow = kinds.at("shadow"),
                   reflection = kinds.at("reflection"), refraction = kinds.at("refraction");
    EXPECT_EQ(eye, 64u * 48u);
    EXPECT_EQ(stats.at("rays_total").get<uint64_t>(), eye + shadow + reflection + refraction);
    // The Cornell scene has a mirror and a glass object: every kind of ray occurs.
    EXPECT_GT(shadow, 0u);
    EXPECT_GT(reflection, 0u);
    EXPECT_GT(refraction, 0u);

    // Generations: eye rays first, each spawning the next, ending with one that spawns nothing.
    const auto& gens = stats.at("rays_by_generation");
    ASSERT_TRUE(gens.is_array());
    ASSERT_GE(gens.size(), 2u);
    EXPECT_EQ(gens[0].at("rays").get<uint64_t>(), eye);
    for (size_t i = 0; i + 1 < gens.size(); ++i) {
        EXPECT_EQ(gens[i].at("spawned"), gens[i + 1].at("rays")) << "generation " << i;
    }
    EXPECT_EQ(gens.back().at("spawned"), 0);
    // Each generation says what answered it and how long it took; the eye rays' first hits
    // came from the raster pass (the default) or the classified query.
    EXPECT_THAT(gens[0].at("query").get<std::string>(), testing::AnyOf("raster", "classify/auto"));
    for (size_t i = 0; i < gens.size(); ++i) {
        if (i > 0) {
            EXPECT_EQ(gens[i].at("query"), "classify/auto") << "generation " << i;
        }
        EXPECT_EQ(gens[i].at("shadow_query"), "classify/auto") << "generation " << i;
        EXPECT_GE(gens[i].at("seconds").get<double>(), 0.0) << "generation " << i;
        EXPECT_FALSE(gens[i].contains("auto_ns_per_ray")) << "generation " << i;
    }
    EXPECT_EQ(Sum(gens, "rays"), eye + reflection + refraction);
    EXPECT_EQ(Sum(gens, "shadow_rays"), shadow);
    // Ray classification tests some primitives per ray, never more than brute force would (25
    // per ray: every primitive). The generations split the tests and the host classification.
    const uint64_t tests = stats.at("intersection_tests");
    EXPECT_EQ(Sum(gens, "intersection_tests"), tests);
    double hostClassify = 0;
    for (size_t i = 0; i < gens.size(); ++i) {
        EXPECT_GE(gens[i].at("host_classify_seconds").get<double>(), 0.0) << "generation " << i;
        hostClassify += gens[i].at("host_classify_seconds").get<double>();
    }
    EXPECT_NEAR(hostClassify, stats.at("time_s").at("host_classify").get<double>(), 1e-9);
    EXPECT_GE(tests, eye);
    EXPECT_LE(tests, (eye + reflection + refraction + shadow) * 25);
    EXPECT_GT(stats.at("mrays_per_s").get<double>(), 0.0);

    const auto& times = stats.at("time_s");
    for (const char* key : {"scene_load", "program_build", "total"}) {
        ASSERT_TRUE(times.contains(key)) << key;
        EXPECT_GE(times.at(key).get<double>(), 0.0) << key;
    }
    for (const char* kernel :
         {"kernel_rc_generate_eye_rays", "kernel_rc_occluded_fragment", "host_classify"}) {
        EXPECT_TRUE(times.contains(kernel)) << kernel;
    }
    EXPECT_LE(times.at("program_build").get<double>(), times.at("total").get<double>());
    // transfer_and_other is what the other timers of the render leave of it (the raster pass's
    // eye hits included).
    double parts = 0;
    for (const auto& [key, seconds] : times.items()) {
        if (key.starts_with("kernel_") || key.starts_with("eye_hits_") || key == "host" ||
            key == "host_classify" || key == "program_build" || key == "classify_setup" ||
            key == "bvh_build") {
            parts += seconds.get<double>();
        }
    }
    const double other = times.at("transfer_and_other").get<double>();
    if (other > 0) {
        EXPECT_NEAR(parts + other, times.at("render").get<double>(), 1e-6);
    }

    // Without -q, stderr ends with one line naming the output, its size and the rays; a render
    // slower than a second writes progress lines before it.
    const std::string summary = "rayclass: x.exr (64x48, " +
                                std::to_string(eye + shadow + reflection + refraction) + " rays, ";
    const size_t lastBreak = r.err.rfind('\n', r.err.empty() ? 0 : r.err.size() - 2);
    const std::string lastLine =
        lastBreak == std::string::npos ? r.err : r.err.substr(lastBreak + 1);
    EXPECT_EQ(lastLine.rfind(summary, 0), 0u) << r.err;
    EXPECT_EQ(r.err.find("rayclass: x.exr"), r.err.rfind("rayclass: x.exr")) << r.err;
}

TEST_F(Cli, ClassifyStatsReportsTheEyeRaysBothWays) {
    const Result r = Run({"classify-stats", Cornell(), "--width", "64", "--height", "48",
                          "--repeat", "1", "--json"});
    ASSERT_EQ(r.status, 0) << r.err;
    const auto stats = nlohmann::json::parse(r.out);
    for (const char* gen : {"eye", "mirror", "eye_from_camera"}) {
        ASSERT_TRUE(stats.contains(gen)) << gen;
        EXPECT_GT(stats[gen]["leaves"].get<int>(), 0) << gen;
    }
    EXPECT_EQ(stats["eye_from_camera"]["rays"], 64 * 48);
    // Cornell's camera lies outside the box, and a ray that enters it meets a wall: here both
    // ways answer exactly the rays that pass the box as misses without a leaf.
    EXPECT_EQ(stats["eye_from_camera"]["rays_missing_scene_box"],
              stats["eye"]["rays_missing_scene_box"]);
    EXPECT_GT(stats["eye"]["rays_missing_scene_box"].get<int>(), 0);
    const Result bad = Run({"classify-stats", Cornell(), "--camera", "far"});
    EXPECT_EQ(bad.status, 2);
    EXPECT_EQ(bad.err, "rayclass classify-stats: --camera must be scene or anchor, not 'far'\n");
}

TEST_F(Cli, ExrCompressionsGiveTheSamePixels) {
    std::vector<image::Image> images;
    for (const char* compression : {"zip", "piz", "none"}) {
        const std::string out = std::string(compression) + ".exr";
        const Result r = Run({"render", Cornell(), "--width", "16", "--height", "12", "-o", out,
                              "--exr-compression", compression, "--aov", "id", "-q"});
        ASSERT_EQ(r.status, 0) << compression << ": " << r.err;
        images.push_back(image::ReadImage(Work(out)));
    }
    for (size_t k = 1; k < images.size(); ++k) {
        EXPECT_EQ(std::memcmp(images[k].rgb.data(), images[0].rgb.data(),
                              images[0].rgb.size() * sizeof(glm::vec3)),
                  0)
            << k;
        EXPECT_EQ(images[k].id, images[0].id) << k;
    }
    // Uncompressed is what it says: larger than ZIP.
    EXPECT_GT(std::filesystem::file_size(Work("none.exr")),
              std::filesystem::file_size(Work("zip.exr")));
}

TEST_F(Cli, SecondRenderLoadsTheKernelsFromTheProgramCache) {
    const std::string cache = (root_ / "cache").string();
    std::vector<bool> fromCache;
    std::vector<std::string> images;
    for (const std::string& dir : {cache, cache, std::string("off")}) {
        const std::string n = std::to_string(images.size());
        const Result r = Run(
            {"render", Cornell(), "--width", "16", "--height", "12", "-o", n + ".exr",
             "--exr-compression", "none", "--aov", "depth,id,normal", "--stats", n + ".json", "-q"},
            "RAYCLASS_CACHE_DIR=" + ShellQuoted(dir) + " ");
        ASSERT_EQ(r.status, 0) << r.err;
        fromCache.push_back(
            nlohmann::json::parse(ReadText(Work(n + ".json"))).at("program_from_cache"));
        images.push_back(ReadText(Work(n + ".exr")));
    }
    EXPECT_EQ(fromCache, (std::vector<bool>{false, true, false}));
    // Kernels from the binary render the same bytes as kernels built from source.
    EXPECT_EQ(images[1], images[0]);
    EXPECT_EQ(images[2], images[0]);
    size_t entries = 0;
    for (const auto& e : fs::directory_iterator(cache)) entries += e.path().extension() == ".bin";
    EXPECT_EQ(entries, 1u);
}

TEST_F(Cli, QuietPngRenderReplacesThePreviousOutput) {
    WriteText(Work("x.png"), "the previous x.png\n");
    const Result r = Run({"render", Cornell(), "--width", "16", "--height", "12", "-o", "x.png",
                          "--exposure", "1", "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(r.err, "");
    EXPECT_EQ(Entries(), std::vector<std::string>{"x.png"});
    EXPECT_EQ(ReadText(Work("x.png")).substr(0, 8), "\x89PNG\r\n\x1a\n");
    const image::Image img = image::ReadImage(Work("x.png"));
    EXPECT_EQ(img.width, 16u);
    EXPECT_EQ(img.height, 12u);
}

// Every layer of `a` and `b`, bit for bit.
bool SameLayers(const image::Image& a, const image::Image& b) {
    auto same = [](const auto& x, const auto& y) {
        return x.size() == y.size() &&
               (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0);
    };
    return a.width == b.width && a.height == b.height && same(a.rgb, b.rgb) &&
           same(a.depth, b.depth) && same(a.id, b.id) && same(a.normal, b.normal);
}

TEST_F(Cli, TilesMergeIntoTheWholeRenderAndSayWhichTheyAre) {
    const std::vector<std::string> common = {
        "render", Cornell(), "--width", "50", "--height", "36", "--aov", "depth,id,normal", "-q"};
    auto render = [&](std::vector<std::string> extra) {
        std::vector<std::string> args = common;
        args.insert(args.end(), extra.begin(), extra.end());
        const Result r = Run(args);
        EXPECT_EQ(r.status, 0) << r.err;
    };
    render({"-o", "whole.exr"});
    std::vector<std::string> merge = {"merge", "-o", "merged.exr"};
    for (int i = 0; i < 3; ++i) {
        const std::string n = std::string(1, 't').append(std::to_string(i));  // see Run
        render(
            {"-o", n + ".exr", "--tile", std::to_string(i).append("/3"), "--stats", n + ".json"});
        const nlohmann::json stats = nlohmann::json::parse(ReadText(Work(n + ".json")));
        EXPECT_EQ(stats.at("tile"), (nlohmann::json{{"index", i}, {"count", 3}}));
        EXPECT_EQ(stats.at("width"), 50);
        merge.push_back(n + ".exr");
    }
    const Result r = Run(merge);
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(
        SameLayers(image::ReadImage(Work("merged.exr")), image::ReadImage(Work("whole.exr"))));
    // A tile left out: the merge names the pixels and writes nothing.
    const Result partial = Run({"merge", "-o", "partial.exr", "t0.exr", "t2.exr"});
    EXPECT_EQ(partial.status, 1);
    EXPECT_EQ(partial.err,
              "rayclass merge: error: no tile covers pixels 16,0,33,36 of the 50x36 image "
              "(--allow-partial merges anyway)\n");
    EXPECT_FALSE(fs::exists(Work("partial.exr")));
}

TEST_F(Cli, CropAndTileUsageErrors) {
    const std::pair<std::vector<std::string>, std::string> cases[] = {
        {{"--crop", "1,2,3"},
         "--crop expects X0,Y0,X1,Y1 (pixel bounds, end exclusive), not '1,2,3'"},
        {{"--crop", "4,2,4,9"}, "--crop 4,2,4,9 is empty (X1 must exceed X0 and Y1 Y0)"},
        {{"--tile", "3"}, "--tile expects I/N (tile I of N, from 0), not '3'"},
        {{"--tile", "4/4"}, "--tile expects a tile index I in [0, 3], not '4'"},
        {{"--tile", "0/2", "--crop", "0,0,1,1"},
         "--crop and --tile both choose the pixels: give one"},
    };
    for (const auto& [extra, message] : cases) {
        std::vector<std::string> args = {"render", Cornell(), "-o", "x.exr"};
        args.insert(args.end(), extra.begin(), extra.end());
        const Result r = Run(args);
        EXPECT_EQ(r.status, 2);
        std::string expected = "rayclass render: ";  // appended: see Run
        EXPECT_EQ(r.err, expected.append(message).append("\n"));
    }
    const Result r = Run({"render", Cornell(), "-o", "x.exr", "--crop", "0,0,801,10", "-q"});
    EXPECT_EQ(r.status, 1);
    EXPECT_EQ(r.err,
              "rayclass render: error: crop 0,0,801,10 is not a non-empty part of the "
              "800x600 image\n");
    EXPECT_EQ(Entries(), std::vector<std::string>{});
}

TEST_F(Cli, FramesFollowTheCameraPathToNumberedFiles) {
    const std::string source = EnvOr("RAYCLASS_SOURCE_DIR", ".");
    const std::vector<std::string> common = {"--width", "40", "--height", "30",
                                             "--aov",   "id", "-q"};
    std::vector<std::string> args = {"render",   source + "/scenes/cornell_orbit.json",
                                     "-o",       "f.exr",
                                     "--frames", "11:12",
                                     "--stats",  "s.json"};
    args.insert(args.end(), common.begin(), common.end());
    const Result r = Run(args);
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(Entries(),
              (std::vector<std::string>{"f_0011.exr", "f_0012.exr", "s_0011.json", "s_0012.json"}));
    const nlohmann::json stats = nlohmann::json::parse(ReadText(Work("s_0012.json")));
    EXPECT_EQ(stats.at("frame"), 12);
    EXPECT_EQ(stats.at("frame_time"), 1.0);
    // Frame 12 is keyframe 1 (12 fps): a still scene with that camera renders the same image.
    nlohmann::json scene = nlohmann::json::parse(ReadText(source + "/scenes/cornell_orbit.json"));
    nlohmann::json& camera = scene.at("camera");
    camera["position"] = camera.at("path").at("keyframes").at(1).at("position");
    camera["look_at"] = camera.at("path").at("keyframes").at(1).at("look_at");
    camera.erase("path");
    for (auto& object : scene.at("objects")) {
        if (object.contains("file"))
            object["file"] = source + "/scenes/" + object["file"].get<std::string>();
    }
    WriteText(Work("still.json"), scene.dump());
    args = {"render", "still.json", "-o", "still.exr"};
    args.insert(args.end(), common.begin(), common.end());
    ASSERT_EQ(Run(args).status, 0);
    EXPECT_TRUE(
        SameLayers(image::ReadImage(Work("f_0012.exr")), image::ReadImage(Work("still.exr"))));
    EXPECT_FALSE(
        SameLayers(image::ReadImage(Work("f_0011.exr")), image::ReadImage(Work("still.exr"))));
    // Frames past the path, or a scene without one: nothing is rendered.
    fs::remove_all(Work());
    fs::create_directories(Work());
    const Result past = Run({"render", source + "/scenes/cornell_orbit.json", "-o", "f.exr",
                             "--frames", "35:37", "-q"});
    EXPECT_EQ(past.status, 1);
    EXPECT_EQ(past.err,
              "rayclass render: error: frame 37 (time 3.083333) lies past the camera path's last "
              "keyframe (time 3.000000; frames 0..36)\n");
    const Result still = Run({"render", Cornell(), "-o", "f.exr", "--frame", "0", "-q"});
    EXPECT_EQ(still.status, 1);
    EXPECT_EQ(still.err, "rayclass render: error: " + Cornell() +
                             ": --frame and --frames need a camera 'path' in the scene\n");
    EXPECT_EQ(Entries(), std::vector<std::string>{});
}

// Scenes with patches: --patch-boxes is checked and sets the boxes per patch.
TEST_F(Cli, PatchScenesTakeBoxCounts) {
    const std::string teapot = EnvOr("RAYCLASS_SOURCE_DIR", ".") + "/scenes/teapot.json";
    const Result bad = Run({"render", teapot, "-o", "x.png", "--patch-boxes", "0"});
    EXPECT_EQ(bad.status, 2);
    EXPECT_EQ(bad.err, "rayclass render: --patch-boxes expects a number in [1, 4096], not '0'\n");
    EXPECT_EQ(Entries(), std::vector<std::string>{});
    const Result r = Run({"render", teapot, "-o", "x.png", "--width", "16", "--height", "12",
                          "--patch-boxes", "2", "--stats", "s.json", "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.err, "");
    const auto stats = nlohmann::json::parse(ReadText(Work("s.json")));
    EXPECT_EQ(stats.at("primitives"), 2 * 33 + 1);  // 33 patches, one sphere
    const auto& newton = stats.at("patch_newton");
    EXPECT_GT(newton.at("tests"), 0);
    EXPECT_EQ(newton.at("tests"),
              newton.at("culled").get<double>() + newton.at("converged").get<double>() +
                  newton.at("diverged").get<double>() + newton.at("left_box").get<double>() +
                  newton.at("on_cap").get<double>());
}

}  // namespace
}  // namespace rayclass::cli
