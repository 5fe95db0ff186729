#include "gpu/scoring.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <mutex>

#include "common/error.hpp"
#include "gpu/opencl_context.hpp"
#include "gpu/thread_pool.hpp"

namespace ovo::gpu {

float inlierConstant(double threshold_rad) {
  const double thr2 = threshold_rad * threshold_rad;
  return static_cast<float>(thr2 / (1.0 + 2.0 * thr2));
}

void ScoringBackend::parallelFor(int n, const std::function<void(int, int)>& fn) {
  if (n > 0) fn(0, n);
}

void ScoringBackend::generateAndScore(int num_hypotheses, const Generator& generate,
                                      float* E_rowmajor, float k, int* inlier_counts) {
  if (num_hypotheses <= 0) return;
  generate(0, num_hypotheses);
  score(E_rowmajor, num_hypotheses, k, inlier_counts);
}

void hostParallelFor(int n, const std::function<void(int, int)>& fn) {
  if (n <= 0) return;
  ThreadPool& pool = ThreadPool::shared();
  const int tasks = std::min(n, 4 * pool.concurrency());
  pool.run(tasks, [&](int t) {
    fn(static_cast<int>(static_cast<long>(n) * t / tasks),
       static_cast<int>(static_cast<long>(n) * (t + 1) / tasks));
  });
}

namespace {

// Hypotheses per pool task of the threads backend: generated and scored while in L1.
constexpr int kThreadsChunk = 64;

/// One thread: the CPU kernel over all hypotheses.
class SerialBackend final : public ScoringBackend {
 public:
  std::string_view name() const override { return "serial"; }
  void setMatches(const MatchesSoA& matches) override { matches_ = matches; }
  void score(const float* E, int num_hypotheses, float k, int* counts) override {
    scoreHypothesesCpu(E, 0, num_hypotheses, matches_, k, counts);
  }

 private:
  MatchesSoA matches_;
};

/// The CPU kernel over chunks of hypotheses on the thread pool (each count is computed by one
/// thread with the serial arithmetic, so the counts equal the serial ones).
class ThreadsBackend final : public ScoringBackend {
 public:
  std::string_view name() const override { return "threads"; }
  void setMatches(const MatchesSoA& matches) override { matches_ = matches; }
  void score(const float* E, int num_hypotheses, float k, int* counts) override {
    const int tasks = (num_hypotheses + kThreadsChunk - 1) / kThreadsChunk;
    ThreadPool::shared().run(tasks, [&](int t) {
      const int b = t * kThreadsChunk, e = std::min(num_hypotheses, b + kThreadsChunk);
      scoreHypothesesCpu(E, b, e, matches_, k, counts + b);
    });
  }
  void generateAndScore(int num_hypotheses, const Generator& generate, float* E, float k,
                        int* counts) override {
    const int tasks = (num_hypotheses + kThreadsChunk - 1) / kThreadsChunk;
    ThreadPool::shared().run(tasks, [&](int t) {
      const int b = t * kThreadsChunk, e = std::min(num_hypotheses, b + kThreadsChunk);
      generate(b, e);
      scoreHypothesesCpu(E, b, e, matches_, k, counts + b);
    });
  }
  void parallelFor(int n, const std::function<void(int, int)>& fn) override {
    hostParallelFor(n, fn);
  }

 private:
  MatchesSoA matches_;
};

}  // namespace

std::unique_ptr<ScoringBackend> makeSerialBackend() { return std::make_unique<SerialBackend>(); }
std::unique_ptr<ScoringBackend> makeThreadsBackend() { return std::make_unique<ThreadsBackend>(); }

std::unique_ptr<ScoringBackend> makeScoringBackend(std::string_view name) {
  if (name == "serial") return makeSerialBackend();
  if (name == "threads") return makeThreadsBackend();
  if (name == "opencl") return makeOpenClBackend();
  if (name == "auto") {
    std::string reason;
    if (OpenClContext::shared(&reason)) {
      try {
        return makeOpenClBackend();
      } catch (const Error& e) {
        reason = e.what();
      }
    }
    static std::once_flag warned;
    std::call_once(warned, [&] {
      spdlog::warn("ransac.backend=auto: no usable OpenCL device ({}); using CPU threads", reason);
    });
    return makeThreadsBackend();
  }
  fail("ransac.backend: unknown backend '{}' (expected serial, threads, opencl or auto)", name);
}

}  // namespace ovo::gpu
