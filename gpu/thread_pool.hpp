// A persistent pool of CPU worker threads for the RANSAC backends: one task counter per job, the
// calling thread works too, idle workers spin briefly and then sleep on a condition variable.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace ovo::gpu {

class ThreadPool {
 public:
  /// The process-wide pool: hardware_concurrency() - 1 workers (the caller is the last thread).
  static ThreadPool& shared();

  explicit ThreadPool(int num_workers);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  /// Threads that run tasks: the workers plus the caller.
  int concurrency() const { return static_cast<int>(workers_.size()) + 1; }

  /// Runs fn(task) for every task in [0, num_tasks), each exactly once, on the workers and the
  /// calling thread, and returns when all are done. Which thread runs a task is unspecified, so
  /// a task's result must not depend on it. Concurrent callers are served one at a time.
  void run(int num_tasks, const std::function<void(int)>& fn);

  /// Sends idle workers to sleep now instead of after their spin: for a caller that is about to
  /// wait on other threads (an OpenCL device on the same cores). The next run() wakes them.
  void rest() { rest_.store(true, std::memory_order_relaxed); }

 private:
  struct Job {
    const std::function<void(int)>* fn = nullptr;
    int num_tasks = 0;
    std::atomic<int> next{0};
    std::atomic<int> done{0};
  };
  static void work(Job& job);
  void publish();  // bumps generation_ and wakes sleeping workers
  void workerLoop();

  std::vector<std::thread> workers_;
  std::mutex run_mutex_;  // one job at a time
  std::mutex job_mutex_;  // guards job_
  std::shared_ptr<Job> job_;
  std::mutex sleep_mutex_;
  std::condition_variable wake_;
  std::atomic<std::uint32_t> generation_{0};
  std::atomic<bool> stop_{false};
  std::atomic<bool> rest_{false};
};

/// Runs fn(begin, end) over at most 4 concurrency() contiguous sub-ranges covering [0, n) on the
/// shared pool.
void parallelForOnPool(int n, const std::function<void(int, int)>& fn);

}  // namespace ovo::gpu
