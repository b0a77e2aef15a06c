#include "locd/dds/log_sink.hpp"

#include <dds/dds.h>

namespace locd::dds {
namespace {

void forward(void* arg, const dds_log_data_t* data) {
  const auto* callback = static_cast<const LogSink::Callback*>(arg);
  if (!data || !data->message) return;
  // `message` starts after Cyclone's header (time, domain, thread: hdrsize bytes before it).
  std::string message(data->message, data->size);
  while (!message.empty() && (message.back() == '\n' || message.back() == ' ')) message.pop_back();
  if (message.empty()) return;
  LogLevel level = LogLevel::kInfo;
  if (data->priority & (DDS_LC_FATAL | DDS_LC_ERROR)) {
    level = LogLevel::kError;
  } else if (data->priority & DDS_LC_WARNING) {
    level = LogLevel::kWarning;
  }
  (*callback)(level, message);
}

}  // namespace

LogSink::LogSink(Callback callback) : callback_(std::move(callback)) { dds_set_log_sink(&forward, &callback_); }

LogSink::~LogSink() { dds_set_log_sink(nullptr, nullptr); }

}  // namespace locd::dds
