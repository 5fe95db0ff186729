#include "apps/online_replay.hpp"

#include <chrono>
#include <limits>
#include <thread>

#include "common/error.hpp"

namespace ovo::app {

ReplaySpan replaySpan(const io::Dataset& data) {
  if (!data.images.empty()) return {data.images.front().t_ns, data.images.back().t_ns};
  ReplaySpan span{std::numeric_limits<Timestamp>::max(), std::numeric_limits<Timestamp>::min()};
  auto cover = [&](Timestamp first, Timestamp last) {
    span.begin_ns = std::min(span.begin_ns, first);
    span.end_ns = std::max(span.end_ns, last);
  };
  if (!data.imu.empty()) cover(data.imu.front().t_ns, data.imu.back().t_ns);
  if (!data.scans.empty()) cover(data.scans.front().t_ns, data.scans.back().t_ns);
  if (span.begin_ns > span.end_ns) return {};
  return span;
}

RealtimeRunResult runRealtime(const io::Dataset& data, estimator::Estimator& est,
                              const RealtimeOptions& options,
                              const OnlinePipeline::OutputCallback& on_output,
                              const ProgressFn& progress) {
  if (!(options.rate > 0.0)) fail("--rate: expected a replay speed > 0, got {}", options.rate);
  RealtimeRunResult result;
  OnlinePipeline pipeline(est, options.pipeline, [&](const OnlineOutput& out) {
    estimator::FrameEstimate f = out.estimate;
    estimator::dropTracks(f);
    result.frames.push_back(std::move(f));  // estimator thread only; read after stop()
    if (on_output) on_output(out);
  });

  using Clock = std::chrono::steady_clock;
  constexpr Timestamp kNever = std::numeric_limits<Timestamp>::max();
  const std::size_t n_images = data.images.size();
  std::size_t next_image = 0, next_imu = 0, next_scan = 0;
  auto timeOf = [&](std::size_t i, std::size_t n, auto&& get) { return i < n ? get(i) : kNever; };
  const ReplaySpan span = replaySpan(data);

  // The next image, decoded ahead of its time (nullopt: skipped).
  auto load = [&](std::size_t i) {
    return loadImageOrSkip(data, i, options.records, result.skipped);
  };
  std::optional<cv::Mat> prefetched;
  if (n_images) prefetched = load(0);
  const auto start = Clock::now();
  pipeline.start();
  auto sleepUntilSensorTime = [&](Timestamp t_ns) {
    const auto target =
        start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                    toSeconds(span.clamp(t_ns) - span.begin_ns) / options.rate));
    std::this_thread::sleep_until(target);
    return target;
  };
  for (;;) {
    const Timestamp t_img =
        timeOf(next_image, n_images, [&](std::size_t i) { return data.images[i].t_ns; });
    const Timestamp t_imu =
        timeOf(next_imu, data.imu.size(), [&](std::size_t i) { return data.imu[i].t_ns; });
    const Timestamp t_scan =
        timeOf(next_scan, data.scans.size(), [&](std::size_t i) { return data.scans[i].t_ns; });
    if (t_img == kNever && t_imu == kNever && t_scan == kNever) break;
    if (t_imu <= t_scan && t_imu <= t_img) {  // at equal times: gyro, then scan, then image
      sleepUntilSensorTime(t_imu);
      pipeline.addGyro(data.imu[next_imu++]);
    } else if (t_scan <= t_img) {
      sleepUntilSensorTime(t_scan);
      pipeline.addScan(data.scans[next_scan++]);
    } else {
      const auto target = sleepUntilSensorTime(t_img);
      const double lag_ms =
          std::chrono::duration<double, std::milli>(Clock::now() - target).count();
      result.replay_lag_ms_max = std::max(result.replay_lag_ms_max, lag_ms);
      if (prefetched) pipeline.addImage(t_img, *prefetched);
      ++next_image;
      if (progress) progress(static_cast<int>(next_image), static_cast<int>(n_images));
      prefetched.reset();
      if (next_image < n_images) prefetched = load(next_image);
    }
  }
  pipeline.stop();
  if (result.frames.empty() && n_images && !result.skipped.empty())
    failNoUsableImage(data, result.skipped);
  result.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  result.stats = pipeline.stats();
  return result;
}

}  // namespace ovo::app
