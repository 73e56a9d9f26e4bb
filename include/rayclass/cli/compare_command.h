// `rayclass compare`: image difference metrics with optional pass/fail bounds, for regression
// checks in scripts.
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace rayclass::cli {

// `args` are the arguments after "compare". Metrics go to `out`, problems to `err`. Returns the
// exit status: 0 within the bounds (or --help), 1 when a bound is exceeded or the sizes differ,
// 2 on bad arguments or an unreadable input.
int CompareCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace rayclass::cli
