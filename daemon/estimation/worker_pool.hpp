// A fixed pool of worker threads for the ensemble filter: run() splits [0, count) into one
// contiguous range per worker (the caller's thread is worker 0) and returns when all are done.
// Threads are created once; run() allocates nothing (the task is passed by reference and
// called through a function pointer, never wrapped in std::function). The task must not throw.
//
// Threads: run() from one owner thread at a time.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <mutex>
#include <thread>
#include <vector>

namespace hvac_twin::est {

class WorkerPool {
 public:
  explicit WorkerPool(std::size_t workers);  // >= 1; workers - 1 threads are started
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  [[nodiscard]] std::size_t size() const { return workers_; }

  // task(worker, begin, end) for each worker's share of [0, count).
  template <class Task>
  void run(std::size_t count, Task& task) {
    dispatch(count, &task, [](void* t, std::size_t w, std::size_t b, std::size_t e) {
      (*static_cast<Task*>(t))(w, b, e);
    });
  }

 private:
  using Call = void (*)(void*, std::size_t, std::size_t, std::size_t);
  void dispatch(std::size_t count, void* task, Call call);
  void loop(std::size_t worker);
  void range(std::size_t worker, std::size_t& begin, std::size_t& end) const;

  std::size_t workers_;
  std::vector<std::thread> threads_;
  std::mutex mutex_;
  std::condition_variable start_, done_;
  std::size_t generation_ = 0, pending_ = 0, count_ = 0;
  void* task_ = nullptr;
  Call call_ = nullptr;
  bool stop_ = false;
};

}  // namespace hvac_twin::est
