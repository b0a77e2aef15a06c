#include "locd/mcap/recorder.hpp"

#include <dds/ddsi/ddsi_serdata.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>

#include "locd/mcap/locd_writer.hpp"
#include "locd/sdk/robot_id.hpp"

namespace locd::mcap {
namespace {

int64_t wall_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

struct Sample {
  const TopicInfo* topic;
  std::string robot_id;
  uint64_t log_time, publish_time;
  std::vector<uint8_t> bytes;
};

}  // namespace

struct Recorder::Impl {
  struct Source {
    Impl* impl;
    const TopicInfo* topic;
    dds::Entity subscriber;
    dds::Entity reader;
  };

  RecorderOptions options;
  LocdWriter writer;  // used by the writer thread only (and by stop() after it ended)
  dds::Participant participant;
  std::vector<std::unique_ptr<Source>> sources;

  mutable std::mutex mutex;
  std::condition_variable wake;
  std::deque<Sample> queue;
  size_t queued_bytes = 0;
  bool stopping = false;
  RecorderCounts counts;
  std::thread thread;


  Impl(const std::string& path, const RecorderOptions& o)
      : options(o), writer(path, o.writer), participant(o.domain_id) {
    dds::Partitions robots;
    for (const std::string& r : o.robots) robots.push_back(topics::robot_partition(r));
    if (robots.empty()) robots.push_back(topics::kAllRobotsPartition);
    for (const TopicInfo& t : locd_topics()) add_source(t, t.per_robot ? robots : dds::Partitions{});
    thread = std::thread([this] { write_loop(); });
  }

  void add_source(const TopicInfo& t, const dds::Partitions& partitions) {
    auto source = std::make_unique<Source>();
    source->impl = this;
    source->topic = &t;
    const dds_entity_t topic = dds::create_topic(participant, *t.descriptor, t.topic);
    std::unique_ptr<dds_qos_t, dds::QosDeleter> qos(dds_create_qos());
    dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, options.depth);
    // A transient-local reader would not match the volatile writers of sensors and poses.
    if (t.transient_local) dds_qset_durability(qos.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
    // The serving server's outputs: what the robot gets (a shared reader would match no server).
    if (t.exclusive) dds_qset_ownership(qos.get(), DDS_OWNERSHIP_EXCLUSIVE);
    dds_listener_t* listener = dds_create_listener(source.get());
    dds_lset_data_available(listener, &Impl::on_data_available);
    source->subscriber = dds::subscriber_for(participant, partitions);
    const dds_entity_t parent = source->subscriber.handle() ? source->subscriber.handle() : participant.handle();
    const dds_entity_t reader = dds_create_reader(parent, topic, qos.get(), listener);
    dds_delete_listener(listener);
    source->reader = dds::Entity(dds::check(reader, (std::string("create reader on ") + t.topic).c_str()));
    sources.push_back(std::move(source));
  }

  static void on_data_available(dds_entity_t reader, void* arg) {
    auto* source = static_cast<Source*>(arg);
    constexpr uint32_t kBatch = 16;
    struct ddsi_serdata* data[kBatch];
    dds_sample_info_t infos[kBatch];
    for (;;) {
      const dds_return_t n = dds_takecdr(reader, data, kBatch, infos, DDS_ANY_STATE);
      if (n <= 0) return;
      const uint64_t now = static_cast<uint64_t>(wall_ns());
      for (int i = 0; i < n; ++i) {
        if (infos[i].valid_data) {
          Sample s;
          s.topic = source->topic;
          s.log_time = now;
          s.publish_time = static_cast<uint64_t>(infos[i].source_timestamp);
          s.bytes.resize(ddsi_serdata_size(data[i]));
          ddsi_serdata_to_ser(data[i], 0, s.bytes.size(), s.bytes.data());
          if (s.topic->per_robot) s.robot_id = robot_id_of(s.bytes.data(), s.bytes.size());
          source->impl->enqueue(std::move(s));
        }
        ddsi_serdata_unref(data[i]);
      }
      if (static_cast<uint32_t>(n) < kBatch) return;
    }
  }

  void enqueue(Sample&& s) {
    std::lock_guard<std::mutex> lock(mutex);
    if (stopping) return;
    if (queued_bytes + s.bytes.size() > options.max_queue_bytes) {
      ++counts.dropped;
      return;
    }
    queued_bytes += s.bytes.size();
    queue.push_back(std::move(s));
    wake.notify_one();
  }

  void write_loop() {
    try {
      write_batches();
    } catch (const std::exception& e) {  // the disk failed: say so, stop recording
      std::lock_guard<std::mutex> lock(mutex);
      counts.error = e.what();
      stopping = true;
    }
  }

  void write_batches() {
    std::deque<Sample> batch;
    for (;;) {
      bool done = false;
      {
        std::unique_lock<std::mutex> lock(mutex);
        wake.wait_for(lock, std::chrono::milliseconds(100), [&] { return stopping || !queue.empty(); });
        batch.swap(queue);
        queued_bytes = 0;
        done = stopping;
      }
      for (const Sample& s : batch) {
        if (s.topic->per_robot && !robot_id_error(s.robot_id).empty()) continue;  // malformed: not recordable
        writer.write(*s.topic, s.robot_id, s.log_time, s.publish_time, s.bytes.data(), s.bytes.size());
        std::lock_guard<std::mutex> lock(mutex);
        ++counts.messages;
        counts.bytes += s.bytes.size();
        ++counts.per_topic[s.topic->topic];
      }
      batch.clear();
      writer.writer().close_chunk_if_older(options.chunk_age);
      {
        std::lock_guard<std::mutex> lock(mutex);
        counts.file_bytes = writer.writer().bytes_written();
      }
      if (done) return;
    }
  }

  void stop() {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (stopping && !thread.joinable()) return;
    }
    sources.clear();  // no more listener calls
    {
      std::lock_guard<std::mutex> lock(mutex);
      stopping = true;
      wake.notify_one();
    }
    if (thread.joinable()) thread.join();
    writer.writer().close();  // throws when the file cannot be finished
    std::lock_guard<std::mutex> lock(mutex);
    counts.file_bytes = writer.writer().bytes_written();
  }
};

namespace {
// Refuses a bad robot id before the file is created.
const RecorderOptions& checked(const RecorderOptions& options) {
  for (const std::string& r : options.robots) check_robot_id(r);
  return options;
}
}  // namespace

Recorder::Recorder(const std::string& path, const RecorderOptions& options)
    : impl_(std::make_unique<Impl>(path, checked(options))) {}

Recorder::~Recorder() {
  try {
    stop();
  } catch (...) {
  }
}

void Recorder::stop() { impl_->stop(); }

RecorderCounts Recorder::counts() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->counts;
}

uint32_t Recorder::matched_writers() const {
  uint32_t total = 0;
  for (const auto& s : impl_->sources) {
    dds_subscription_matched_status_t st{};
    if (dds_get_subscription_matched_status(s->reader.handle(), &st) == DDS_RETCODE_OK) total += st.current_count;
  }
  return total;
}

}  // namespace locd::mcap
