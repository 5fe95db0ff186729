#include "apps/offline_runner.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>

#include "common/error.hpp"
#include "estimator/common/lidar_ground.hpp"

namespace ovo::app {
namespace {

using Clock = std::chrono::steady_clock;

// feedUntilImage sinks for one stage each.
struct FrontendStage {
  estimator::Estimator& est;
  void addGyro(const ImuSample& s) { est.addFrontendGyro(s); }
  void addScan(const LidarScan& /*scan*/) {}
};
struct EstimatorStage {
  estimator::Estimator& est;
  void addGyro(const ImuSample& s) { est.addEstimatorGyro(s); }
  void addScan(const LidarScan& scan) { est.addScan(scan); }
};

// A bad image: thrown when strict, else counted (and warned about when the first of its kind).
void skipImage(const io::RecordError& bad, const io::RecordPolicy& policy,
               io::SkippedRecords& skipped) {
  if (policy.strict) throw bad;
  if (skipped.add("camera", bad.reason(), bad.what())) warnSkipped(skipped.kinds().back(), true);
}

void keepFrame(OfflineRunResult& result, estimator::FrameEstimate estimate, const cv::Mat& grey,
               const FrameFn& on_frame) {
  result.frames.push_back(std::move(estimate));
  if (on_frame) on_frame(result.frames.back(), grey);
  estimator::dropTracks(result.frames.back());
}

void runInSequence(const io::Dataset& data, estimator::Estimator& est, const ProgressFn& progress,
                   const FrameFn& on_frame, const io::RecordPolicy& policy,
                   OfflineRunResult& result) {
  std::size_t next_imu = 0, next_scan = 0;
  const int total = static_cast<int>(data.images.size());
  for (int i = 0; i < total; ++i) {
    const auto& entry = data.images[i];
    // A skipped image's gyro samples and scans go with the next image.
    if (const auto grey = loadImageOrSkip(data, i, policy, result.skipped)) {
      estimator::feedUntilImage(est.measurementsUntil(entry.t_ns), data.imu, next_imu, data.scans,
                                next_scan, est);
      keepFrame(result, est.addImage(entry.t_ns, *grey), *grey, on_frame);
    }
    if (progress) progress(i + 1, total);
  }
  while (next_imu < data.imu.size()) est.addGyro(data.imu[next_imu++]);
}

// The frontend thread's hand-over to the estimator stage.
class StageQueue {
 public:
  struct Item {
    std::unique_ptr<estimator::FrontendFrame> frame;
    cv::Mat grey;
    std::size_t index = 0;  // in data.images
  };

  // Frontend: blocks until update() is done for `updates` frames (false: stopping).
  bool waitForUpdates(int updates) {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return stop_ || updates_done_ >= updates; });
    return !stop_;
  }
  void push(Item item) {
    {
      std::lock_guard lock(mutex_);
      items_.push_back(std::move(item));
    }
    changed_.notify_all();
  }
  // Estimator: the next tracked frame; nullopt when the frontend failed, stopped or is done.
  std::optional<Item> pop() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return stop_ || !items_.empty(); });
    if (items_.empty()) return std::nullopt;
    Item item = std::move(items_.front());
    items_.pop_front();
    return item;
  }
  void updateDone() {
    {
      std::lock_guard lock(mutex_);
      ++updates_done_;
    }
    changed_.notify_all();
  }
  void stop(std::exception_ptr error = nullptr) {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
      if (error && !error_) error_ = error;
    }
    changed_.notify_all();
  }
  std::exception_ptr error() {
    std::lock_guard lock(mutex_);
    return error_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Item> items_;
  int updates_done_ = 0;
  bool stop_ = false;
  std::exception_ptr error_;
};

// Decodes the dataset's images in order on its own thread, up to kPrefetchImages ahead of the
// frontend stage, which then does not wait for the PNG decoder (a good share of a run's CPU, on
// the frontend's path before).
constexpr std::size_t kPrefetchImages = 4;

class ImagePrefetcher {
 public:
  explicit ImagePrefetcher(const io::Dataset& data) : data_(data), thread_([this] { run(); }) {}
  ImagePrefetcher(const ImagePrefetcher&) = delete;
  ImagePrefetcher& operator=(const ImagePrefetcher&) = delete;
  ~ImagePrefetcher() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    changed_.notify_all();
    thread_.join();
  }

  // The next image in order (nullopt: skipped, counted in `skipped`, which only the consumer
  // touches); an error (naming the file) is rethrown when its image is due.
  std::optional<cv::Mat> next(const io::RecordPolicy& policy, io::SkippedRecords& skipped) {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return !images_.empty() || error_; });
    if (images_.empty()) std::rethrow_exception(error_);
    Decoded d = std::move(images_.front());
    images_.pop_front();
    changed_.notify_all();
    lock.unlock();
    if (d.bad) {
      skipImage(*d.bad, policy, skipped);
      return std::nullopt;
    }
    return std::move(d.image);
  }

 private:
  struct Decoded {
    cv::Mat image;
    std::optional<io::RecordError> bad;  // the image cannot be used
  };

  void run() {
    for (std::size_t i = 0; i < data_.images.size(); ++i) {
      Decoded d;
      try {
        d.image = io::loadDatasetImage(data_, i);
      } catch (const io::RecordError& e) {
        d.bad = e;
      } catch (...) {
        std::lock_guard lock(mutex_);
        error_ = std::current_exception();
        changed_.notify_all();
        return;
      }
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [&] { return stop_ || images_.size() < kPrefetchImages; });
      if (stop_) return;
      images_.push_back(std::move(d));
      changed_.notify_all();
    }
  }

  const io::Dataset& data_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Decoded> images_;
  std::exception_ptr error_;
  bool stop_ = false;
  std::thread thread_;  // last: starts once the members above exist
};

void runPipelined(const io::Dataset& data, estimator::Estimator& est, const ProgressFn& progress,
                  const FrameFn& on_frame, const io::RecordPolicy& policy,
                  OfflineRunResult& result) {
  const int total = static_cast<int>(data.images.size());
  StageQueue queue;
  std::size_t frontend_imu = 0;  // the frontend thread's cursor
  io::SkippedRecords skipped;    // the frontend thread's until it is joined
  ImagePrefetcher images(data);  // outlives the frontend thread
  std::thread frontend([&] {
    try {
      std::size_t no_scan = data.scans.size();
      FrontendStage stage{est};
      int tracked = 0;
      for (int i = 0; i < total; ++i) {
        const auto& entry = data.images[i];
        std::optional<cv::Mat> grey = images.next(policy, skipped);
        if (!grey) continue;  // skipped: its gyro samples go with the next image
        estimator::feedUntilImage(entry.t_ns, data.imu, frontend_imu, data.scans, no_scan, stage);
        // track(k) after update(k - 1 - lead): the frontend runs up to `lead` frames ahead.
        if (!queue.waitForUpdates(tracked - estimator::kFrontendLeadFrames)) return;
        auto frame = est.track(entry.t_ns, *grey);
        queue.push({std::move(frame), std::move(*grey), static_cast<std::size_t>(i)});
        ++tracked;
      }
      queue.stop();  // done: the estimator stage takes what is queued, then ends
    } catch (...) {
      queue.stop(std::current_exception());
    }
  });
  // Stops and joins the frontend thread however the estimator stage leaves.
  struct Join {
    StageQueue& queue;
    std::thread& thread;
    ~Join() {
      queue.stop();
      if (thread.joinable()) thread.join();
    }
  } join{queue, frontend};

  std::size_t next_imu = 0, next_scan = 0;
  EstimatorStage stage{est};
  while (auto item = queue.pop()) {
    estimator::feedUntilImage(est.measurementsUntil(data.images[item->index].t_ns), data.imu,
                              next_imu, data.scans, next_scan, stage);
    keepFrame(result, est.update(std::move(item->frame)), item->grey, on_frame);
    queue.updateDone();
    if (progress) progress(static_cast<int>(item->index) + 1, total);
  }
  frontend.join();
  result.skipped.merge(skipped);
  if (auto error = queue.error()) std::rethrow_exception(error);
  if (progress) progress(total, total);
  while (next_imu < data.imu.size()) est.addGyro(data.imu[next_imu++]);
}

}  // namespace

std::optional<cv::Mat> loadImageOrSkip(const io::Dataset& data, std::size_t index,
                                       const io::RecordPolicy& policy,
                                       io::SkippedRecords& skipped) {
  try {
    return io::loadDatasetImage(data, index);
  } catch (const io::RecordError& e) {
    skipImage(e, policy, skipped);
    return std::nullopt;
  }
}

void warnSkipped(const io::SkippedRecords::Kind& kind, bool more_may_follow) {
  if (more_may_follow)
    spdlog::warn(
        "{}: bad record skipped ({}): {} (more of this kind are skipped without a word; "
        "metrics.json's skipped counts them)",
        kind.sensor, kind.reason, kind.first);
  else
    spdlog::warn("{} (metrics.json's skipped counts them)", io::SkippedRecords::describe(kind));
}

void failNoUsableImage(const io::Dataset& data, const io::SkippedRecords& skipped) {
  for (const auto& k : skipped.kinds())
    if (k.sensor == "camera")
      fail("{}: none of the {} images could be used; the first: {}", data.root.string(),
           data.images.size(), k.first);
  fail("{}: no image was processed", data.root.string());
}

std::optional<std::string> imagesOntoGyroClock(io::Dataset& data) {
  const double offset_s = data.rig.camera_time_offset_s;
  if (offset_s == 0.0) return std::nullopt;
  const Timestamp offset_ns = fromSeconds(offset_s);
  for (io::ImageEntry& image : data.images) image.t_ns -= offset_ns;
  data.rig.camera_time_offset_s = 0.0;
  return fmt::format(
      "camera.time_offset_s {:+.2f} ms (rig): image stamps moved onto the gyro clock; the poses "
      "are at gyro-clock times",
      offset_s * 1e3);
}

estimator::SensorSetup sensorSetupFromRig(const io::RigInfo& rig, const camera::Camera& camera,
                                          const SE3& T_B_C) {
  estimator::SensorSetup s{.camera = camera};
  s.T_B_C = T_B_C;
  s.T_B_L = rig.T_B_L;
  s.camera_rate_hz = rig.camera_rate_hz;
  s.pixel_sigma = rig.pixel_sigma;
  s.camera_height_m = rig.camera_height_m;
  s.time_offset_s = rig.camera_time_offset_s;
  s.rolling_shutter_s = rig.camera_rolling_shutter_s;
  s.gyro_noise_density = rig.gyro_noise_density;
  s.gyro_bias_random_walk = rig.gyro_bias_random_walk;
  s.lidar_range_sigma_m = rig.lidar_range_sigma_m;
  return s;
}

estimator::SensorSetup sensorSetupFrom(const io::Dataset& data) {
  if (!data.camera) fail("{}: the dataset has no camera calibration", data.root.string());
  estimator::SensorSetup s = sensorSetupFromRig(data.rig, *data.camera, data.rig.T_B_C);
  s.has_gyro = !data.imu.empty();
  s.has_lidar = !data.scans.empty();
  return s;
}

std::optional<std::string> cameraHeightFromScans(const io::Dataset& data,
                                                 estimator::SensorSetup* setup) {
  if (setup->camera_height_m || data.scans.empty()) return std::nullopt;
  const auto h = estimator::cameraHeightFromLidar(data.scans, setup->T_B_L, setup->T_B_C);
  if (!h) return std::nullopt;
  setup->camera_height_m = h->camera_height_m;
  return fmt::format(
      "camera height {:.3f} m measured from the LiDAR's ground hits ({} agreeing scans of {} "
      "with ground hits, first {} scans): the rig gives none",
      h->camera_height_m, h->scans_agreeing, h->scans_used, h->scans_seen);
}

OfflineRunResult runOffline(const io::Dataset& data, estimator::Estimator& est,
                            const ProgressFn& progress, const FrameFn& on_frame,
                            const OfflineOptions& options) {
  OfflineRunResult result;
  const auto t0 = Clock::now();
  if (options.pipelined)
    runPipelined(data, est, progress, on_frame, options.records, result);
  else
    runInSequence(data, est, progress, on_frame, options.records, result);
  if (result.frames.empty() && !data.images.empty()) failNoUsableImage(data, result.skipped);
  est.finish();
  result.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return result;
}

}  // namespace ovo::app
