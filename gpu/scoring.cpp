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

void generateAndScoreCpu(const BearingsSoA& bearings, const MatchesSoA& matches, std::uint64_t seed,
                         int h_begin, int h_end, float k, int* counts) {
  float E[9 * kFusedChunk];
  for (int c0 = h_begin; c0 < h_end; c0 += kFusedChunk) {
    const int c1 = std::min(h_end, c0 + kFusedChunk);
    generateHypothesesCpu(bearings, seed, c0, c1, E);
    scoreHypothesesCpu(E, 0, c1 - c0, matches, k, counts + (c0 - h_begin));
  }
}

namespace {

/// One thread: the CPU kernels over all hypotheses.
class SerialBackend final : public ScoringBackend {
 public:
  std::string_view name() const override { return "serial"; }
  void setMatches(const MatchesSoA& matches, const BearingsSoA& bearings) override {
    matches_ = matches;
    bearings_ = bearings;
  }
  void score(const float* E, int num_hypotheses, float k, int* counts) override {
    scoreHypothesesCpu(E, 0, num_hypotheses, matches_, k, counts);
  }
  void generateAndScore(std::uint64_t seed, int h_begin, int h_end, float k, int* counts) override {
    generateAndScoreCpu(bearings_, matches_, seed, h_begin, h_end, k, counts);
  }
  void generate(std::uint64_t seed, int h_begin, int h_end, float* E) override {
    generateHypothesesCpu(bearings_, seed, h_begin, h_end, E);
  }

 private:
  MatchesSoA matches_;
  BearingsSoA bearings_;
};

/// The CPU kernels over chunks of kFusedChunk hypotheses on the thread pool, taken in turn by
/// whichever thread is free (each count is computed by one thread with the serial arithmetic, so
/// the counts equal the serial ones).
class ThreadsBackend final : public ScoringBackend {
 public:
  std::string_view name() const override { return "threads"; }
  void setMatches(const MatchesSoA& matches, const BearingsSoA& bearings) override {
    matches_ = matches;
    bearings_ = bearings;
  }
  void score(const float* E, int num_hypotheses, float k, int* counts) override {
    const int tasks = (num_hypotheses + kFusedChunk - 1) / kFusedChunk;
    ThreadPool::shared().run(tasks, [&](int t) {
      const int b = t * kFusedChunk, e = std::min(num_hypotheses, b + kFusedChunk);
      scoreHypothesesCpu(E, b, e, matches_, k, counts + b);
    });
  }
  void generateAndScore(std::uint64_t seed, int h_begin, int h_end, float k, int* counts) override {
    const int tasks = (h_end - h_begin + kFusedChunk - 1) / kFusedChunk;
    ThreadPool::shared().run(tasks, [&](int t) {
      const int b = h_begin + t * kFusedChunk, e = std::min(h_end, b + kFusedChunk);
      generateAndScoreCpu(bearings_, matches_, seed, b, e, k, counts + (b - h_begin));
    });
  }
  void generate(std::uint64_t seed, int h_begin, int h_end, float* E) override {
    parallelForOnPool(h_end - h_begin, [&](int b, int e) {
      generateHypothesesCpu(bearings_, seed, h_begin + b, h_begin + e, E + 9 * b);
    });
  }
  void parallelFor(int n, const std::function<void(int, int)>& fn) override {
    parallelForOnPool(n, fn);
  }

 private:
  MatchesSoA matches_;
  BearingsSoA bearings_;
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
