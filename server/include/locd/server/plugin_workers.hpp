// Plugins run in worker processes (locd-worker) that PluginWorkers starts, feeds and watches, so
// that a plugin that crashes, exits, hangs or exhausts its memory costs only the sessions on its
// worker. Each worker runs instances of one plugin (at most `sessions_per_worker`), one request at
// a time, in the order sent. One I/O thread reads every worker's replies, flushes what could not
// be written at once, enforces the deadline of the request each worker is busy with (a worker that
// misses it is killed) and reaps workers that end. The owner of an instance (a Session) hears its
// replies, log lines and the loss of its worker on that thread, in order.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "locd/server/log.hpp"
#include "locd/server/plugin_index.hpp"
#include "locd/server/worker_launch.hpp"
#include "locd/server/worker_protocol.hpp"

namespace locd::server {

struct WorkerSettings {
  std::filesystem::path executable;  // locd-worker
  // Instances of one plugin sharing a process; kAuto: each robot alone while the plugin has fewer
  // than workers_per_plugin workers, then every new session joins the plugin's least-loaded one.
  static constexpr size_t kAuto = 0;
  size_t sessions_per_worker = kAuto;
  size_t workers_per_plugin = 0;     // the cap of kAuto; 0: max(8, 4 x this machine's cores)
  double configure_deadline_s = 120.0;
  double update_deadline_s = 10.0;   // update, set_pose, save_map, release
  long memory_limit_mb = 4096;       // address space of a worker (RLIMIT_AS); 0 = unbounded
  // A worker process pinged every kPingPeriod that has not answered for this long is killed: it
  // is stopped (SIGSTOP) or frozen, whatever its request's deadline. A thread of its own answers,
  // so a plugin busy with a long update still does. 0: no ping.
  double liveness_timeout_s = 0.7;
  // Per-plugin overrides (config `plugin_workers.plugins`).
  struct Override {
    std::optional<size_t> sessions_per_worker;
    std::optional<double> configure_deadline_s;
    std::optional<double> update_deadline_s;
  };
  std::map<std::string, Override> plugins;
  // What workers may read and write (filled from the server's directories), and whether they
  // confine themselves at all (config `plugin_workers.sandbox`; off only to measure its cost).
  SandboxPaths sandbox;

  size_t sessions_per_worker_of(const std::string& plugin) const;  // kAuto or a fixed count
  size_t auto_worker_cap() const;
  double deadline_s(const std::string& plugin, worker::Op op) const;
};

// When a session whose plugin failed is restarted, and when it is given up.
struct FailurePolicy {
  uint32_t max_failures = 5;       // failures in a row after which the session is stopped as failed
  double backoff_initial_s = 0.5;  // delay before the first restart after a failure of the session's own
  double backoff_max_s = 30.0;     // the delay doubles up to this
  double failure_reset_s = 60.0;   // running this long without failing forgets the failures in a row
};

// Why an instance's worker is gone, as its owner hears it.
struct WorkerLoss {
  std::string description;  // names the plugin, the worker's pid, the signal or exit code and the request
  bool blamed = false;      // the worker died on this instance's request (or, idle, with no request)
};

class InstanceOwner {
 public:
  virtual ~InstanceOwner() = default;
  virtual void on_reply(uint64_t instance, worker::Reply reply) = 0;
  virtual void on_log(uint64_t instance, const worker::LogLine& line) = 0;
  virtual void on_lost(uint64_t instance, const WorkerLoss& loss) = 0;
};

class PluginWorkers {
 public:
  PluginWorkers(WorkerSettings settings, Limits limits, Logger& logger);
  ~PluginWorkers();
  PluginWorkers(const PluginWorkers&) = delete;
  PluginWorkers& operator=(const PluginWorkers&) = delete;

  // A new instance of `plugin` on a worker of that plugin with room, started when none
  // has. Throws std::runtime_error when no worker can be started.
  uint64_t create_instance(const std::shared_ptr<const PluginDescription>& plugin, std::weak_ptr<InstanceOwner> owner);
  // The requests of an instance, encoded here (the worker channel has one owner: this class
  // writes every frame and reads every reply). `what` names the request in messages should the
  // worker die or hang on it ("update of locd/scan at 12.300000 s"). Each returns false when the
  // instance is gone (its loss is reported to the owner); the reply reaches the owner's on_reply.
  bool configure(uint64_t instance, const worker::ConfigureRequest& request, std::string what);
  bool set_pose(uint64_t instance, const PoseEstimate& pose, std::string what);
  bool update(uint64_t instance, const Measurement& measurement, std::string what);
  bool save_map(uint64_t instance, std::string what);
  // Sends kRelease and forgets the instance: its owner hears nothing more of it.
  void release(uint64_t instance);
  // Runs `task` on the I/O thread after `delay` (restart backoff). Dropped at shutdown.
  void after(std::chrono::steady_clock::duration delay, std::function<void()> task);
  // Closes every channel, waits up to `grace` for the workers to exit, kills the rest, joins the
  // I/O thread. Owners hear nothing once it has begun.
  void shutdown(std::chrono::milliseconds grace);

  // For tests and statistics.
  pid_t pid_of(uint64_t instance) const;  // 0 when the instance is unknown
  size_t worker_count() const;

 private:
  // Queues an encoded request frame for `instance`.
  bool send(uint64_t instance, worker::Op op, std::string frame, std::string what);
  struct Worker;
  struct Timer {
    std::chrono::steady_clock::time_point due;
    std::function<void()> task;
  };

  struct SpawnRequest;
  std::shared_ptr<Worker> start_worker(const std::shared_ptr<const PluginDescription>& plugin);
  std::shared_ptr<Worker> start_worker_on_io_thread(const std::shared_ptr<const PluginDescription>& plugin);
  void run_spawn_requests();
  void run();
  void read_from(const std::shared_ptr<Worker>& worker);
  void flush(const std::shared_ptr<Worker>& worker);
  bool queue_locked(Worker& worker, uint64_t instance, worker::Op op, std::string frame, std::string what);
  void write_some_locked(Worker& worker);
  void kill(const std::shared_ptr<Worker>& worker, const std::string& reason);
  void reap(const std::shared_ptr<Worker>& worker);
  void check_deadlines();
  // Pings the workers and kills one that stopped answering (liveness_timeout_s).
  void check_liveness();
  void read_liveness(const std::shared_ptr<Worker>& worker);
  void read_stderr(const std::shared_ptr<Worker>& worker);
  void run_due_timers();
  int next_wait_ms() const;
  std::shared_ptr<Worker> worker_by_key(uint64_t key) const;
  std::shared_ptr<InstanceOwner> owner_of(uint64_t instance) const;

  const WorkerSettings settings_;
  const Limits limits_;
  const uint64_t max_payload_;
  Logger& logger_;
  int epoll_ = -1;
  int wake_ = -1;  // eventfd

  mutable std::mutex mutex_;
  std::map<uint64_t, std::shared_ptr<Worker>> workers_;  // by worker key
  struct Instance {
    std::shared_ptr<Worker> worker;
    std::weak_ptr<InstanceOwner> owner;
  };
  std::map<uint64_t, Instance> instances_;
  std::vector<Timer> timers_;
  std::vector<std::shared_ptr<SpawnRequest>> spawns_;
  uint64_t next_instance_ = 1;
  uint64_t next_worker_key_ = 1;
  std::map<std::string, size_t> spawning_;  // per plugin: workers being started for create_instance
  bool stopping_ = false;
  bool stopped_ = false;
  std::chrono::steady_clock::time_point last_liveness_check_{};  // I/O thread only
  std::thread io_;
};

}  // namespace locd::server
