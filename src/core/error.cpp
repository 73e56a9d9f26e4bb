#include "rayclass/core/error.h"

namespace rayclass {

ClError::ClError(std::string call, int code, std::string detail)
    : Error(call + " failed: " + std::to_string(code) + (detail.empty() ? "" : "\n" + detail)),
      code_(code) {}

}  // namespace rayclass
