#include "locd/server/plugin_workers.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <deque>
#include <fstream>
#include <future>
#include <sstream>
#include <stdexcept>

extern char** environ;

namespace locd::server {
namespace {

using Clock = std::chrono::steady_clock;

// How often the I/O thread looks at deadlines and timers when nothing else wakes it.
constexpr int kTickMs = 25;
constexpr int kCheckEveryMs = 10;
constexpr size_t kReadChunk = 256 * 1024;
// The channel's and the liveness socket's fd numbers inside the worker (locd-worker --channel-fd,
// --liveness-fd).
constexpr int kWorkerChannelFd = 3;
constexpr int kWorkerLivenessFd = 4;
// Liveness: a byte to every worker this often; its ping thread sends it back.
constexpr auto kPingPeriod = std::chrono::milliseconds(200);
// What epoll tells about a worker: data.u64 = key * kEventKinds + kind.
constexpr uint64_t kEventKinds = 4;
enum EventKind : uint64_t { kChannelEvent = 0, kExitEvent = 1, kLivenessEvent = 2, kStderrEvent = 3 };
// After a SIGKILL, how long shutdown waits for the kernel to reap a worker.
constexpr auto kReapAfterKill = std::chrono::milliseconds(1000);

int pidfd_open(pid_t pid) { return static_cast<int>(::syscall(SYS_pidfd_open, pid, 0)); }
int pidfd_send_signal(int pidfd, int signal) {
  return static_cast<int>(::syscall(SYS_pidfd_send_signal, pidfd, signal, nullptr, 0));
}

std::string signal_description(int signal) {
  const char* abbreviation = sigabbrev_np(signal);
  const char* text = strsignal(signal);
  return "signal " + std::to_string(signal) + " (" + (abbreviation ? std::string("SIG") + abbreviation : "?") +
         (text ? std::string(", ") + text : "") + ")";
}

std::string seconds(double s) {
  std::ostringstream out;
  out << s << " s";
  return out.str();
}

// What the kernel says of a process that does not answer (field 3 of /proc/PID/stat).
std::string process_state(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  std::getline(in, text);
  const size_t close = text.rfind(')');
  if (close == std::string::npos || close + 2 >= text.size()) return "its state unknown";
  switch (text[close + 2]) {
    case 'T': return "the process was stopped (SIGSTOP)";
    case 't': return "the process was stopped by a debugger";
    case 'D': return "the process was in an uninterruptible wait";
    case 'Z': return "the process had ended";
    default: return std::string("the process was in state ") + text[close + 2];
  }
}

}  // namespace

size_t WorkerSettings::auto_worker_cap() const {
  if (workers_per_plugin > 0) return workers_per_plugin;
  return std::max<size_t>(8, 4 * static_cast<size_t>(std::max(1u, std::thread::hardware_concurrency())));
}

size_t WorkerSettings::sessions_per_worker_of(const std::string& plugin) const {
  auto it = plugins.find(plugin);
  return it != plugins.end() && it->second.sessions_per_worker ? *it->second.sessions_per_worker : sessions_per_worker;
}

double WorkerSettings::deadline_s(const std::string& plugin, worker::Op op) const {
  auto it = plugins.find(plugin);
  if (op == worker::Op::kConfigure) {
    return it != plugins.end() && it->second.configure_deadline_s ? *it->second.configure_deadline_s
                                                                  : configure_deadline_s;
  }
  return it != plugins.end() && it->second.update_deadline_s ? *it->second.update_deadline_s : update_deadline_s;
}

struct PluginWorkers::SpawnRequest {
  std::shared_ptr<const PluginDescription> plugin;
  std::promise<std::shared_ptr<Worker>> result;
};

struct PluginWorkers::Worker {
  uint64_t key = 0;
  pid_t pid = 0;  // also its process group: everything the plugin starts is killed with it
  int pidfd = -1;
  int fd = -1;
  int liveness_fd = -1;
  int stderr_fd = -1;  // the worker's stderr: text from outside, logged escaped and rate-limited
  std::string plugin;
  std::unique_ptr<StderrLines> stderr_lines;  // I/O thread only

  struct Request {
    uint64_t instance;
    worker::Op op;
    std::string what;
    double deadline_s;
  };

  std::mutex mutex;  // everything below but `inbox`
  std::string outbox;
  size_t outbox_sent = 0;
  bool writing = false;  // EPOLLOUT registered
  std::deque<Request> in_flight;
  Clock::time_point front_since;
  size_t instances = 0;
  bool closed = false;   // accepts no more requests
  bool retired = false;  // closed by the server: its last instance was released
  bool deadline_missed = false;
  std::string kill_reason;

  std::string inbox;  // I/O thread only
  // Liveness (I/O thread only): the ping not answered yet, and when the next is due.
  bool pinging = false;  // from its first liveness byte on (a worker still starting is not pinged)
  bool ping_outstanding = false;
  Clock::time_point ping_sent{}, next_ping{};
};

PluginWorkers::PluginWorkers(WorkerSettings settings, Limits limits, Logger& logger)
    : settings_(std::move(settings)), limits_(limits), max_payload_(worker::max_payload_bytes(limits)),
      logger_(logger) {
  epoll_ = epoll_create1(EPOLL_CLOEXEC);
  wake_ = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (epoll_ < 0 || wake_ < 0) throw std::runtime_error(std::string("epoll/eventfd: ") + std::strerror(errno));
  epoll_event event{};
  event.events = EPOLLIN;
  event.data.u64 = 0;
  epoll_ctl(epoll_, EPOLL_CTL_ADD, wake_, &event);
  io_ = std::thread([this] { run(); });
}

PluginWorkers::~PluginWorkers() {
  shutdown(std::chrono::milliseconds(1000));
  close(epoll_);
  close(wake_);
}

std::shared_ptr<PluginWorkers::Worker> PluginWorkers::start_worker(const std::shared_ptr<const PluginDescription>& plugin) {
  int channel[2], liveness[2];
  if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, channel) != 0) {
    throw std::runtime_error(std::string("cannot make a worker channel: ") + std::strerror(errno));
  }
  if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, liveness) != 0) {
    const int error = errno;
    close(channel[0]);
    close(channel[1]);
    throw std::runtime_error(std::string("cannot make a worker's liveness socket: ") + std::strerror(error));
  }
  int errors[2];
  if (pipe2(errors, O_CLOEXEC) != 0) {
    const int error = errno;
    for (int fd : {channel[0], channel[1], liveness[0], liveness[1]}) close(fd);
    throw std::runtime_error(std::string("cannot make a worker's stderr pipe: ") + std::strerror(error));
  }
  const std::string exe = settings_.executable.string();
  const std::string limits = std::to_string(limits_.max_scan_beams) + "," + std::to_string(limits_.max_cloud_points) +
                             "," + std::to_string(limits_.max_image_pixels) + "," +
                             std::to_string(limits_.max_detections) + "," + std::to_string(limits_.max_particles) +
                             "," + std::to_string(limits_.max_map_cells);
  std::vector<std::string> arguments = {exe,
                                              "--plugin",
                                              plugin->file.string(),
                                              "--channel-fd",
                                              std::to_string(kWorkerChannelFd),
                                              "--liveness-fd",
                                              std::to_string(kWorkerLivenessFd),
                                              "--parent",
                                              std::to_string(getpid()),
                                              "--memory-limit-mb",
                                              std::to_string(settings_.memory_limit_mb),
                                              "--limits",
                                              limits};
  append_sandbox_arguments(arguments, settings_.sandbox);
  std::vector<char*> argv;
  for (const auto& a : arguments) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  // No DDS identity, no secrets: only the variables a plugin's libraries use.
  std::vector<std::string> environment = worker_environment(environ);
  std::vector<char*> envp;
  for (auto& e : environment) envp.push_back(e.data());
  envp.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, channel[1], kWorkerChannelFd);
  posix_spawn_file_actions_adddup2(&actions, liveness[1], kWorkerLivenessFd);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, errors[1], STDERR_FILENO);
  posix_spawn_file_actions_addclosefrom_np(&actions, kWorkerLivenessFd + 1);
  // A process group of its own (its id is the worker's pid): whatever the plugin forks is in it,
  // and is killed with the worker (PR_SET_PDEATHSIG is not inherited by the plugin's children).
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attributes, 0);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, exe.c_str(), &actions, &attributes, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  close(channel[1]);
  close(liveness[1]);
  close(errors[1]);
  if (rc != 0) {
    close(channel[0]);
    close(liveness[0]);
    close(errors[0]);
    throw std::runtime_error("cannot start the plugin worker '" + exe + "': " + std::strerror(rc));
  }
  const int pidfd = pidfd_open(pid);
  if (pidfd < 0) {
    const int error = errno;
    ::kill(-pid, SIGKILL);
    waitpid(pid, nullptr, 0);
    close(channel[0]);
    close(liveness[0]);
    close(errors[0]);
    throw std::runtime_error(std::string("pidfd_open: ") + std::strerror(error));
  }
  fcntl(channel[0], F_SETFL, fcntl(channel[0], F_GETFL) | O_NONBLOCK);
  fcntl(liveness[0], F_SETFL, fcntl(liveness[0], F_GETFL) | O_NONBLOCK);
  fcntl(errors[0], F_SETFL, fcntl(errors[0], F_GETFL) | O_NONBLOCK);

  auto worker = std::make_shared<Worker>();
  worker->pid = pid;
  worker->pidfd = pidfd;
  worker->fd = channel[0];
  worker->liveness_fd = liveness[0];
  worker->stderr_fd = errors[0];
  worker->plugin = plugin->name;
  worker->stderr_lines =
      std::make_unique<StderrLines>("plugin '" + plugin->name + "' (worker pid " + std::to_string(pid) + ")", logger_);
  // Its first instance is the one it is started for: counted before any other session can see
  // the worker, so sessions_per_worker holds however many sessions start at once.
  worker->instances = 1;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    worker->key = next_worker_key_++;
    workers_[worker->key] = worker;
  }
  epoll_event event{};
  event.events = EPOLLIN | EPOLLRDHUP;
  event.data.u64 = worker->key * kEventKinds + kChannelEvent;
  epoll_ctl(epoll_, EPOLL_CTL_ADD, worker->fd, &event);
  event.events = EPOLLIN;
  event.data.u64 = worker->key * kEventKinds + kExitEvent;
  epoll_ctl(epoll_, EPOLL_CTL_ADD, worker->pidfd, &event);
  event.events = EPOLLIN;
  event.data.u64 = worker->key * kEventKinds + kLivenessEvent;
  epoll_ctl(epoll_, EPOLL_CTL_ADD, worker->liveness_fd, &event);
  event.events = EPOLLIN;
  event.data.u64 = worker->key * kEventKinds + kStderrEvent;
  epoll_ctl(epoll_, EPOLL_CTL_ADD, worker->stderr_fd, &event);
  logger_.log(LogLevel::kDebug, "server", "started worker pid " + std::to_string(pid) + " for plugin " + worker->plugin);
  return worker;
}

std::shared_ptr<PluginWorkers::Worker> PluginWorkers::start_worker_on_io_thread(
    const std::shared_ptr<const PluginDescription>& plugin) {
  // A worker dies with the thread that started it (PR_SET_PDEATHSIG), so only the I/O thread,
  // which lives as long as the workers, starts them.
  if (std::this_thread::get_id() == io_.get_id()) return start_worker(plugin);
  auto request = std::make_shared<SpawnRequest>();
  request->plugin = plugin;
  auto result = request->result.get_future();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) throw std::runtime_error("the server is shutting down");
    spawns_.push_back(request);
  }
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_, &one, sizeof one);
  return result.get();
}

void PluginWorkers::run_spawn_requests() {
  std::vector<std::shared_ptr<SpawnRequest>> requests;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    requests.swap(spawns_);
  }
  for (const auto& request : requests) {
    try {
      request->result.set_value(start_worker(request->plugin));
    } catch (...) {
      request->result.set_exception(std::current_exception());
    }
  }
}

uint64_t PluginWorkers::create_instance(const std::shared_ptr<const PluginDescription>& plugin,
                                        std::weak_ptr<InstanceOwner> owner) {
  const size_t capacity = settings_.sessions_per_worker_of(plugin->name);
  std::shared_ptr<Worker> chosen;
  {
    // The slot is taken in the same step as it is found (a worker's count never lags behind the
    // sessions that chose it); a new worker comes with its first slot taken, and a worker being
    // started counts against the automatic cap from the moment it is decided.
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) throw std::runtime_error("the server is shutting down");
    size_t open_workers = spawning_[plugin->name];
    std::shared_ptr<Worker> least_loaded;
    size_t least_instances = 0;
    for (const auto& [_, w] : workers_) {
      std::lock_guard<std::mutex> worker_lock(w->mutex);
      if (w->plugin != plugin->name || w->closed) continue;
      ++open_workers;
      if (capacity != WorkerSettings::kAuto && w->instances < capacity) {
        ++w->instances;
        chosen = w;
        break;
      }
      if (capacity == WorkerSettings::kAuto && (!least_loaded || w->instances < least_instances)) {
        least_loaded = w;
        least_instances = w->instances;
      }
    }
    if (least_loaded && open_workers >= settings_.auto_worker_cap()) {
      std::lock_guard<std::mutex> worker_lock(least_loaded->mutex);
      if (!least_loaded->closed) {
        ++least_loaded->instances;
        chosen = least_loaded;
      }
    }
    if (!chosen) ++spawning_[plugin->name];
  }
  if (!chosen) {
    struct Spawned {
      PluginWorkers& self;
      const std::string& plugin;
      ~Spawned() {
        std::lock_guard<std::mutex> lock(self.mutex_);
        --self.spawning_[plugin];
      }
    } spawned{*this, plugin->name};
    chosen = start_worker_on_io_thread(plugin);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (!workers_.count(chosen->key)) {
    // Reaped meanwhile: its loss was told to the instances it had, which did not include this one.
    throw std::runtime_error("its worker (pid " + std::to_string(chosen->pid) + ") ended as the session was placed on it");
  }
  const uint64_t instance = next_instance_++;
  instances_[instance] = {chosen, std::move(owner)};
  return instance;
}

bool PluginWorkers::configure(uint64_t instance, const worker::ConfigureRequest& request, std::string what) {
  std::string frame;
  worker::append_configure(frame, instance, request);
  return send(instance, worker::Op::kConfigure, std::move(frame), std::move(what));
}

bool PluginWorkers::set_pose(uint64_t instance, const PoseEstimate& pose, std::string what) {
  std::string frame;
  worker::append_set_pose(frame, instance, pose);
  return send(instance, worker::Op::kSetPose, std::move(frame), std::move(what));
}

bool PluginWorkers::update(uint64_t instance, const Measurement& measurement, std::string what) {
  std::string frame;
  worker::append_update(frame, instance, measurement);
  return send(instance, worker::Op::kUpdate, std::move(frame), std::move(what));
}

bool PluginWorkers::save_map(uint64_t instance, std::string what) {
  std::string frame;
  worker::append_request(frame, instance, worker::Op::kSaveMap);
  return send(instance, worker::Op::kSaveMap, std::move(frame), std::move(what));
}

bool PluginWorkers::send(uint64_t instance, worker::Op op, std::string frame, std::string what) {
  std::shared_ptr<Worker> w;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = instances_.find(instance);
    if (stopping_ || it == instances_.end()) return false;
    w = it->second.worker;
  }
  std::lock_guard<std::mutex> lock(w->mutex);
  return queue_locked(*w, instance, op, std::move(frame), std::move(what));
}

bool PluginWorkers::queue_locked(Worker& w, uint64_t instance, worker::Op op, std::string frame, std::string what) {
  if (w.closed) return false;
  if (w.in_flight.empty()) w.front_since = Clock::now();
  w.in_flight.push_back({instance, op, std::move(what), settings_.deadline_s(w.plugin, op)});
  if (w.outbox_sent == w.outbox.size()) {
    w.outbox.clear();
    w.outbox_sent = 0;
  }
  if (w.outbox.empty()) {
    w.outbox = std::move(frame);
  } else {
    w.outbox.append(frame);
  }
  // Write what the socket takes now; the I/O thread writes the rest when it can.
  write_some_locked(w);
  if (w.outbox_sent < w.outbox.size() && !w.writing) {
    epoll_event event{};
    event.events = EPOLLIN | EPOLLRDHUP | EPOLLOUT;
    event.data.u64 = w.key * kEventKinds + kChannelEvent;
    epoll_ctl(epoll_, EPOLL_CTL_MOD, w.fd, &event);
    w.writing = true;
  }
  return true;
}

void PluginWorkers::write_some_locked(Worker& w) {
  while (w.outbox_sent < w.outbox.size()) {
    const ssize_t n = ::send(w.fd, w.outbox.data() + w.outbox_sent, w.outbox.size() - w.outbox_sent, MSG_NOSIGNAL);
    if (n > 0) {
      w.outbox_sent += static_cast<size_t>(n);
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else {
      break;  // EAGAIN: later; EPIPE: the worker is ending, its reaping reports it
    }
  }
}

void PluginWorkers::release(uint64_t instance) {
  std::shared_ptr<Worker> w;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = instances_.find(instance);
    if (it == instances_.end()) return;
    w = it->second.worker;
    instances_.erase(it);
  }
  std::lock_guard<std::mutex> lock(w->mutex);
  --w->instances;
  if (w->instances == 0 && !w->closed) {
    // Its last instance: the worker ends (it reads the end of its channel and exits).
    w->closed = true;
    w->retired = true;
    ::shutdown(w->fd, SHUT_WR);
    return;
  }
  std::string frame;
  worker::append_request(frame, instance, worker::Op::kRelease);
  queue_locked(*w, instance, worker::Op::kRelease, std::move(frame), "release of an instance");
}

void PluginWorkers::after(std::chrono::steady_clock::duration delay, std::function<void()> task) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return;
    timers_.push_back({Clock::now() + delay, std::move(task)});
  }
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_, &one, sizeof one);
}

void PluginWorkers::flush(const std::shared_ptr<Worker>& w) {
  std::lock_guard<std::mutex> lock(w->mutex);
  write_some_locked(*w);
  if (w->outbox_sent == w->outbox.size() && w->writing) {
    w->outbox.clear();
    w->outbox_sent = 0;
    epoll_event event{};
    event.events = EPOLLIN | EPOLLRDHUP;
    event.data.u64 = w->key * kEventKinds + kChannelEvent;
    epoll_ctl(epoll_, EPOLL_CTL_MOD, w->fd, &event);
    w->writing = false;
  }
}

std::shared_ptr<InstanceOwner> PluginWorkers::owner_of(uint64_t instance) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (stopping_) return nullptr;
  auto it = instances_.find(instance);
  return it == instances_.end() ? nullptr : it->second.owner.lock();
}

void PluginWorkers::read_from(const std::shared_ptr<Worker>& w) {
  char chunk[kReadChunk];
  bool ended = false;
  for (;;) {
    const ssize_t n = ::read(w->fd, chunk, sizeof chunk);
    if (n > 0) {
      w->inbox.append(chunk, static_cast<size_t>(n));
      if (static_cast<size_t>(n) < sizeof chunk) break;
    } else if (n == 0) {
      ended = true;
      break;
    } else if (errno == EINTR) {
      continue;
    } else {
      if (errno != EAGAIN && errno != EWOULDBLOCK) ended = true;
      break;
    }
  }
  size_t offset = 0;
  try {
    while (w->inbox.size() - offset >= worker::kFrameHeaderBytes) {
      const worker::FrameHeader header = worker::parse_header(w->inbox.data() + offset, max_payload_);
      if (w->inbox.size() - offset - worker::kFrameHeaderBytes < header.length) break;
      const std::string_view payload(w->inbox.data() + offset + worker::kFrameHeaderBytes, header.length);
      offset += worker::kFrameHeaderBytes + header.length;
      if (header.op == static_cast<uint32_t>(worker::Op::kLog)) {
        const worker::LogLine line = worker::decode_log(payload);
        if (auto owner = owner_of(header.instance)) owner->on_log(header.instance, line);
        continue;
      }
      if (header.op != static_cast<uint32_t>(worker::Op::kReply)) {
        throw worker::ProtocolError(std::string("the worker sent a request op (") +
                                    worker::op_name(static_cast<worker::Op>(header.op)) + ")");
      }
      worker::Reply reply = worker::decode_reply(payload, limits_);
      {
        std::lock_guard<std::mutex> lock(w->mutex);
        if (w->in_flight.empty() || w->in_flight.front().instance != header.instance ||
            w->in_flight.front().op != reply.request) {
          throw worker::ProtocolError("a reply that answers no request (instance " + std::to_string(header.instance) +
                                      ", " + worker::op_name(reply.request) + ")");
        }
        w->in_flight.pop_front();
        w->front_since = Clock::now();
      }
      if (reply.request == worker::Op::kRelease) continue;
      if (auto owner = owner_of(header.instance)) owner->on_reply(header.instance, std::move(reply));
    }
  } catch (const worker::ProtocolError& e) {
    w->inbox.clear();
    kill(w, std::string("broke the worker protocol (") + e.what() + ")");
    return;
  }
  w->inbox.erase(0, offset);
  if (ended) {
    // The worker closed its end: it is ending; its pidfd reports when.
    epoll_ctl(epoll_, EPOLL_CTL_DEL, w->fd, nullptr);
    std::lock_guard<std::mutex> lock(w->mutex);
    w->closed = true;
  }
}

void PluginWorkers::kill(const std::shared_ptr<Worker>& w, const std::string& reason) {
  std::lock_guard<std::mutex> lock(w->mutex);
  if (w->kill_reason.empty()) w->kill_reason = reason;
  w->closed = true;
  pidfd_send_signal(w->pidfd, SIGKILL);
  // Its group too. Safe by pid: the worker is not reaped yet, so its pid (the group's id) is
  // not free for reuse.
  ::kill(-w->pid, SIGKILL);
}

void PluginWorkers::reap(const std::shared_ptr<Worker>& w) {
  siginfo_t info{};
  if (waitid(static_cast<idtype_t>(P_PIDFD), static_cast<id_t>(w->pidfd), &info, WEXITED | WNOHANG | WNOWAIT) != 0 ||
      info.si_pid == 0) {
    return;  // not ended yet
  }
  // Ended, not reaped yet: what the plugin started goes with it (the group's id stays reserved
  // until the worker is reaped, below).
  ::kill(-w->pid, SIGKILL);
  info = {};
  waitid(static_cast<idtype_t>(P_PIDFD), static_cast<id_t>(w->pidfd), &info, WEXITED | WNOHANG);
  std::deque<Worker::Request> in_flight;
  std::string kill_reason;
  bool retired = false;
  bool deadline_missed = false;
  {
    std::lock_guard<std::mutex> lock(w->mutex);
    w->closed = true;
    in_flight.swap(w->in_flight);
    kill_reason = w->kill_reason;
    retired = w->retired;
    deadline_missed = w->deadline_missed;
  }
  epoll_ctl(epoll_, EPOLL_CTL_DEL, w->fd, nullptr);
  epoll_ctl(epoll_, EPOLL_CTL_DEL, w->pidfd, nullptr);
  epoll_ctl(epoll_, EPOLL_CTL_DEL, w->liveness_fd, nullptr);
  read_stderr(w);  // what it wrote last (its own dying words; what its children write later is lost)
  epoll_ctl(epoll_, EPOLL_CTL_DEL, w->stderr_fd, nullptr);
  w->stderr_lines->finish();
  close(w->fd);
  close(w->pidfd);
  close(w->liveness_fd);
  close(w->stderr_fd);

  std::vector<std::pair<uint64_t, std::weak_ptr<InstanceOwner>>> lost;
  bool stopping = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    workers_.erase(w->key);
    for (auto it = instances_.begin(); it != instances_.end();) {
      if (it->second.worker == w) {
        lost.emplace_back(it->first, it->second.owner);
        it = instances_.erase(it);
      } else {
        ++it;
      }
    }
    stopping = stopping_;
  }
  if (stopping) return;
  if (retired && lost.empty()) {
    logger_.log(LogLevel::kDebug, "server", "worker pid " + std::to_string(w->pid) + " of plugin " + w->plugin + " retired");
    return;
  }

  std::string cause;
  if (!kill_reason.empty()) {
    cause = kill_reason + ", and was killed";
  } else if (info.si_code == CLD_EXITED) {
    switch (info.si_status) {
      case worker::kExitOutOfMemory:
        cause = "ran out of memory (memory_limit_mb = " + std::to_string(settings_.memory_limit_mb) + ")";
        break;
      case worker::kExitCannotStart: cause = "could not start (the server log says why)"; break;
      case worker::kExitChannelLost: cause = "broke its channel to the server"; break;
      default: cause = "exited with code " + std::to_string(info.si_status);
    }
  } else {
    cause = "was killed by " + signal_description(info.si_status);
  }
  // A worker killed for a missed deadline names the request in its reason already.
  const std::string where = deadline_missed ? "" : in_flight.empty() ? " while idle" : " while handling the " + in_flight.front().what;
  const std::string description =
      "plugin '" + w->plugin + "' (worker pid " + std::to_string(w->pid) + ") " + cause + where;
  logger_.log(LogLevel::kError, "server", description);

  const bool idle = in_flight.empty();
  for (const auto& [instance, weak_owner] : lost) {
    const bool blamed = idle || in_flight.front().instance == instance;
    WorkerLoss loss;
    loss.blamed = blamed;
    loss.description = blamed ? description : description + " (another session's request; this one restarts)";
    if (auto owner = weak_owner.lock()) owner->on_lost(instance, loss);
  }
}

void PluginWorkers::check_deadlines() {
  std::vector<std::shared_ptr<Worker>> workers;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [_, w] : workers_) workers.push_back(w);
  }
  const auto now = Clock::now();
  for (const auto& w : workers) {
    std::string reason;
    {
      std::lock_guard<std::mutex> lock(w->mutex);
      if (w->closed || w->in_flight.empty()) continue;
      const auto& front = w->in_flight.front();
      if (now - w->front_since < std::chrono::duration<double>(front.deadline_s)) continue;
      reason = "did not answer the " + front.what + " within " + seconds(front.deadline_s) + " (" +
               (front.op == worker::Op::kConfigure ? "configure_deadline_s" : "update_deadline_s") + ")";
      w->deadline_missed = true;
    }
    kill(w, reason);
  }
}

void PluginWorkers::check_liveness() {
  if (settings_.liveness_timeout_s <= 0.0) return;
  const auto now = Clock::now();
  // This thread itself late (locd stopped, or starved): the workers' silence meanwhile says
  // nothing of them; they are pinged afresh.
  const bool thread_was_late = last_liveness_check_ != Clock::time_point{} && now - last_liveness_check_ > kPingPeriod;
  last_liveness_check_ = now;
  std::vector<std::shared_ptr<Worker>> workers;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [_, w] : workers_) workers.push_back(w);
  }
  const auto timeout = std::chrono::duration<double>(settings_.liveness_timeout_s);
  for (const auto& w : workers) {
    {
      std::lock_guard<std::mutex> lock(w->mutex);
      if (w->closed) continue;
    }
    if (!w->pinging) continue;
    if (thread_was_late) {
      w->ping_outstanding = false;
      w->next_ping = now;
    }
    if (w->ping_outstanding) {
      if (now - w->ping_sent < timeout) continue;
      kill(w, "did not answer its liveness ping within " + seconds(settings_.liveness_timeout_s) +
                  " (liveness_timeout_s; " + process_state(w->pid) + ")");
      continue;
    }
    if (now < w->next_ping) continue;
    const char ping = 'p';
    if (::send(w->liveness_fd, &ping, 1, MSG_NOSIGNAL | MSG_DONTWAIT) == 1) {
      w->ping_outstanding = true;
      w->ping_sent = now;
      w->next_ping = now + kPingPeriod;
    }
  }
}

void PluginWorkers::read_liveness(const std::shared_ptr<Worker>& w) {
  char answers[64];
  for (;;) {
    const ssize_t n = ::recv(w->liveness_fd, answers, sizeof answers, MSG_DONTWAIT);
    if (n > 0) {
      if (!w->pinging) {
        // Its first byte: the ping thread runs (the worker has started); pinging begins.
        w->pinging = true;
        w->next_ping = Clock::now() + kPingPeriod;
      }
      w->ping_outstanding = false;
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n == 0) epoll_ctl(epoll_, EPOLL_CTL_DEL, w->liveness_fd, nullptr);  // ending; the pidfd tells when
    return;
  }
}

void PluginWorkers::read_stderr(const std::shared_ptr<Worker>& w) {
  // At most a few chunks per wake-up: a worker that floods its stderr cannot hold the I/O thread
  // (the pipe fills and the worker blocks on its own writes).
  char chunk[4096];
  for (int reads = 0; reads < 4; ++reads) {
    const ssize_t n = ::read(w->stderr_fd, chunk, sizeof chunk);
    if (n > 0) {
      w->stderr_lines->append(chunk, static_cast<size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n == 0) epoll_ctl(epoll_, EPOLL_CTL_DEL, w->stderr_fd, nullptr);  // closed: the worker and its children are gone
    return;
  }
}

void PluginWorkers::run_due_timers() {
  std::vector<std::function<void()>> due;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto now = Clock::now();
    auto first_later = std::partition(timers_.begin(), timers_.end(), [&](const Timer& t) { return t.due <= now; });
    for (auto it = timers_.begin(); it != first_later; ++it) due.push_back(std::move(it->task));
    timers_.erase(timers_.begin(), first_later);
  }
  for (auto& task : due) task();
}

int PluginWorkers::next_wait_ms() const {
  std::lock_guard<std::mutex> lock(mutex_);
  int wait = kTickMs;
  const auto now = Clock::now();
  for (const auto& t : timers_) {
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(t.due - now).count();
    wait = static_cast<int>(std::clamp<long long>(ms, 0, wait));
  }
  return wait;
}

std::shared_ptr<PluginWorkers::Worker> PluginWorkers::worker_by_key(uint64_t key) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = workers_.find(key);
  return it == workers_.end() ? nullptr : it->second;
}

void PluginWorkers::run() {
  epoll_event events[64];
  Clock::time_point last_check{};
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stopped_) return;
    }
    const int n = epoll_wait(epoll_, events, 64, next_wait_ms());
    for (int i = 0; i < n; ++i) {
      const uint64_t key = events[i].data.u64;
      if (key == 0) {
        uint64_t count = 0;
        [[maybe_unused]] const ssize_t r = ::read(wake_, &count, sizeof count);
        continue;
      }
      auto w = worker_by_key(key / kEventKinds);
      if (!w) continue;
      if (key % kEventKinds == kExitEvent) {
        reap(w);
        continue;
      }
      if (key % kEventKinds == kLivenessEvent) {
        read_liveness(w);
        continue;
      }
      if (key % kEventKinds == kStderrEvent) {
        read_stderr(w);
        continue;
      }
      if (events[i].events & EPOLLOUT) flush(w);
      if (events[i].events & (EPOLLIN | EPOLLRDHUP | EPOLLHUP | EPOLLERR)) read_from(w);
    }
    run_spawn_requests();
    // Deadlines and timers at most every kCheckEveryMs: under load the loop wakes thousands of
    // times a second, and a deadline is seconds long.
    const auto now = Clock::now();
    if (now - last_check >= std::chrono::milliseconds(kCheckEveryMs)) {
      last_check = now;
      check_deadlines();
      check_liveness();
      run_due_timers();
    }
  }
}

void PluginWorkers::shutdown(std::chrono::milliseconds grace) {
  std::vector<std::shared_ptr<Worker>> workers;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopped_) return;
    stopping_ = true;
    timers_.clear();
    for (const auto& [_, w] : workers_) workers.push_back(w);
  }
  // A worker reads the end of its channel and exits; a hung one is killed after the grace.
  for (const auto& w : workers) {
    std::lock_guard<std::mutex> lock(w->mutex);
    w->closed = true;
    ::shutdown(w->fd, SHUT_WR);
  }
  auto wait_until_reaped = [&](Clock::time_point deadline) {
    while (Clock::now() < deadline) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (workers_.empty()) return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return false;
  };
  if (!wait_until_reaped(Clock::now() + grace)) {
    std::vector<std::shared_ptr<Worker>> remaining;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (const auto& [_, w] : workers_) remaining.push_back(w);
    }
    for (const auto& w : remaining) {
      logger_.log(LogLevel::kWarning, "server",
                  "worker pid " + std::to_string(w->pid) + " of plugin " + w->plugin +
                      " did not exit within the shutdown grace; killed");
      kill(w, "did not exit at shutdown");
    }
    wait_until_reaped(Clock::now() + kReapAfterKill);
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopped_ = true;
  }
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_, &one, sizeof one);
  if (io_.joinable()) io_.join();
  for (const auto& request : spawns_) {
    request->result.set_exception(std::make_exception_ptr(std::runtime_error("the server is shutting down")));
  }
  spawns_.clear();
}

pid_t PluginWorkers::pid_of(uint64_t instance) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = instances_.find(instance);
  return it == instances_.end() ? 0 : it->second.worker->pid;
}

size_t PluginWorkers::worker_count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return workers_.size();
}

}  // namespace locd::server
