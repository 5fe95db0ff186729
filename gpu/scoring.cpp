#include "gpu/scoring.hpp"

#include <spdlog/spdlog.h>
#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <mutex>

#include "common/error.hpp"
#include "gpu/opencl_context.hpp"

namespace ovo::gpu {

float inlierConstant(double threshold_rad) {
  const double thr2 = threshold_rad * threshold_rad;
  return static_cast<float>(thr2 / (1.0 + 2.0 * thr2));
}

void ScoringBackend::parallelFor(int n, const std::function<void(int, int)>& fn) {
  if (n > 0) fn(0, n);
}

namespace {

// Splits [0, n) over TBB's worker threads in chunks of about n / (4 threads).
void tbbFor(int n, const std::function<void(int, int)>& fn) {
  if (n <= 0) return;
  const int threads = std::max(1, tbb::info::default_concurrency());
  const int grain = std::max(1, n / (4 * threads));
  tbb::parallel_for(
      tbb::blocked_range<int>(0, n, grain),
      [&](const tbb::blocked_range<int>& r) { fn(r.begin(), r.end()); }, tbb::simple_partitioner());
}

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

/// The CPU kernel over blocks of hypotheses on TBB's threads (each count is computed by one
/// thread with the serial arithmetic, so the counts equal the serial ones).
class ThreadsBackend final : public ScoringBackend {
 public:
  std::string_view name() const override { return "threads"; }
  void setMatches(const MatchesSoA& matches) override { matches_ = matches; }
  void score(const float* E, int num_hypotheses, float k, int* counts) override {
    tbbFor(num_hypotheses,
           [&](int b, int e) { scoreHypothesesCpu(E, b, e, matches_, k, counts + b); });
  }
  void parallelFor(int n, const std::function<void(int, int)>& fn) override { tbbFor(n, fn); }

 private:
  MatchesSoA matches_;
};

}  // namespace

std::unique_ptr<ScoringBackend> makeSerialBackend() { return std::make_unique<SerialBackend>(); }
std::unique_ptr<ScoringBackend> makeThreadsBackend() { return std::make_unique<ThreadsBackend>(); }

// Host-side threads for the OpenCL backend's parallelFor (defined here to keep TBB in one file).
void hostParallelFor(int n, const std::function<void(int, int)>& fn) { tbbFor(n, fn); }

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
