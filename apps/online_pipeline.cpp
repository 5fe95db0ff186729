#include "apps/online_pipeline.hpp"

#include <spdlog/spdlog.h>

#include <opencv2/imgproc.hpp>

#include "apps/run_metrics.hpp"
#include "common/error.hpp"

namespace ovo::app {

void applyOnlineSolveBudget(Config& config, const std::string& estimator) {
  if (estimator == "window" && !config.has("window.max_solver_time_s"))
    config.applyOverride(fmt::format("window.max_solver_time_s={}", kOnlineSolveBudgetS));
}

double OnlineStats::latencyMedianMs() const { return percentile(latency_ms, 50); }
double OnlineStats::latencyP99Ms() const { return percentile(latency_ms, 99); }

OnlinePipeline::OnlinePipeline(estimator::Estimator& estimator, OnlineOptions options,
                               OutputCallback callback)
    : estimator_(estimator), options_(options), callback_(std::move(callback)) {
  if (options_.image_queue_depth < 1) fail("online pipeline: image_queue_depth must be >= 1");
  if (options_.frame_queue_depth < 1) fail("online pipeline: frame_queue_depth must be >= 1");
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
  startLocked();
}

void OnlinePipeline::startLocked() {
  started_ = true;
  frontend_thread_ = std::thread([this] { runFrontend(); });
  estimator_thread_ = std::thread([this] { runEstimator(); });
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
    // The frontend's prior source first: once last_gyro_t_ says a sample is there, it is.
    estimator_.addFrontendGyro(sample);
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
  wake_.notify_all();
  return true;
}

OnlinePipeline::Clock::time_point OnlinePipeline::gyroDeadline(Clock::time_point arrival,
                                                               Timestamp later_ns) const {
  const double wait_ms = options_.gyro_wait_ms + 1e-6 * static_cast<double>(later_ns);
  return arrival + std::chrono::duration_cast<Clock::duration>(
                       std::chrono::duration<double, std::milli>(wait_ms));
}

bool OnlinePipeline::gyroReady(const PendingImage& image, Clock::time_point now) const {
  if (!any_gyro_ || last_gyro_t_ >= image.t_ns) return true;
  return now >= gyroDeadline(image.arrival);
}

void OnlinePipeline::setError(std::exception_ptr error) {
  {
    std::lock_guard lock(mutex_);
    if (!error_) error_ = error;
    stopping_ = true;
    frontend_done_ = true;
    images_.clear();
    frames_.clear();
  }
  wake_.notify_all();
}

void OnlinePipeline::runFrontend() {
  try {
    for (;;) {
      std::unique_lock lock(mutex_);
      for (;;) {
        if (error_) return;
        if (!images_.empty()) {
          const auto now = Clock::now();
          if (stopping_ || gyroReady(images_.front(), now)) break;
          wake_.wait_until(lock, gyroDeadline(images_.front().arrival));
          continue;
        }
        if (stopping_) {
          frontend_done_ = true;
          lock.unlock();
          wake_.notify_all();
          return;
        }
        wake_.wait(lock);
      }
      PendingImage image = std::move(images_.front());
      images_.pop_front();
      lock.unlock();

      TrackedFrame tracked;
      tracked.frame = estimator_.track(image.t_ns, image.grey);
      tracked.grey = std::move(image.grey);
      tracked.arrival = image.arrival;
      tracked.tracked = Clock::now();

      lock.lock();
      wake_.wait(lock, [&] {
        return error_ || static_cast<int>(frames_.size()) < options_.frame_queue_depth;
      });
      if (error_) return;
      frames_.push_back(std::move(tracked));
      lock.unlock();
      wake_.notify_all();
    }
  } catch (...) {
    setError(std::current_exception());
  }
}

void OnlinePipeline::runEstimator() {
  std::shared_ptr<const LidarScan> last_scan;
  try {
    for (;;) {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return error_ || !frames_.empty() || frontend_done_; });
      if (error_ || frames_.empty()) return;  // failed, or the frontend is done and all is out
      TrackedFrame tracked = std::move(frames_.front());
      frames_.pop_front();
      wake_.notify_all();  // room in the frame queue
      // A camera found to run early was exposed after its stamp: the gyro up to that instant
      // comes that much later, and the frame waits for it (as the frontend waits for the gyro
      // at its stamp: gyro_wait_ms more at most). A scan that comes after the frame still goes
      // to its keyframe (the window attaches late scans).
      const Timestamp t_ns = tracked.frame->t_ns;
      const Timestamp until = estimator_.measurementsUntil(t_ns);
      if (until > t_ns) {
        wake_.wait_until(lock, gyroDeadline(tracked.arrival, until - t_ns), [&] {
          return error_ || stopping_ || (any_gyro_ && last_gyro_t_ >= until);
        });
        if (error_) return;
      }
      std::vector<ImuSample> gyro;
      while (!gyro_.empty()) {
        gyro.push_back(gyro_.front());
        gyro_.pop_front();
        if (gyro.back().t_ns >= until) break;
      }
      std::vector<LidarScan> scans;
      while (!scans_.empty() && scans_.front().t_ns <= until) {
        scans.push_back(std::move(scans_.front()));
        scans_.pop_front();
      }
      lock.unlock();

      for (const auto& s : gyro) estimator_.addEstimatorGyro(s);
      for (const auto& s : scans) estimator_.addScan(s);
      if (!scans.empty()) last_scan = std::make_shared<const LidarScan>(scans.back());
      OnlineOutput out;
      const auto dequeued = Clock::now();
      out.estimate = estimator_.update(std::move(tracked.frame));
      out.latency_ms =
          std::chrono::duration<double, std::milli>(Clock::now() - tracked.arrival).count();
      out.queue_ms = std::chrono::duration<double, std::milli>(dequeued - tracked.tracked).count();
      out.grey = std::move(tracked.grey);
      out.last_scan = last_scan;
      {
        std::lock_guard guard(mutex_);
        ++stats_.frames_processed;
        stats_.latency_ms.push_back(out.latency_ms);
        const std::size_t keep = options_.latency_history;
        if (keep > 0 && stats_.latency_ms.size() >= 2 * keep)
          stats_.latency_ms.erase(stats_.latency_ms.begin(), stats_.latency_ms.end() - keep);
        out.frames_dropped = stats_.frames_dropped;
      }
      if (callback_) callback_(out);
    }
  } catch (...) {
    setError(std::current_exception());
  }
}

void OnlinePipeline::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopped_) return;
    stopping_ = true;
    if (!started_) startLocked();  // never started: process what was queued
  }
  wake_.notify_all();
  if (frontend_thread_.joinable()) frontend_thread_.join();
  if (estimator_thread_.joinable()) estimator_thread_.join();
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
  for (const auto& s : gyro) estimator_.addEstimatorGyro(s);
  estimator_.finish();
}

OnlineStats OnlinePipeline::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

int OnlinePipeline::framesDropped() const {
  std::lock_guard lock(mutex_);
  return stats_.frames_dropped;
}

std::string OnlinePipeline::error() const {
  std::exception_ptr error;
  {
    std::lock_guard lock(mutex_);
    error = error_;
  }
  if (!error) return {};
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    return e.what();
  } catch (...) {
    return "unknown error";
  }
}

}  // namespace ovo::app
