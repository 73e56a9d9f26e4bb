// Errors rayclass reports to its user. Every failure that a user can cause (bad input, a missing
// device, a kernel that does not build) is one of these; cli/main is the single place that turns
// them into a message and an exit status.
#pragma once

#include <stdexcept>
#include <string>

namespace rayclass {

class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// A problem in an input file. what() reads "FILE:LINE: PROBLEM" (or "FILE: PROBLEM" when the
// problem has no line), the form compilers use, so editors can jump to it.
class SceneError : public Error {
public:
    SceneError(std::string file, int line, std::string problem)
        : Error(Format(file, line, problem)),
          file_(std::move(file)),
          line_(line),
          problem_(std::move(problem)) {}

    const std::string& file() const { return file_; }
    int line() const { return line_; }  // 0 when the problem concerns the whole file
    const std::string& problem() const { return problem_; }

private:
    static std::string Format(const std::string& file, int line, const std::string& problem) {
        return line > 0 ? file + ":" + std::to_string(line) + ": " + problem : file + ": " + problem;
    }
    std::string file_;
    int line_;
    std::string problem_;
};

// A failed OpenCL call: carries the call, the error's name (CL_OUT_OF_RESOURCES, ...) and, for
// program builds, the build log.
class ClError : public Error {
public:
    ClError(const std::string& call, int code, const std::string& name,
            const std::string& detail = {});
    int code() const { return code_; }

private:
    int code_;
};

// A failed OpenGL/EGL step of the raster pass.
class GlError : public Error {
public:
    using Error::Error;
};

// Wrong usage of the command line.
class UsageError : public Error {
public:
    using Error::Error;
};

}  // namespace rayclass
