// The one place that includes the OpenCL C++ bindings, with the settings the Debian header needs
// (a minimum version of 120 does not compile with target 300).
#pragma once

#define CL_HPP_TARGET_OPENCL_VERSION 300
#define CL_HPP_MINIMUM_OPENCL_VERSION 200
#define CL_HPP_ENABLE_EXCEPTIONS
#include <CL/opencl.hpp>
