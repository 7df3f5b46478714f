#include "daemon/estimation/worker_pool.hpp"

#include <algorithm>

namespace hvac_twin::est {

WorkerPool::WorkerPool(std::size_t workers) : workers_(std::max<std::size_t>(workers, 1)) {
  for (std::size_t w = 1; w < workers_; ++w)
    threads_.emplace_back([this, w] { loop(w); });
}

WorkerPool::~WorkerPool() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  start_.notify_all();
  for (auto& t : threads_)
    t.join();
}

void WorkerPool::range(std::size_t worker, std::size_t& begin, std::size_t& end) const {
  const std::size_t share = count_ / workers_, extra = count_ % workers_;
  begin = worker * share + std::min(worker, extra);
  end = begin + share + (worker < extra ? 1 : 0);
}

void WorkerPool::dispatch(std::size_t count, void* task, Call call) {
  {
    std::lock_guard lock(mutex_);
    count_ = count;
    task_ = task;
    call_ = call;
    pending_ = workers_ - 1;
    ++generation_;
  }
  start_.notify_all();
  std::size_t b = 0, e = 0;
  range(0, b, e);
  if (b < e) call(task, 0, b, e);
  std::unique_lock lock(mutex_);
  done_.wait(lock, [this] { return pending_ == 0; });
}

void WorkerPool::loop(std::size_t worker) {
  std::size_t seen = 0;
  for (;;) {
    std::size_t b = 0, e = 0;
    void* task = nullptr;
    Call call = nullptr;
    {
      std::unique_lock lock(mutex_);
      start_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
      range(worker, b, e);
      task = task_;
      call = call_;
    }
    if (b < e) call(task, worker, b, e);
    {
      std::lock_guard lock(mutex_);
      --pending_;
    }
    done_.notify_one();
  }
}

}  // namespace hvac_twin::est
