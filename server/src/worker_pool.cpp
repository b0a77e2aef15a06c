#include "locd/server/worker_pool.hpp"

#include <exception>
#include <stdexcept>

namespace locd::server {

WorkerPool::WorkerPool(size_t threads) {
  if (threads == 0) throw std::invalid_argument("WorkerPool needs at least one thread");
  threads_.reserve(threads);
  for (size_t i = 0; i < threads; ++i) threads_.emplace_back([this] { run(); });
}

WorkerPool::~WorkerPool() { shutdown(); }

bool WorkerPool::post(std::function<void()> task) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return false;
    tasks_.push_back(std::move(task));
  }
  wake_.notify_one();
  return true;
}

void WorkerPool::shutdown() {
  std::deque<std::function<void()>> discarded;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_ && threads_.empty()) return;
    stopping_ = true;
    discarded.swap(tasks_);
  }
  wake_.notify_all();
  for (auto& t : threads_) {
    if (t.joinable()) t.join();
  }
  threads_.clear();
  // `discarded` (and whatever its tasks own) goes away here, outside the lock.
}

void WorkerPool::run() {
  for (;;) {
    std::function<void()> task;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !tasks_.empty(); });
      if (stopping_) return;
      task = std::move(tasks_.front());
      tasks_.pop_front();
    }
    try {
      task();
    } catch (const std::exception& e) {
      if (error_handler_) error_handler_(e.what());
    } catch (...) {
      if (error_handler_) error_handler_("a task threw a non-standard exception");
    }
  }
}

}  // namespace locd::server
