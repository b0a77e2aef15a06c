#include "locd/server/worker_sandbox.hpp"

#include <fcntl.h>
#include <linux/capability.h>
#include <linux/landlock.h>
#include <sched.h>
#include <seccomp.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <stdexcept>

namespace locd::server {
namespace fs = std::filesystem;

namespace {

// Landlock rights newer than the kernel headers Debian 12 ships (ABI 3, 4, 6).
constexpr uint64_t kAccessFsTruncate = 1ull << 14;
constexpr uint64_t kAccessNetBindTcp = 1ull << 0;
constexpr uint64_t kAccessNetConnectTcp = 1ull << 1;
constexpr uint64_t kScopeAbstractUnixSocket = 1ull << 0;
constexpr uint64_t kScopeSignal = 1ull << 1;

// struct landlock_ruleset_attr as of ABI 6 (the kernel takes the size it is given).
struct RulesetAttributes {
  uint64_t handled_access_fs = 0;
  uint64_t handled_access_net = 0;
  uint64_t scoped = 0;
};

constexpr uint64_t kReadFile = LANDLOCK_ACCESS_FS_EXECUTE | LANDLOCK_ACCESS_FS_READ_FILE;
constexpr uint64_t kReadTree = kReadFile | LANDLOCK_ACCESS_FS_READ_DIR;
constexpr uint64_t kAccessFsV1 =
    LANDLOCK_ACCESS_FS_EXECUTE | LANDLOCK_ACCESS_FS_WRITE_FILE | LANDLOCK_ACCESS_FS_READ_FILE |
    LANDLOCK_ACCESS_FS_READ_DIR | LANDLOCK_ACCESS_FS_REMOVE_DIR | LANDLOCK_ACCESS_FS_REMOVE_FILE |
    LANDLOCK_ACCESS_FS_MAKE_CHAR | LANDLOCK_ACCESS_FS_MAKE_DIR | LANDLOCK_ACCESS_FS_MAKE_REG |
    LANDLOCK_ACCESS_FS_MAKE_SOCK | LANDLOCK_ACCESS_FS_MAKE_FIFO | LANDLOCK_ACCESS_FS_MAKE_BLOCK |
    LANDLOCK_ACCESS_FS_MAKE_SYM;

// System directories a plugin's libraries and their run-time lookups need (read only).
const char* const kSystemTrees[] = {"/usr", "/lib", "/lib64", "/proc", "/sys", "/etc/ld.so.conf.d"};
const char* const kSystemFiles[] = {"/etc/ld.so.cache", "/etc/localtime", "/dev/urandom", "/dev/zero"};

class FileDescriptor {
 public:
  explicit FileDescriptor(int fd) : fd_(fd) {}
  ~FileDescriptor() {
    if (fd_ >= 0) close(fd_);
  }
  int get() const { return fd_; }

 private:
  int fd_;
};

// Adds "beneath `path`, `access`" (`access` cut to what the ruleset handles; to file rights for a
// file). A path that does not exist is skipped.
void allow(int ruleset, const fs::path& path, uint64_t access, uint64_t handled) {
  const FileDescriptor fd(open(path.c_str(), O_PATH | O_CLOEXEC));
  if (fd.get() < 0) return;
  std::error_code ec;
  if (!fs::is_directory(path, ec)) {
    access &= LANDLOCK_ACCESS_FS_EXECUTE | LANDLOCK_ACCESS_FS_WRITE_FILE | LANDLOCK_ACCESS_FS_READ_FILE |
              kAccessFsTruncate;
  }
  landlock_path_beneath_attr rule{};
  rule.allowed_access = access & handled;
  rule.parent_fd = fd.get();
  if (syscall(SYS_landlock_add_rule, ruleset, LANDLOCK_RULE_PATH_BENEATH, &rule, 0) != 0) {
    throw std::runtime_error("landlock_add_rule(" + path.string() + "): " + std::strerror(errno));
  }
}

// Returns a notice when the kernel has no Landlock.
std::string restrict_files(const WorkerConfinement& confinement) {
  const long abi = syscall(SYS_landlock_create_ruleset, nullptr, 0, LANDLOCK_CREATE_RULESET_VERSION);
  if (abi < 1) {
    return std::string("notice: Landlock is not available (") + std::strerror(errno) +
           "): this worker's file access is not limited (the key files included); seccomp and the dropped "
           "privileges still hold";
  }
  RulesetAttributes attributes;
  attributes.handled_access_fs = kAccessFsV1;
  if (abi >= 2) attributes.handled_access_fs |= LANDLOCK_ACCESS_FS_REFER;
  if (abi >= 3) attributes.handled_access_fs |= kAccessFsTruncate;
  size_t size = sizeof(uint64_t);
  if (abi >= 4) {
    attributes.handled_access_net = kAccessNetBindTcp | kAccessNetConnectTcp;  // no rule: no TCP at all
    size = 2 * sizeof(uint64_t);
  }
  if (abi >= 6) {
    attributes.scoped = kScopeAbstractUnixSocket | kScopeSignal;  // signals only within the worker's own processes
    size = sizeof attributes;
  }
  const FileDescriptor ruleset(static_cast<int>(syscall(SYS_landlock_create_ruleset, &attributes, size, 0)));
  if (ruleset.get() < 0) throw std::runtime_error(std::string("landlock_create_ruleset: ") + std::strerror(errno));
  const uint64_t handled = attributes.handled_access_fs;
  for (const char* tree : kSystemTrees) allow(ruleset.get(), tree, kReadTree, handled);
  for (const char* file : kSystemFiles) allow(ruleset.get(), file, kReadFile, handled);
  allow(ruleset.get(), "/dev/null", LANDLOCK_ACCESS_FS_READ_FILE | LANDLOCK_ACCESS_FS_WRITE_FILE, handled);
  for (const auto& dir : confinement.readable) allow(ruleset.get(), dir, kReadTree, handled);
  if (!confinement.writable.empty()) allow(ruleset.get(), confinement.writable, handled & ~LANDLOCK_ACCESS_FS_EXECUTE, handled);
  if (syscall(SYS_landlock_restrict_self, ruleset.get(), 0) != 0) {
    throw std::runtime_error(std::string("landlock_restrict_self: ") + std::strerror(errno));
  }
  return "";
}

// Every capability gone (from the bounding set too), for a worker of a locd run as root.
void drop_capabilities() {
  for (int cap = 0; cap <= 63; ++cap) {
    if (prctl(PR_CAPBSET_READ, cap, 0, 0, 0) < 0) break;  // past the last capability
    prctl(PR_CAPBSET_DROP, cap, 0, 0, 0);                // EPERM without CAP_SETPCAP: nothing to drop then
  }
  prctl(PR_CAP_AMBIENT, PR_CAP_AMBIENT_CLEAR_ALL, 0, 0, 0);
  __user_cap_header_struct header{_LINUX_CAPABILITY_VERSION_3, 0};
  __user_cap_data_struct data[2] = {};
  if (syscall(SYS_capset, &header, data) != 0) {
    throw std::runtime_error(std::string("capset: ") + std::strerror(errno));
  }
}

void filter_system_calls() {
  scmp_filter_ctx filter = seccomp_init(SCMP_ACT_ALLOW);
  if (!filter) throw std::runtime_error("seccomp_init failed");
  struct Release {
    scmp_filter_ctx f;
    ~Release() { seccomp_release(f); }
  } release{filter};
  const uint32_t refuse = SCMP_ACT_ERRNO(EPERM);
  static const char* const kRefused[] = {
      // network and other processes
      "socket", "connect", "bind", "listen", "accept", "accept4", "ptrace", "process_vm_readv",
      "process_vm_writev", "pidfd_open", "pidfd_getfd", "pidfd_send_signal", "kcmp",
      // programs, privileges, the machine
      "execve", "execveat", "setuid", "setgid", "setreuid", "setregid", "setresuid", "setresgid", "setgroups",
      "setfsuid", "setfsgid", "capset", "mount", "umount2", "pivot_root", "chroot", "setns", "unshare",
      "move_mount", "open_tree", "fsopen", "fsmount", "fsconfig", "fspick", "mount_setattr", "kexec_load",
      "kexec_file_load", "init_module", "finit_module", "delete_module", "bpf", "perf_event_open", "keyctl",
      "add_key", "request_key", "userfaultfd", "io_uring_setup", "io_uring_enter", "io_uring_register",
      "open_by_handle_at", "name_to_handle_at", "reboot", "swapon", "swapoff", "acct", "quotactl", "mknod",
      "mknodat", "settimeofday", "clock_settime", "clock_adjtime", "adjtimex", "sethostname", "setdomainname",
      "iopl", "ioperm", "syslog", "fanotify_init", "landlock_create_ruleset", "landlock_add_rule",
      "landlock_restrict_self"};
  for (const char* name : kRefused) {
    const int number = seccomp_syscall_resolve_name(name);
    if (number == __NR_SCMP_ERROR) continue;  // not on this architecture
    if (seccomp_rule_add(filter, refuse, number, 0) != 0) {
      throw std::runtime_error(std::string("seccomp_rule_add(") + name + ") failed");
    }
  }
  // clone3 passes its flags in memory, where a filter cannot look: ENOSYS makes glibc use clone,
  // whose namespace flags are refused.
  seccomp_rule_add(filter, SCMP_ACT_ERRNO(ENOSYS), SCMP_SYS(clone3), 0);
  for (uint64_t flag : {static_cast<uint64_t>(CLONE_NEWNS), static_cast<uint64_t>(CLONE_NEWUSER),
                        static_cast<uint64_t>(CLONE_NEWPID), static_cast<uint64_t>(CLONE_NEWNET),
                        static_cast<uint64_t>(CLONE_NEWIPC), static_cast<uint64_t>(CLONE_NEWUTS),
                        static_cast<uint64_t>(CLONE_NEWCGROUP)}) {
    if (seccomp_rule_add(filter, refuse, SCMP_SYS(clone), 1, SCMP_A0(SCMP_CMP_MASKED_EQ, flag, flag)) != 0) {
      throw std::runtime_error("seccomp_rule_add(clone) failed");
    }
  }
  const int rc = seccomp_load(filter);
  if (rc != 0) throw std::runtime_error(std::string("seccomp_load: ") + std::strerror(-rc));
}

}  // namespace

std::vector<std::string> confine_worker(const WorkerConfinement& confinement) {
  std::vector<std::string> notices;
  if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0) {
    throw std::runtime_error(std::string("PR_SET_NO_NEW_PRIVS: ") + std::strerror(errno));
  }
  drop_capabilities();
  const std::string landlock = restrict_files(confinement);
  if (!landlock.empty()) notices.push_back(landlock);
  filter_system_calls();
  return notices;
}

}  // namespace locd::server
