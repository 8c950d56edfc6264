// A fixed team of threads for the skinning loops: run(count, body) calls body(i) once for every i
// in [0, count), spread over the calling thread and threads - 1 workers, and returns when all
// calls have finished. Items are handed out in increasing order from one atomic counter, so
// neighbouring items (the vertex blocks of one frame) tend to run close together in time; which
// thread runs an item never changes what the item computes.
//
// Waiting is on condition variables, never spinning: the machines this runs on are shared (batch
// jobs side by side), and a spinning thread steals the core that the thread it waits for needs.
// Waking a sleeping worker costs tens of microseconds, so callers share only work that is much
// longer than that (LinearBlendSkinner::kMinSharedVertexFrames).
//
// Ownership: the pool owns its workers for its whole life (started by the constructor, joined
// by the destructor); the body is borrowed for the duration of one run(). One run() at a time:
// the pool belongs to one caller (the skinner that created it). body must not throw.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace odyssey::skinning {

class WorkerPool {
 public:
  // threads >= 1 (std::invalid_argument otherwise); 1 runs everything on the caller.
  explicit WorkerPool(int threads);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  int threads() const { return static_cast<int>(workers_.size()) + 1; }
  void run(std::size_t count, const std::function<void(std::size_t)>& body);

 private:
  void work_loop();
  void take_items(const std::function<void(std::size_t)>& body, std::size_t count);

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, finished_;
  // The current run, guarded by mutex_ except the counter items are taken from. Every worker
  // takes part in every run (possibly finding no item left) and run() returns only after all of
  // them have reported back, so no worker can still be in a run when the next one resets next_.
  const std::function<void(std::size_t)>* body_ = nullptr;
  std::size_t count_ = 0;
  std::atomic<std::size_t> next_{0};
  std::size_t generation_ = 0;  // bumped by each run() so sleeping workers see new work
  std::size_t workers_done_ = 0;
  bool stopping_ = false;
};

}  // namespace odyssey::skinning
