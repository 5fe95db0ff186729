#include "gpu/thread_pool.hpp"

#include <algorithm>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define OVO_CPU_RELAX() _mm_pause()
#else
#define OVO_CPU_RELAX() std::this_thread::yield()
#endif

namespace ovo::gpu {
namespace {

// Spin iterations (~30 ns each) before an idle worker sleeps / the caller starts yielding: a
// RANSAC call issues jobs back to back, but other processes share the cores.
constexpr int kSpinIterations = 2000;

}  // namespace

ThreadPool& ThreadPool::shared() {
  static ThreadPool pool(std::max(1, static_cast<int>(std::thread::hardware_concurrency())) - 1);
  return pool;
}

ThreadPool::ThreadPool(int num_workers) {
  for (int i = 0; i < num_workers; ++i) workers_.emplace_back([this] { workerLoop(); });
}

ThreadPool::~ThreadPool() {
  stop_.store(true);
  publish();
  for (auto& t : workers_) t.join();
}

void ThreadPool::publish() {
  {
    std::lock_guard lock(sleep_mutex_);  // a worker between its check and its sleep sees it
    generation_.fetch_add(1, std::memory_order_release);
  }
  wake_.notify_all();
}

void ThreadPool::work(Job& job) {
  for (;;) {
    const int task = job.next.fetch_add(1, std::memory_order_relaxed);
    if (task >= job.num_tasks) return;
    (*job.fn)(task);
    job.done.fetch_add(1, std::memory_order_release);
  }
}

void ThreadPool::workerLoop() {
  // The generation at construction: a worker that starts late still sees every later publish.
  std::uint32_t seen = 0;
  for (;;) {
    std::uint32_t now = generation_.load(std::memory_order_acquire);
    for (int i = 0; i < kSpinIterations && now == seen && !rest_.load(std::memory_order_relaxed);
         ++i) {
      OVO_CPU_RELAX();
      now = generation_.load(std::memory_order_acquire);
    }
    if (now == seen) {
      std::unique_lock lock(sleep_mutex_);
      wake_.wait(lock, [&] { return generation_.load(std::memory_order_acquire) != seen; });
      continue;
    }
    seen = now;
    if (stop_.load()) return;
    std::shared_ptr<Job> job;
    {
      std::lock_guard lock(job_mutex_);
      job = job_;
    }
    // A late worker may find a finished job: its counter is exhausted and fn is never called.
    if (job) work(*job);
  }
}

void ThreadPool::run(int num_tasks, const std::function<void(int)>& fn) {
  if (num_tasks <= 0) return;
  if (workers_.empty() || num_tasks == 1) {
    for (int t = 0; t < num_tasks; ++t) fn(t);
    return;
  }
  std::lock_guard run_lock(run_mutex_);
  auto job = std::make_shared<Job>();
  job->fn = &fn;
  job->num_tasks = num_tasks;
  {
    std::lock_guard lock(job_mutex_);
    job_ = job;
  }
  rest_.store(false, std::memory_order_relaxed);
  publish();
  work(*job);
  for (int i = 0; job->done.load(std::memory_order_acquire) < num_tasks; ++i) {
    if (i < kSpinIterations)
      OVO_CPU_RELAX();
    else
      std::this_thread::yield();
  }
  std::lock_guard lock(job_mutex_);
  job_.reset();
}

void parallelForOnPool(int n, const std::function<void(int, int)>& fn) {
  if (n <= 0) return;
  ThreadPool& pool = ThreadPool::shared();
  const int tasks = std::min(n, 4 * pool.concurrency());
  pool.run(tasks, [&](int t) {
    fn(static_cast<int>(static_cast<long>(n) * t / tasks),
       static_cast<int>(static_cast<long>(n) * (t + 1) / tasks));
  });
}

}  // namespace ovo::gpu
