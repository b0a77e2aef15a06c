// locctl --json: one JSON object per answer (per pose for watch), keys in the order written.
// nlohmann-json escapes strings per RFC 8259, writes numbers that read back exactly and writes
// NaN and infinities as null.
#pragma once

#include <nlohmann/json.hpp>

namespace locd::locctl {

using Json = nlohmann::ordered_json;

}  // namespace locd::locctl
