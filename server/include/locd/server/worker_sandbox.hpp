// The confinement a plugin worker (or inspector) puts itself under before it loads any plugin
// code, so that a plugin's static constructors run confined too:
//   - no new privileges (PR_SET_NO_NEW_PRIVS), and every capability dropped (a locd run as root);
//   - Landlock: files readable only under the system library directories, the plugin and map
//     directories given; writable only under the output directory; no signal to a process
//     outside the worker's own (ABI 6), no TCP (ABI 4). A kernel without Landlock: a notice, and
//     file access is not limited;
//   - a seccomp filter (libseccomp) that refuses with EPERM what a plugin never needs: creating
//     sockets or connecting them, ptrace and reading other processes' memory, running programs,
//     mounting, namespaces, kernel modules, BPF, keyrings, io_uring, changing user ids.
// Threads, memory, files opened through the rules above, fork, signals within the worker's own
// processes stay allowed: what Eigen, OpenCV, TBB and the allocators use.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace locd::server {

struct WorkerConfinement {
  std::vector<std::filesystem::path> readable;  // besides the system directories
  std::filesystem::path writable;               // empty: nowhere
};

// What confine_worker did not manage (e.g. "Landlock is not supported by this kernel ..."): the
// worker reports each on stderr, where locd logs it. Throws std::runtime_error when a step that
// must work (no_new_privs, seccomp) fails.
std::vector<std::string> confine_worker(const WorkerConfinement& confinement);

}  // namespace locd::server
