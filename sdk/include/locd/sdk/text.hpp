// Text from the network on its way into a log line or a message: control characters, quotes and
// bytes outside printable ASCII are escaped, so a robot id or a YAML value cannot forge a line.
#pragma once

#include <string>
#include <string_view>

namespace locd {

// "\n" -> "\\n", "\t" -> "\\t", other bytes outside 0x20..0x7e -> "\\xHH"; a backslash stays, so
// text escaped once (a message naming a robot id) reads the same when the log escapes it again.
// At most `max_length` input bytes are shown; longer text ends in "...(N bytes)".
std::string escaped(std::string_view text, size_t max_length = 256);

}  // namespace locd
