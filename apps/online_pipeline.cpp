#include "apps/online_pipeline.hpp"

#include <spdlog/spdlog.h>

#include <opencv2/imgproc.hpp>

#include "apps/run_metrics.hpp"
#include "common/error.hpp"

namespace ovo::app {

double OnlineStats::latencyMedianMs() const { return percentile(latency_ms, 50); }
double OnlineStats::latencyP99Ms() const { return percentile(latency_ms, 99); }

OnlinePipeline::OnlinePipeline(estimator::Estimator& estimator, OnlineOptions options,
                               OutputCallback callback)
    : estimator_(estimator), options_(options), callback_(std::move(callback)) {
  if (options_.image_queue_depth < 1) fail("online pipeline: image_queue_depth must be >= 1");
}

OnlinePipeline::~OnlinePipeline() {
  try {
    stop();
  } catch (const std::exception& e) {
    spdlog::error("online pipeline: {}", e.what());
  }
}

void OnlinePipeline::start() {
  std::lock_guard lock(mutex_);
  if (started_ || stopping_) return;
  started_ = true;
  thread_ = std::thread([this] { run(); });
}

bool OnlinePipeline::running() const {
  std::lock_guard lock(mutex_);
  return started_ && !stopping_;
}

bool OnlinePipeline::addImage(Timestamp t_ns, const cv::Mat& image) {
  if (image.empty()) fail("online pipeline: empty image at t = {} ns", t_ns);
  if (image.depth() != CV_8U ||
      (image.channels() != 1 && image.channels() != 3 && image.channels() != 4))
    fail("online pipeline: image at t = {} ns: expected 8-bit grey, BGR or BGRA, got type {}", t_ns,
         image.type());
  const auto arrival = Clock::now();
  cv::Mat grey;
  if (image.channels() == 1)
    grey = image.clone();
  else
    cv::cvtColor(image, grey, image.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || (any_image_ && t_ns <= last_image_t_)) {
      ++stats_.rejected;
      return false;
    }
    any_image_ = true;
    last_image_t_ = t_ns;
    ++stats_.frames_in;
    while (static_cast<int>(images_.size()) >= options_.image_queue_depth) {
      images_.pop_front();  // behind: the oldest waiting frame goes
      ++stats_.frames_dropped;
    }
    images_.push_back({t_ns, std::move(grey), arrival});
  }
  wake_.notify_all();
  return true;
}

bool OnlinePipeline::addGyro(const ImuSample& sample) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || (any_gyro_ && sample.t_ns <= last_gyro_t_)) {
      ++stats_.rejected;
      return false;
    }
    any_gyro_ = true;
    last_gyro_t_ = sample.t_ns;
    ++stats_.gyro_in;
    gyro_.push_back(sample);
  }
  wake_.notify_all();
  return true;
}

bool OnlinePipeline::addScan(const LidarScan& scan) {
  std::lock_guard lock(mutex_);
  if (stopping_ || (any_scan_ && scan.t_ns <= last_scan_t_)) {
    ++stats_.rejected;
    return false;
  }
  any_scan_ = true;
  last_scan_t_ = scan.t_ns;
  ++stats_.scans_in;
  scans_.push_back(scan);
  return true;
}

bool OnlinePipeline::gyroReady(const PendingImage& image, Clock::time_point now) const {
  if (!any_gyro_ || last_gyro_t_ >= image.t_ns) return true;
  return now >=
         image.arrival + std::chrono::duration_cast<Clock::duration>(
                             std::chrono::duration<double, std::milli>(options_.gyro_wait_ms));
}

void OnlinePipeline::run() {
  std::shared_ptr<const LidarScan> last_scan;
  try {
    for (;;) {
      std::unique_lock lock(mutex_);
      for (;;) {
        if (!images_.empty()) {
          const auto now = Clock::now();
          if (stopping_ || gyroReady(images_.front(), now)) break;
          wake_.wait_until(
              lock, images_.front().arrival +
                        std::chrono::duration_cast<Clock::duration>(
                            std::chrono::duration<double, std::milli>(options_.gyro_wait_ms)));
          continue;
        }
        if (stopping_) return;
        wake_.wait(lock);
      }
      PendingImage image = std::move(images_.front());
      images_.pop_front();
      std::vector<ImuSample> gyro;
      while (!gyro_.empty()) {
        gyro.push_back(gyro_.front());
        gyro_.pop_front();
        if (gyro.back().t_ns >= image.t_ns) break;
      }
      std::vector<LidarScan> scans;
      while (!scans_.empty() && scans_.front().t_ns <= image.t_ns) {
        scans.push_back(std::move(scans_.front()));
        scans_.pop_front();
      }
      lock.unlock();

      for (const auto& s : gyro) estimator_.addGyro(s);
      for (const auto& s : scans) estimator_.addScan(s);
      if (!scans.empty()) last_scan = std::make_shared<const LidarScan>(scans.back());
      OnlineOutput out;
      out.estimate = estimator_.addImage(image.t_ns, image.grey);
      out.latency_ms =
          std::chrono::duration<double, std::milli>(Clock::now() - image.arrival).count();
      out.grey = std::move(image.grey);
      out.last_scan = last_scan;
      {
        std::lock_guard guard(mutex_);
        ++stats_.frames_processed;
        stats_.latency_ms.push_back(out.latency_ms);
        out.frames_dropped = stats_.frames_dropped;
      }
      if (callback_) callback_(out);
    }
  } catch (...) {
    std::lock_guard lock(mutex_);
    error_ = std::current_exception();
    stopping_ = true;
    images_.clear();
  }
}

void OnlinePipeline::stop() {
  bool run_here = false;
  {
    std::lock_guard lock(mutex_);
    if (stopped_) return;
    stopping_ = true;
    run_here = !started_;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (run_here) run();  // never started: process what was queued on this thread
  std::exception_ptr error;
  std::deque<ImuSample> gyro;
  {
    std::lock_guard lock(mutex_);
    stopped_ = true;
    error = error_;
    gyro.swap(gyro_);
    scans_.clear();
  }
  if (error) std::rethrow_exception(error);
  for (const auto& s : gyro) estimator_.addGyro(s);
  estimator_.finish();
}

OnlineStats OnlinePipeline::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

}  // namespace ovo::app
