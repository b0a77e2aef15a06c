#include "record.hpp"

#include <atomic>
#include <chrono>
#include <csignal>
#include <iostream>
#include <thread>

#include "json.hpp"
#include "locd/mcap/recorder.hpp"

namespace locd::locctl {
namespace {

std::atomic<bool> stop_requested{false};
void on_stop(int) { stop_requested = true; }

}  // namespace

int command_record(const CommandLine& cl) {
  mcap::RecorderOptions options;
  options.domain_id = cl.domain;
  options.robots.assign(cl.arguments.begin() + 1, cl.arguments.end());
  options.writer.compression = mcap::parse_compression(cl.compression);
  const std::string& path = cl.arguments[0];
  std::signal(SIGINT, on_stop);
  std::signal(SIGTERM, on_stop);
  const auto start = std::chrono::steady_clock::now();
  mcap::Recorder recorder(path, options);
  std::cerr << "locctl record: recording " << (options.robots.empty() ? std::string("every robot") : std::to_string(options.robots.size()) + " robot(s)")
            << " on domain " << cl.domain << " into " << path << "; Ctrl-C stops\n";
  while (!stop_requested) {
    if (cl.duration_s && std::chrono::steady_clock::now() - start >= std::chrono::duration<double>(*cl.duration_s)) break;
    if (!recorder.counts().error.empty()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  recorder.stop();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const mcap::RecorderCounts c = recorder.counts();
  if (!c.error.empty()) throw std::runtime_error("recording into '" + path + "' failed: " + c.error);
  if (cl.json) {
    Json topics = Json::object();
    for (const auto& [topic, count] : c.per_topic) topics[topic] = count;
    std::cout << Json{{"command", "record"}, {"ok", true}, {"file", path}, {"messages", c.messages},
                      {"payload_bytes", c.bytes}, {"file_bytes", c.file_bytes}, {"dropped", c.dropped},
                      {"seconds", seconds}, {"topics", topics}}
                     .dump()
              << "\n";
  } else {
    std::cout << "recorded " << c.messages << " messages (" << c.bytes << " bytes of samples, file " << c.file_bytes
              << " bytes) in " << seconds << " s into " << path;
    if (c.dropped > 0) std::cout << "; " << c.dropped << " dropped (the disk did not keep up)";
    std::cout << "\n";
  }
  return 0;
}

}  // namespace locd::locctl
