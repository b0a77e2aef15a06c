// Polls a condition until it holds or a timeout passes: the wait of tests that watch DDS state
// (matched endpoints, a status field) without a callback to wake them.
#pragma once

#include <chrono>
#include <thread>

namespace locd::test {

template <typename Condition>
bool eventually(Condition condition, std::chrono::milliseconds timeout = std::chrono::seconds(30)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

}  // namespace locd::test
