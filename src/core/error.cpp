#include "rayclass/core/error.h"

namespace rayclass {

ClError::ClError(const std::string& call, int code, const std::string& name,
                 const std::string& detail)
    : Error(call + " failed with " + name + " (" + std::to_string(code) + ")" +
            (detail.empty() ? "" : "\n" + detail)),
      code_(code) {}

}  // namespace rayclass
