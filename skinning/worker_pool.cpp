#include "skinning/worker_pool.h"

#include <stdexcept>
#include <string>

namespace odyssey::skinning {

WorkerPool::WorkerPool(int threads) {
  if (threads < 1) throw std::invalid_argument("a worker pool needs at least 1 thread, got " + std::to_string(threads));
  workers_.reserve(static_cast<std::size_t>(threads - 1));
  for (int i = 1; i < threads; ++i) workers_.emplace_back([this] { work_loop(); });
}

WorkerPool::~WorkerPool() {
  {
    const std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  for (std::thread& worker : workers_) worker.join();
}

void WorkerPool::take_items(const std::function<void(std::size_t)>& body, std::size_t count) {
  for (std::size_t i = next_.fetch_add(1, std::memory_order_relaxed); i < count;
       i = next_.fetch_add(1, std::memory_order_relaxed)) {
    body(i);
  }
}

void WorkerPool::work_loop() {
  std::size_t seen = 0;
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return stopping_ || generation_ != seen; });
    if (stopping_) return;
    seen = generation_;
    const std::function<void(std::size_t)>& body = *body_;
    const std::size_t count = count_;
    lock.unlock();
    take_items(body, count);
    lock.lock();
    if (++workers_done_ == workers_.size()) finished_.notify_one();
  }
}

void WorkerPool::run(std::size_t count, const std::function<void(std::size_t)>& body) {
  if (workers_.empty() || count <= 1) {
    for (std::size_t i = 0; i < count; ++i) body(i);
    return;
  }
  {
    const std::lock_guard lock(mutex_);
    body_ = &body;
    count_ = count;
    next_.store(0, std::memory_order_relaxed);
    workers_done_ = 0;
    ++generation_;
  }
  wake_.notify_all();
  take_items(body, count);
  std::unique_lock lock(mutex_);
  finished_.wait(lock, [&] { return workers_done_ == workers_.size(); });
}

}  // namespace odyssey::skinning
