// Clocks for the frontend's per-stage timings: wall time (what a live pipeline waits for) and the
// calling thread's CPU time (what a stage costs, independent of other load on the machine).
#pragma once

#include <chrono>
#include <ctime>

namespace ovo::frontend {

/// CPU time consumed by the calling thread (milliseconds, arbitrary origin).
inline double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

/// Wall time (milliseconds, steady clock, arbitrary origin).
inline double wallMs() {
  return std::chrono::duration<double, std::milli>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

/// Wall and thread-CPU stopwatch (milliseconds since construction or the last lap()).
class StageClock {
 public:
  StageClock() : wall_(wallMs()), cpu_(threadCpuMs()) {}
  /// Adds the time since the previous lap to *wall_ms and *cpu_ms and restarts.
  void lap(double* wall_ms, double* cpu_ms) {
    const double wall = wallMs();
    const double cpu = threadCpuMs();
    *wall_ms += wall - wall_;
    *cpu_ms += cpu - cpu_;
    wall_ = wall;
    cpu_ = cpu;
  }

 private:
  double wall_;
  double cpu_;
};

}  // namespace ovo::frontend
