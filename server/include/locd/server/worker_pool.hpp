// N threads serving one FIFO task queue. Sessions put their drain tasks here; a task never
// blocks on another. shutdown() discards tasks not yet started and joins the threads.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace locd::server {

class WorkerPool {
 public:
  explicit WorkerPool(size_t threads);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // Queues a task; returns false (and drops it) once shutdown has begun. A task that throws
  // is caught and passed to the error handler so a worker never dies.
  bool post(std::function<void()> task);
  void shutdown();
  size_t size() const { return threads_.size(); }
  void on_task_error(std::function<void(const std::string&)> handler) { error_handler_ = std::move(handler); }

 private:
  void run();
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> tasks_;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
  std::function<void(const std::string&)> error_handler_;
};

}  // namespace locd::server
