// Typed failures a plugin or the server raises. The server maps each to a status message the
// robot sees; none of them stops the server or another session.
#pragma once

#include <stdexcept>
#include <string>

namespace locd {

// A configuration is wrong: the message names the key, the value and what is allowed.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One measurement is unusable (NaN, wrong size, stamp going backwards, ...). The session
// counts it as rejected and carries on.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A plugin library cannot be used (missing entry point, wrong ABI, ...).
class PluginLoadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace locd
