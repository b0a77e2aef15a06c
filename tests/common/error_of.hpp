// The message of the error of type E that `f` throws, or "no <E>" when it throws none: the
// form every "the message names the key, value and what is allowed" assertion reads.
#pragma once

#include <string>

#include "locd/sdk/errors.hpp"

namespace locd::test {

template <typename E = ConfigError, typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace locd::test
