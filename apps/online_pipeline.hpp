// The live API (DESIGN section 1, Kimera-VIO / OKVIS style): feed images, gyro samples and LiDAR
// scans from any thread and any source, get poses by callback. This class owns the queues and
// two threads; the estimator it drives has no threads and is the same code the offline runner
// calls, split in its two stages:
//
//   addImage -> [image queue, depth image_queue_depth, oldest dropped] -> frontend thread:
//   Estimator::track() -> [frame queue, depth frame_queue_depth, the frontend waits when full]
//   -> estimator thread: Estimator::update() -> callback.
//
// The frontend thread tracks image k+1 while the estimator thread updates with image k. Images
// are the only measurements dropped (counted) when the pipeline falls behind. Gyro samples and
// scans are never dropped: every gyro sample goes at once to the frontend's prior source
// (Estimator::addFrontendGyro) and into an unbounded queue for the estimator thread, which feeds
// gyro and scans in time order before the frame they precede (the gyro up to and including the
// first sample at or after the frame time, as the offline runner does). The frontend thread waits
// (at most gyro_wait_ms) for the gyro sample at or after an image's time before tracking it.
#pragma once

#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>
#include <thread>
#include <vector>

#include "common/config.hpp"
#include "estimator/estimator.hpp"

namespace ovo::app {

/// Bounds of a recording's replay speed (ovo run --realtime --rate, ovo_live_camera --rate for a
/// video file): 1e-10 slept for ever between frames, 1e-300 overflowed the sleep into none.
inline constexpr double kMinReplayRate = 0.01;
inline constexpr double kMaxReplayRate = 1000.0;

/// The online mode's time budget per window solve (window.max_solver_time_s), s: a late solve
/// holds up every frame queued behind it.
inline constexpr double kOnlineSolveBudgetS = 0.04;
/// Gives `config` that budget for the window estimator unless it sets one: what every online entry
/// point (ovo run --realtime, the live API with realtime, ovo_live_camera) applies before it
/// makes the estimator.
void applyOnlineSolveBudget(Config& config, const std::string& estimator);

struct OnlineOptions {
  int image_queue_depth = 2;   // frames waiting for the frontend; beyond it the oldest is dropped
  int frame_queue_depth = 2;   // tracked frames waiting for the estimator stage (frontend waits)
  double gyro_wait_ms = 50.0;  // a frame waits at most this long (from addImage) for the gyro
                               // sample at or after its time, once any gyro sample has been seen
  /// OnlineStats::latency_ms: 0 keeps every frame's (ovo run --realtime writes them per frame);
  /// N keeps the last N to 2N, so that a run of hours stays flat in memory (kept whole, the
  /// vector grows with every frame).
  std::size_t latency_history = 0;
};

/// latency_history for a run of hours (ovo_soak, ovo_live_camera, the API without its
/// trajectory): 30 minutes at 20 Hz.
inline constexpr std::size_t kLongRunLatencyHistory = 36000;

/// One processed frame, handed to the output callback.
struct OnlineOutput {
  estimator::FrameEstimate estimate;
  cv::Mat grey;                                // the image that was processed (do not modify)
  std::shared_ptr<const LidarScan> last_scan;  // latest scan fed before it (may be null)
  double latency_ms = 0.0;                     // addImage() -> pose out [ms]
  double queue_ms = 0.0;   // of which waiting between the stages (frame queue) [ms]
  int frames_dropped = 0;  // so far
};

struct OnlineStats {
  int frames_in = 0;         // images accepted by addImage
  int frames_processed = 0;  // images the estimator stage processed
  int frames_dropped = 0;    // images dropped because the pipeline was behind
  int rejected = 0;          // measurements refused (time not increasing, after stop)
  long gyro_in = 0, scans_in = 0;
  std::vector<double> latency_ms;  // per processed frame (the recent ones: latency_history)
  double latencyMedianMs() const;
  double latencyP99Ms() const;
};

class OnlinePipeline {
 public:
  /// Called on the estimator thread after each frame; keep it short (copy what you need).
  using OutputCallback = std::function<void(const OnlineOutput&)>;

  /// `estimator` must outlive the pipeline and must not be used elsewhere until stop().
  OnlinePipeline(estimator::Estimator& estimator, OnlineOptions options, OutputCallback callback);
  ~OnlinePipeline();  // stop()
  OnlinePipeline(const OnlinePipeline&) = delete;
  OnlinePipeline& operator=(const OnlinePipeline&) = delete;

  /// Starts the two threads (measurements added before are queued, not lost).
  void start();
  /// Processes the frames still queued (starting the threads when start() was not called), feeds
  /// the remaining gyro samples, calls Estimator::finish() and joins the threads. Idempotent.
  /// Rethrows an exception the estimator or the callback threw on either thread.
  void stop();
  bool running() const;

  /// Thread-safe. 8-bit grey, BGR or BGRA (converted to grey; the data is copied). Returns false
  /// (and counts it as rejected) when t_ns is not after the previous image or after stop().
  /// Throws ovo::Error for an empty image or another pixel type.
  bool addImage(Timestamp t_ns, const cv::Mat& image);
  /// Thread-safe; false when not after the previous sample or after stop().
  bool addGyro(const ImuSample& sample);
  bool addScan(const LidarScan& scan);

  /// A copy of the counters and the recent latencies (up to latency_history doubles).
  OnlineStats stats() const;
  /// stats().frames_dropped without copying the latencies (cheap enough to call every frame).
  int framesDropped() const;
  /// The message of the exception that stopped the threads (stop() rethrows it); empty while none
  /// did.
  std::string error() const;

 private:
  using Clock = std::chrono::steady_clock;
  struct PendingImage {
    Timestamp t_ns;
    cv::Mat grey;
    Clock::time_point arrival;
  };
  struct TrackedFrame {
    std::unique_ptr<estimator::FrontendFrame> frame;
    cv::Mat grey;
    Clock::time_point arrival, tracked;
  };
  void startLocked();  // under mutex_
  void runFrontend();
  void runEstimator();
  void setError(std::exception_ptr error);  // stops both threads; stop() rethrows it
  bool gyroReady(const PendingImage& image, Clock::time_point now) const;  // under mutex_
  /// When a frame that arrived at `arrival` stops waiting for its gyro: gyro_wait_ms on, plus
  /// later_ns for a gyro expected that much after the frame's stamp.
  Clock::time_point gyroDeadline(Clock::time_point arrival, Timestamp later_ns = 0) const;

  estimator::Estimator& estimator_;
  const OnlineOptions options_;
  const OutputCallback callback_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;  // every change of the queues or the state below
  std::deque<PendingImage> images_;
  std::deque<TrackedFrame> frames_;
  std::deque<ImuSample> gyro_;
  std::deque<LidarScan> scans_;
  Timestamp last_image_t_ = 0, last_gyro_t_ = 0, last_scan_t_ = 0;
  bool any_image_ = false, any_gyro_ = false, any_scan_ = false;
  bool started_ = false, stopping_ = false, stopped_ = false;
  bool frontend_done_ = false;  // the frontend thread has tracked its last image
  OnlineStats stats_;
  std::exception_ptr error_;
  std::thread frontend_thread_, estimator_thread_;
};

}  // namespace ovo::app
