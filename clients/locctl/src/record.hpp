// `locctl record OUT.mcap [ROBOT...]`: every locd topic of those robots into an MCAP file.
#pragma once

#include "command_line.hpp"

namespace locd::locctl {

// Records until SIGINT/SIGTERM or --duration; returns the exit status. Throws on failure.
int command_record(const CommandLine& cl);

}  // namespace locd::locctl
