// What the running process has used so far: CPU time (user + system, all threads) and its peak
// resident memory, from getrusage (Linux: ru_maxrss in KiB). `ovo run`'s metrics.json reports the
// run's share (timing.cpu_s, timing.peak_rss_mb). currentRssMb: the resident memory now.
#pragma once

#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>

namespace ovo {

struct ProcessUsage {
  double cpu_s = 0.0;        // user + system CPU time of every thread, s
  double peak_rss_mb = 0.0;  // the largest resident set so far, MiB
};

inline ProcessUsage processUsage() {
  rusage u{};
  if (::getrusage(RUSAGE_SELF, &u) != 0) return {};
  const auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
  };
  return {seconds(u.ru_utime) + seconds(u.ru_stime), static_cast<double>(u.ru_maxrss) / 1024.0};
}

/// The process's resident memory now [MiB] (Linux /proc/self/statm); < 0 where unknown.
inline double currentRssMb() {
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return -1.0;
  long total = 0, resident = 0;
  const int n = std::fscanf(f, "%ld %ld", &total, &resident);
  std::fclose(f);
  const long page = ::sysconf(_SC_PAGESIZE);
  if (n != 2 || page <= 0) return -1.0;
  return static_cast<double>(resident) * static_cast<double>(page) / (1024.0 * 1024.0);
}

}  // namespace ovo
