#include "apps/offline_runner.hpp"

#include <fmt/format.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>

#include "common/error.hpp"
#include "estimator/lidar_ground.hpp"

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

void keepFrame(OfflineRunResult& result, estimator::FrameEstimate estimate, const cv::Mat& grey,
               const FrameFn& on_frame) {
  result.frames.push_back(std::move(estimate));
  if (on_frame) on_frame(result.frames.back(), grey);
  result.frames.back().tracks.clear();
}

void runInSequence(const io::Dataset& data, estimator::Estimator& est, const ProgressFn& progress,
                   const FrameFn& on_frame, OfflineRunResult& result) {
  std::size_t next_imu = 0, next_scan = 0;
  const int total = static_cast<int>(data.images.size());
  for (int i = 0; i < total; ++i) {
    const auto& entry = data.images[i];
    estimator::feedUntilImage(entry.t_ns, data.imu, next_imu, data.scans, next_scan, est);
    const cv::Mat grey = io::loadDatasetImage(data, i);  // a bad image is an error naming the file
    keepFrame(result, est.addImage(entry.t_ns, grey), grey, on_frame);
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
  // Estimator: the next tracked frame; nullopt when the frontend failed or stopped.
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
// frontend stage, which then does not wait for the PNG decoder (9 % of a run's CPU on the
// simulated vineyard_row, about 3.5 ms an image, on the frontend's path before).
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

  // The next image in order; a decoding error (naming the file) is rethrown when its image is due.
  cv::Mat next() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return !images_.empty() || error_; });
    if (images_.empty()) std::rethrow_exception(error_);
    cv::Mat image = std::move(images_.front());
    images_.pop_front();
    changed_.notify_all();
    return image;
  }

 private:
  void run() {
    for (std::size_t i = 0; i < data_.images.size(); ++i) {
      cv::Mat image;
      try {
        image = io::loadDatasetImage(data_, i);
      } catch (...) {
        std::lock_guard lock(mutex_);
        error_ = std::current_exception();
        changed_.notify_all();
        return;
      }
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [&] { return stop_ || images_.size() < kPrefetchImages; });
      if (stop_) return;
      images_.push_back(std::move(image));
      changed_.notify_all();
    }
  }

  const io::Dataset& data_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<cv::Mat> images_;
  std::exception_ptr error_;
  bool stop_ = false;
  std::thread thread_;  // last: starts once the members above exist
};

void runPipelined(const io::Dataset& data, estimator::Estimator& est, const ProgressFn& progress,
                  const FrameFn& on_frame, OfflineRunResult& result) {
  const int total = static_cast<int>(data.images.size());
  StageQueue queue;
  std::size_t frontend_imu = 0;  // the frontend thread's cursor
  ImagePrefetcher images(data);  // outlives the frontend thread
  std::thread frontend([&] {
    try {
      std::size_t no_scan = data.scans.size();
      FrontendStage stage{est};
      for (int i = 0; i < total; ++i) {
        const auto& entry = data.images[i];
        cv::Mat grey = images.next();  // a bad image is an error naming the file
        estimator::feedUntilImage(entry.t_ns, data.imu, frontend_imu, data.scans, no_scan, stage);
        // track(i) after update(i - 1 - lead): the frontend runs up to `lead` frames ahead.
        if (!queue.waitForUpdates(i - estimator::kFrontendLeadFrames)) return;
        auto frame = est.track(entry.t_ns, grey);
        queue.push({std::move(frame), std::move(grey)});
      }
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
      thread.join();
    }
  } join{queue, frontend};

  std::size_t next_imu = 0, next_scan = 0;
  EstimatorStage stage{est};
  for (int i = 0; i < total; ++i) {
    auto item = queue.pop();
    if (!item) break;
    estimator::feedUntilImage(data.images[i].t_ns, data.imu, next_imu, data.scans, next_scan,
                              stage);
    keepFrame(result, est.update(std::move(item->frame)), item->grey, on_frame);
    queue.updateDone();
    if (progress) progress(i + 1, total);
  }
  if (auto error = queue.error()) std::rethrow_exception(error);
  while (next_imu < data.imu.size()) est.addGyro(data.imu[next_imu++]);
}

}  // namespace

estimator::SensorSetup sensorSetupFrom(const io::Dataset& data) {
  if (!data.camera) fail("{}: the dataset has no camera calibration", data.root.string());
  estimator::SensorSetup s{.camera = *data.camera};
  s.T_B_C = data.rig.T_B_C;
  s.T_B_L = data.rig.T_B_L;
  s.camera_rate_hz = data.rig.camera_rate_hz;
  s.pixel_sigma = data.rig.pixel_sigma;
  s.camera_height_m = data.rig.camera_height_m;
  s.time_offset_s = data.rig.camera_time_offset_s;
  s.rolling_shutter_s = data.rig.camera_rolling_shutter_s;
  s.gyro_noise_density = data.rig.gyro_noise_density;
  s.gyro_bias_random_walk = data.rig.gyro_bias_random_walk;
  s.lidar_range_sigma_m = data.rig.lidar_range_sigma_m;
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
    runPipelined(data, est, progress, on_frame, result);
  else
    runInSequence(data, est, progress, on_frame, result);
  est.finish();
  result.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return result;
}

}  // namespace ovo::app
