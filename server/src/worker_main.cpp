// locd-worker: runs the instances of one plugin for locd, in a process of their own, so that a
// plugin that crashes, exits, hangs or exhausts its memory costs only the sessions in this
// process (locd restarts them from their last pose). Started by locd only:
//
//   locd-worker --plugin FILE --channel-fd 3 --liveness-fd 4 --parent PID --memory-limit-mb N
//               --limits B,P,I,D,PA,M --sandbox on|off [--read DIR]... [--write DIR]
//   locd-worker --inspect FILE --memory-limit-mb N --sandbox on|off [--read DIR]...
//
// Before it loads the plugin (whose static constructors run then) it confines itself
// (worker_sandbox.hpp): --read names the directories it may read besides the system's (plugins,
// maps), --write the one it may write (the output directory). --inspect loads the plugin, prints
// its descriptor (plugin_index.hpp) on stdout and exits: locd learns its catalog so, without
// mapping any plugin code itself.
//
// It reads requests from the channel (worker_protocol.hpp), one at a time, and answers each
// before reading the next; a thread of its own answers locd's liveness pings. It runs in a
// process group of its own (locd starts it so), and ends when locd closes the channel, and
// with locd: then everything in its group (what the plugin forked) is killed too.
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <new>
#include <string>
#include <vector>

#include "locd/sdk/plugin_loader.hpp"
#include "locd/sdk/text.hpp"
#include "locd/server/worker_protocol.hpp"
#include "locd/server/worker_sandbox.hpp"

namespace {

using namespace locd;
using namespace locd::server::worker;
using locd::server::confine_worker;
using locd::server::WorkerConfinement;

struct Arguments {
  std::string plugin_file;
  bool inspect = false;
  bool sandbox = true;
  std::vector<std::filesystem::path> readable;
  std::filesystem::path writable;
  int channel = -1;
  int liveness = -1;
  pid_t parent = 0;
  long memory_limit_mb = 0;
  Limits limits;
};

[[noreturn]] void die(int code, const std::string& why) {
  std::fprintf(stderr, "locd-worker[%d]: %s\n", static_cast<int>(getpid()), why.c_str());
  _exit(code);
}

size_t parse_size(const std::string& text, const char* what) {
  char* end = nullptr;
  errno = 0;
  const unsigned long long value = std::strtoull(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno != 0) die(kExitCannotStart, std::string("bad ") + what + " '" + text + "'");
  return static_cast<size_t>(value);
}

Limits parse_limits(const std::string& text) {
  std::vector<size_t> values;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = text.find(',', start);
    const size_t end = comma == std::string::npos ? text.size() : comma;
    values.push_back(parse_size(text.substr(start, end - start), "limit"));
    start = end + 1;
  }
  if (values.size() != 6) die(kExitCannotStart, "--limits needs 6 numbers");
  Limits l;
  l.max_scan_beams = values[0];
  l.max_cloud_points = values[1];
  l.max_image_pixels = values[2];
  l.max_detections = values[3];
  l.max_particles = values[4];
  l.max_map_cells = values[5];
  return l;
}

Arguments parse_arguments(int argc, char** argv) {
  Arguments a;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--plugin") a.plugin_file = value;
    else if (flag == "--inspect") a.plugin_file = value, a.inspect = true;
    else if (flag == "--sandbox" && (value == "on" || value == "off")) a.sandbox = value == "on";
    else if (flag == "--read") a.readable.emplace_back(value);
    else if (flag == "--write") a.writable = value;
    else if (flag == "--channel-fd") a.channel = static_cast<int>(parse_size(value, "channel fd"));
    else if (flag == "--liveness-fd") a.liveness = static_cast<int>(parse_size(value, "liveness fd"));
    else if (flag == "--parent") a.parent = static_cast<pid_t>(parse_size(value, "parent pid"));
    else if (flag == "--memory-limit-mb") a.memory_limit_mb = static_cast<long>(parse_size(value, "memory limit"));
    else if (flag == "--limits") a.limits = parse_limits(value);
    else die(kExitCannotStart, "unknown option " + flag + " (locd-worker is started by locd)");
  }
  if (a.inspect && !a.plugin_file.empty()) return a;
  if (a.plugin_file.empty() || a.channel < 0 || a.parent <= 0) {
    die(kExitCannotStart, "needs --plugin, --channel-fd and --parent (locd-worker is started by locd)");
  }
  return a;
}

// Sent by the kernel when locd dies (PR_SET_PDEATHSIG). Caught, unlike SIGKILL, so that the
// whole process group goes, this worker with it: the plugin's children do not inherit the
// parent-death signal.
const int kParentDeathSignal = SIGRTMIN;

void on_parent_death(int) {
  ::kill(0, SIGKILL);
  _exit(kExitChannelLost);
}

// The process's own limits: it dies with locd (its process group with it), it is the kernel's
// first choice when memory runs out, it writes no core files, and its address space is bounded.
void confine(const Arguments& a) {
  // kill(0) must reach this worker's own group only, never locd's.
  if (getpgrp() != getpid()) die(kExitCannotStart, "not the leader of a process group of its own (locd starts it so)");
  struct sigaction death {};
  death.sa_handler = on_parent_death;
  sigemptyset(&death.sa_mask);
  sigaction(kParentDeathSignal, &death, nullptr);
  if (a.parent > 0) {
    prctl(PR_SET_PDEATHSIG, kParentDeathSignal);
    if (getppid() != a.parent) _exit(0);  // locd died before the line above took effect
  }
  std::ofstream("/proc/self/oom_score_adj") << "1000\n";
  const rlimit no_core{0, 0};
  setrlimit(RLIMIT_CORE, &no_core);
  if (a.memory_limit_mb > 0) {
    const rlim_t bytes = static_cast<rlim_t>(a.memory_limit_mb) << 20;
    const rlimit address_space{bytes, bytes};
    if (setrlimit(RLIMIT_AS, &address_space) != 0) die(kExitCannotStart, std::string("setrlimit: ") + std::strerror(errno));
  }
  signal(SIGPIPE, SIG_IGN);
  if (!a.sandbox) return;
  WorkerConfinement confinement;
  confinement.readable = a.readable;
  confinement.readable.push_back(std::filesystem::path(a.plugin_file).parent_path());
  confinement.writable = a.writable;
  try {
    for (const auto& notice : confine_worker(confinement)) {
      std::fprintf(stderr, "locd-worker[%d]: %s\n", static_cast<int>(getpid()), notice.c_str());
    }
  } catch (const std::exception& e) {
    die(kExitCannotStart, std::string("cannot confine the worker: ") + e.what());
  }
}

// --inspect: the plugin's descriptor on the stdout locd reads (plugin_index.hpp); the plugin's
// own writes to fd 1 go to /dev/null. A refusal is one line "error TEXT".
int inspect(const Arguments& a) {
  const int out = dup(STDOUT_FILENO);
  const int null = open("/dev/null", O_WRONLY | O_CLOEXEC);
  if (out < 0 || null < 0 || dup2(null, STDOUT_FILENO) < 0) die(kExitCannotStart, "cannot set up stdout");
  close(null);
  FILE* report = fdopen(out, "w");
  if (!report) die(kExitCannotStart, "cannot set up stdout");
  try {
    const auto library = PluginLibrary::open(a.plugin_file);
    const auto& d = library->descriptor();
    std::fprintf(report, "locd-plugin-inspection 1\nname %s\nversion %s\ndescription %s\nconsumes %u\n",
                 escaped(d.name, 64).c_str(), escaped(d.version ? d.version : "", 64).c_str(),
                 escaped(d.description ? d.description : "", 512).c_str(), static_cast<unsigned>(d.consumes));
    std::fflush(report);
    _exit(0);  // no plugin destructor runs
  } catch (const std::exception& e) {
    std::fprintf(report, "error %s\n", escaped(e.what(), 1024).c_str());
    std::fflush(report);
    _exit(kExitCannotStart);
  }
}

// Answers locd's liveness pings (a byte each) from a thread of its own, so a plugin busy with a
// long request still answers, and a stopped or frozen process does not. It announces itself with
// one byte; it ends when locd closes the socket. No allocation here (a thread's first malloc
// reserves an arena of 64 MB of address space, counted against memory_limit_mb).
void* answer_pings(void* socket) {
  const int fd = static_cast<int>(reinterpret_cast<intptr_t>(socket));
  char bytes[64] = {'h'};
  ssize_t n = 1;
  for (;;) {
    for (ssize_t sent = 0; sent < n;) {
      const ssize_t w = ::write(fd, bytes + sent, static_cast<size_t>(n - sent));
      if (w > 0) sent += w;
      else if (errno != EINTR) return nullptr;
    }
    do {
      n = ::read(fd, bytes, sizeof bytes);
    } while (n < 0 && errno == EINTR);
    if (n <= 0) return nullptr;
  }
}

void start_answering_pings(int fd) {
  if (fd < 0) return;
  pthread_attr_t attributes;
  pthread_attr_init(&attributes);
  pthread_attr_setstacksize(&attributes, 64 * 1024);
  pthread_attr_setdetachstate(&attributes, PTHREAD_CREATE_DETACHED);
  // Signals are for the main thread (the parent-death signal included).
  sigset_t all, previous;
  sigfillset(&all);
  pthread_sigmask(SIG_SETMASK, &all, &previous);
  pthread_t thread;
  const int rc = pthread_create(&thread, &attributes, answer_pings, reinterpret_cast<void*>(static_cast<intptr_t>(fd)));
  pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  pthread_attr_destroy(&attributes);
  if (rc != 0) die(kExitCannotStart, std::string("cannot start the liveness thread: ") + std::strerror(rc));
}

class Channel {
 public:
  explicit Channel(int fd) : fd_(fd) {}

  // False when locd closed the channel. Reads ahead what the socket holds (usually the whole
  // next frame, often several), so a frame costs one read.
  bool read_exact(char* into, size_t bytes) {
    size_t done = 0;
    while (done < bytes) {
      if (begin_ == end_) {
        const ssize_t n = ::read(fd_, buffer_, sizeof buffer_);
        if (n > 0) {
          begin_ = 0;
          end_ = static_cast<size_t>(n);
        } else if (n == 0) {
          if (done == 0) return false;
          die(kExitChannelLost, "channel closed inside a frame");
        } else if (errno != EINTR) {
          die(kExitChannelLost, std::string("read: ") + std::strerror(errno));
        }
        continue;
      }
      const size_t take = std::min(bytes - done, end_ - begin_);
      std::memcpy(into + done, buffer_ + begin_, take);
      begin_ += take;
      done += take;
    }
    return true;
  }

  void write_all(const std::string& bytes) {
    size_t done = 0;
    while (done < bytes.size()) {
      const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
      if (n > 0) {
        done += static_cast<size_t>(n);
      } else if (n < 0 && errno != EINTR) {
        die(kExitChannelLost, std::string("write: ") + std::strerror(errno));
      }
    }
  }

 private:
  int fd_;
  char buffer_[64 * 1024];
  size_t begin_ = 0, end_ = 0;
};

// Refuses outputs beyond the limits here, as an error of the update, before they are encoded: the
// server would otherwise see an oversized frame and count it against the whole worker.
void check_outputs(const UpdateResult& result, const Limits& limits) {
  auto check = [](size_t count, size_t limit, const char* what, const char* key) {
    if (count > limit) {
      throw std::length_error("the plugin returned " + std::to_string(count) + " " + what + ", more than " + key +
                              " = " + std::to_string(limit));
    }
  };
  check(result.diagnostics.particles.size(), limits.max_particles, "particles", "max_particles");
  if (result.grid) check(result.grid->cells.size(), limits.max_map_cells, "grid cells", "max_map_cells");
  if (result.map_cloud) {
    check(result.map_cloud->points.size(), std::max(limits.max_cloud_points, limits.max_map_cells), "map points",
          "max_map_cells");
  }
}

class Worker {
 public:
  Worker(Arguments arguments, std::shared_ptr<PluginLibrary> library)
      : arguments_(std::move(arguments)), library_(std::move(library)), channel_(arguments_.channel),
        max_payload_(max_payload_bytes(arguments_.limits)) {}

  void run() {
    std::string payload;
    char header_bytes[kFrameHeaderBytes];
    while (channel_.read_exact(header_bytes, sizeof header_bytes)) {
      FrameHeader header;
      try {
        header = parse_header(header_bytes, max_payload_);
      } catch (const ProtocolError& e) {
        die(kExitChannelLost, e.what());
      }
      payload.resize(header.length);
      if (header.length > 0 && !channel_.read_exact(payload.data(), header.length)) {
        die(kExitChannelLost, "channel closed inside a frame");
      }
      Reply reply = handle(static_cast<Op>(header.op), header.instance, payload);
      out_.clear();
      append_reply(out_, header.instance, reply);
      channel_.write_all(out_);
    }
  }

 private:
  Reply handle(Op op, uint64_t instance, const std::string& payload) {
    Reply reply;
    reply.request = op;
    const auto start = std::chrono::steady_clock::now();
    try {
      switch (op) {
        case Op::kConfigure: reply.result = configure(instance, decode_configure(payload, arguments_.limits)); break;
        case Op::kSetPose: find(instance).set_pose(decode_set_pose(payload)); break;
        case Op::kUpdate:
          reply.result = find(instance).update(decode_update(payload, arguments_.limits));
          check_outputs(reply.result, arguments_.limits);
          break;
        case Op::kSaveMap: reply.message = find(instance).save_map(); break;
        case Op::kRelease: instances_.erase(instance); break;
        default: die(kExitChannelLost, std::string("unexpected request ") + op_name(op));
      }
    } catch (const ProtocolError& e) {
      die(kExitChannelLost, e.what());
    } catch (const std::bad_alloc&) {
      die(kExitOutOfMemory, "out of memory in plugin " + library_->name());
    } catch (const InputError& e) {
      reply = failed(op, Outcome::kInputError, e.what());
    } catch (const ConfigError& e) {
      reply = failed(op, Outcome::kConfigError, e.what());
    } catch (const std::exception& e) {
      reply = failed(op, Outcome::kPluginError, e.what());
    } catch (...) {
      reply = failed(op, Outcome::kPluginError, "a non-standard exception");
    }
    reply.compute_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return reply;
  }

  static Reply failed(Op op, Outcome outcome, const std::string& message) {
    Reply reply;
    reply.request = op;
    reply.outcome = outcome;
    reply.message = message;
    return reply;
  }

  UpdateResult configure(uint64_t instance, const ConfigureRequest& request) {
    PluginContext context;
    context.robot_id = request.robot_id;
    context.limits = request.limits;
    std::vector<std::filesystem::path> directories(request.map_directories.begin(), request.map_directories.end());
    context.maps = MapResolver(directories);
    context.output_directory = request.output_directory;
    context.log = [this, instance](LogLevel level, const std::string& text) {
      std::string frame;
      append_log(frame, instance, LogLine{level, text});
      channel_.write_all(frame);
    };
    const PluginConfig config = split_plugin_config(request.config);
    if (config.plugin != library_->name()) {
      throw ConfigError(request.config.source + ": plugin '" + config.plugin + "' sent to the worker of '" +
                        library_->name() + "'");
    }
    LocalizerPtr localizer = create_configured(*library_, context, config.params);
    UpdateResult initial = localizer->initial_outputs();
    check_outputs(initial, arguments_.limits);
    instances_[instance] = std::move(localizer);
    return initial;
  }

  Localizer& find(uint64_t instance) {
    auto it = instances_.find(instance);
    if (it == instances_.end()) throw ProtocolError("request for unknown instance " + std::to_string(instance));
    return *it->second;
  }

  Arguments arguments_;
  std::shared_ptr<PluginLibrary> library_;
  Channel channel_;
  uint64_t max_payload_;
  std::map<uint64_t, LocalizerPtr> instances_;
  std::string out_;
};

}  // namespace

int main(int argc, char** argv) {
  Arguments arguments = parse_arguments(argc, argv);
  confine(arguments);
  if (arguments.inspect) return inspect(arguments);
  start_answering_pings(arguments.liveness);
  std::shared_ptr<PluginLibrary> library;
  try {
    library = PluginLibrary::open(arguments.plugin_file);
  } catch (const std::exception& e) {
    die(kExitCannotStart, e.what());
  }
  Worker(std::move(arguments), std::move(library)).run();
  return 0;
}
