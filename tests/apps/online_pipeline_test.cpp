// The threaded online pipeline with a scripted estimator: measurement order, the frontend and
// estimator stages on their own threads, dropping the oldest frames when behind, waiting for the
// gyro, latency, errors and shutdown. Blocking is controlled by gates, never by timing
// assumptions.
#include "apps/online_pipeline.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "common/error.hpp"

namespace ovo::app {
namespace {

using namespace std::chrono_literals;

// Records every estimator-stage call in order ('g' gyro, 's' scan, 'i' image update) and the
// frontend stage's separately; track() and update() can each be held at a gate and can throw.
class ScriptedEstimator final : public estimator::Estimator {
 public:
  struct Call {
    char kind;  // 'g' gyro, 's' scan, 'i' image (update)
    Timestamp t_ns;
  };

  std::string name() const override { return "scripted"; }
  void addFrontendGyro(const ImuSample& s) override {
    std::lock_guard lock(mutex_);
    frontend_gyro_.push_back(s.t_ns);
  }
  void addEstimatorGyro(const ImuSample& s) override { record('g', s.t_ns); }
  void addScan(const LidarScan& s) override { record('s', s.t_ns); }
  std::unique_ptr<estimator::FrontendFrame> track(Timestamp t_ns, const cv::Mat& grey) override {
    {
      std::unique_lock lock(mutex_);
      tracked_.push_back(t_ns);
      last_type_ = grey.type();
      ++images_entered_;
      // The frontend saw the gyro sample at or after the image (the pipeline waits for it).
      gyro_seen_at_track_.push_back(frontend_gyro_.empty() ? -1 : frontend_gyro_.back());
      changed_.notify_all();
      changed_.wait(lock, [&] { return gate_open_; });
    }
    if (throw_in_track_at_ == t_ns) fail("scripted frontend failure at {}", t_ns);
    auto frame = std::make_unique<estimator::FrontendFrame>();
    frame->t_ns = t_ns;
    return frame;
  }
  estimator::FrameEstimate update(std::unique_ptr<estimator::FrontendFrame> frame) override {
    const Timestamp t_ns = frame->t_ns;
    record('i', t_ns);
    {
      std::unique_lock lock(mutex_);
      ++updates_entered_;
      changed_.notify_all();
      changed_.wait(lock, [&] { return update_gate_open_; });
    }
    if (work_ > 0ms) std::this_thread::sleep_for(work_);
    if (throw_at_ == t_ns) fail("scripted failure at {}", t_ns);
    estimator::FrameEstimate f;
    f.t_ns = t_ns;
    f.tracked = true;
    f.T_W_B.translation() = Vec3(toSeconds(t_ns), 0, 0);
    return f;
  }
  void finish() override { ++finish_calls_; }
  Trajectory trajectory() const override { return {}; }
  estimator::EstimatorStats stats() const override { return {}; }

  void closeGate() {
    std::lock_guard lock(mutex_);
    gate_open_ = false;
  }
  void openGate() {
    std::lock_guard lock(mutex_);
    gate_open_ = true;
    changed_.notify_all();
  }
  void closeUpdateGate() {
    std::lock_guard lock(mutex_);
    update_gate_open_ = false;
  }
  void openUpdateGate() {
    std::lock_guard lock(mutex_);
    update_gate_open_ = true;
    changed_.notify_all();
  }
  // Images that entered track() (the frontend stage) and update() (the estimator stage).
  void waitImagesEntered(int n) {
    std::unique_lock lock(mutex_);
    ASSERT_TRUE(changed_.wait_for(lock, 10s, [&] { return images_entered_ >= n; }));
  }
  void waitUpdatesEntered(int n) {
    std::unique_lock lock(mutex_);
    ASSERT_TRUE(changed_.wait_for(lock, 10s, [&] { return updates_entered_ >= n; }));
  }
  int updatesEntered() const {
    std::lock_guard lock(mutex_);
    return updates_entered_;
  }
  std::vector<Call> calls() const {
    std::lock_guard lock(mutex_);
    return calls_;
  }
  std::vector<Timestamp> tracked() const {
    std::lock_guard lock(mutex_);
    return tracked_;
  }
  std::vector<Timestamp> frontendGyro() const {
    std::lock_guard lock(mutex_);
    return frontend_gyro_;
  }
  std::vector<Timestamp> gyroSeenAtTrack() const {
    std::lock_guard lock(mutex_);
    return gyro_seen_at_track_;
  }

  std::chrono::milliseconds work_{0};
  Timestamp throw_at_ = -1;
  Timestamp throw_in_track_at_ = -1;
  int finish_calls_ = 0;
  int last_type_ = -1;

 private:
  void record(char kind, Timestamp t) {
    std::lock_guard lock(mutex_);
    calls_.push_back({kind, t});
  }
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool gate_open_ = true, update_gate_open_ = true;
  int images_entered_ = 0, updates_entered_ = 0;
  std::vector<Call> calls_;
  std::vector<Timestamp> tracked_, frontend_gyro_, gyro_seen_at_track_;
};

cv::Mat greyImage() { return cv::Mat(24, 32, CV_8UC1, cv::Scalar(100)); }

// Counts the pipeline's outputs; waitFor(n) blocks until n have come out (false after 10 s).
struct OutputCounter {
  std::mutex m;
  std::condition_variable cv;
  int outputs = 0;
  OnlinePipeline::OutputCallback callback() {
    return [this](const OnlineOutput&) {
      std::lock_guard lock(m);
      ++outputs;
      cv.notify_all();
    };
  }
  bool waitFor(int n) {
    std::unique_lock lock(m);
    return cv.wait_for(lock, std::chrono::seconds(10), [&] { return outputs == n; });
  }
};

constexpr Timestamp kMs = 1'000'000;

TEST(OnlinePipeline, FeedsGyroAndScansInTimeOrderBeforeTheImageTheyPrecede) {
  ScriptedEstimator est;
  OnlineOptions options;
  options.image_queue_depth = 1000;  // nothing dropped here
  options.gyro_wait_ms = 60'000;     // every image waits for the gyro sample after it
  std::vector<Timestamp> outputs;
  OnlinePipeline pipeline(est, options,
                          [&](const OnlineOutput& o) { outputs.push_back(o.estimate.t_ns); });
  pipeline.start();
  // 1 s of data in sensor order: gyro 200 Hz, scans 10 Hz (offset 3 ms), images 20 Hz.
  for (Timestamp t = 0; t <= 1000 * kMs; t += kMs) {
    if (t % (5 * kMs) == 0) pipeline.addGyro({t, Vec3(0.1, 0, 0), Vec3::Zero()});
    if (t % (100 * kMs) == 3 * kMs) {
      LidarScan scan;
      scan.t_ns = t;
      pipeline.addScan(scan);
    }
    if (t % (50 * kMs) == 2 * kMs) pipeline.addImage(t, greyImage());
  }
  pipeline.stop();

  const auto calls = est.calls();
  std::vector<Timestamp> gyro, images;
  Timestamp last_gyro = -1, last_scan = -1;
  for (const auto& c : calls) {
    if (c.kind == 'g') {
      EXPECT_GT(c.t_ns, last_gyro);
      last_gyro = c.t_ns;
      gyro.push_back(c.t_ns);
    } else if (c.kind == 's') {
      last_scan = c.t_ns;
    } else {
      images.push_back(c.t_ns);
      // The gyro up to and including the first sample at or after the frame time ...
      EXPECT_GE(last_gyro, c.t_ns) << "image " << c.t_ns;
      EXPECT_LT(last_gyro - c.t_ns, 5 * kMs) << "image " << c.t_ns;
      // ... and every scan at or before it, none after.
      EXPECT_LE(last_scan, c.t_ns);
      EXPECT_GT(last_scan + 100 * kMs, c.t_ns) << "a scan before image " << c.t_ns << " is missing";
    }
  }
  EXPECT_EQ(gyro.size(), 201u);                // every sample exactly once, the tail after stop()
  EXPECT_EQ(est.frontendGyro().size(), 201u);  // and to the frontend's prior source
  EXPECT_EQ(images.size(), 20u);
  EXPECT_EQ(est.tracked(), images);
  const auto seen = est.gyroSeenAtTrack();
  for (std::size_t k = 0; k < images.size(); ++k)
    EXPECT_GE(seen[k], images[k]) << "the frontend tracked image " << images[k]
                                  << " without the gyro";
  EXPECT_EQ(outputs, images);
  EXPECT_EQ(est.finish_calls_, 1);
  const OnlineStats s = pipeline.stats();
  EXPECT_EQ(s.frames_in, 20);
  EXPECT_EQ(s.frames_processed, 20);
  EXPECT_EQ(s.frames_dropped, 0);
  EXPECT_EQ(s.gyro_in, 201);
  EXPECT_EQ(s.scans_in, 10);
}

TEST(OnlinePipeline, TheFrontendTracksTheNextImageWhileTheEstimatorUpdates) {
  ScriptedEstimator est;
  est.closeUpdateGate();
  OnlinePipeline pipeline(est, {}, {});
  pipeline.start();
  pipeline.addImage(0, greyImage());
  est.waitUpdatesEntered(1);  // image 0 is in update(), held
  pipeline.addImage(50 * kMs, greyImage());
  pipeline.addImage(100 * kMs, greyImage());
  est.waitImagesEntered(3);  // ... while the frontend thread tracks images 1 and 2
  EXPECT_EQ(est.updatesEntered(), 1);
  est.openUpdateGate();
  pipeline.stop();
  EXPECT_EQ(pipeline.stats().frames_processed, 3);
  EXPECT_EQ(pipeline.stats().frames_dropped, 0);
}

TEST(OnlinePipeline, DropsOnlyCameraFramesWhenTheEstimatorStageIsBehind) {
  ScriptedEstimator est;
  OnlineOptions options;
  options.image_queue_depth = 2;
  options.frame_queue_depth = 2;
  std::vector<Timestamp> outputs;
  OnlinePipeline pipeline(est, options,
                          [&](const OnlineOutput& o) { outputs.push_back(o.estimate.t_ns); });
  est.closeUpdateGate();
  pipeline.start();
  pipeline.addImage(0, greyImage());
  est.waitUpdatesEntered(1);  // image 0 held in update()
  // Images 1, 2 go to the frame queue; image 3 is tracked and waits for room there.
  for (int i = 1; i <= 3; ++i) {
    pipeline.addImage(i * 50 * kMs, greyImage());
    est.waitImagesEntered(i + 1);
  }
  for (int i = 4; i < 20; ++i) {
    pipeline.addGyro({i * 50 * kMs, Vec3::Zero(), Vec3::Zero()});
    pipeline.addImage(i * 50 * kMs, greyImage());
  }
  est.openUpdateGate();
  pipeline.stop();

  // 4..17 dropped before the frontend, oldest first; every gyro sample reached both stages.
  EXPECT_EQ(outputs, (std::vector<Timestamp>{0, 50 * kMs, 100 * kMs, 150 * kMs, 18 * 50 * kMs,
                                             19 * 50 * kMs}));
  const OnlineStats s = pipeline.stats();
  EXPECT_EQ(s.frames_in, 20);
  EXPECT_EQ(s.frames_processed, 6);
  EXPECT_EQ(s.frames_dropped, 14);
  int gyro_calls = 0;
  for (const auto& c : est.calls()) gyro_calls += c.kind == 'g';
  EXPECT_EQ(gyro_calls, 16);
  EXPECT_EQ(est.frontendGyro().size(), 16u);
}

TEST(OnlinePipeline, DropsTheOldestWaitingFramesWhenBehindAndCountsThem) {
  ScriptedEstimator est;
  OnlineOptions options;
  options.image_queue_depth = 2;
  std::vector<Timestamp> outputs;
  std::vector<int> dropped_seen;
  OnlinePipeline pipeline(est, options, [&](const OnlineOutput& o) {
    outputs.push_back(o.estimate.t_ns);
    dropped_seen.push_back(o.frames_dropped);
  });
  est.closeGate();
  pipeline.start();
  pipeline.addImage(0, greyImage());
  est.waitImagesEntered(1);  // frame 0 is being processed (held at the gate)
  for (int i = 1; i < 20; ++i) pipeline.addImage(i * 50 * kMs, greyImage());
  est.openGate();
  pipeline.stop();

  // Frames 1..17 were dropped oldest first; the two newest waited and were processed.
  EXPECT_EQ(outputs, (std::vector<Timestamp>{0, 18 * 50 * kMs, 19 * 50 * kMs}));
  const OnlineStats s = pipeline.stats();
  EXPECT_EQ(s.frames_in, 20);
  EXPECT_EQ(s.frames_processed, 3);
  EXPECT_EQ(s.frames_dropped, 17);
  EXPECT_EQ(pipeline.framesDropped(), 17);
  EXPECT_EQ(dropped_seen.back(), 17);
  EXPECT_EQ(s.latency_ms.size(), 3u);
}

TEST(OnlinePipeline, AFrameWaitsForTheGyroSampleAfterItsTime) {
  ScriptedEstimator est;
  OnlineOptions options;
  options.gyro_wait_ms = 60'000;  // wait for the gyro, however long
  OutputCounter counter;
  OnlinePipeline pipeline(est, options, counter.callback());
  pipeline.start();
  pipeline.addGyro({0, Vec3::Zero(), Vec3::Zero()});
  pipeline.addImage(10 * kMs, greyImage());
  std::this_thread::sleep_for(50ms);  // give the pipeline a chance to (wrongly) go ahead
  pipeline.addGyro({15 * kMs, Vec3::Zero(), Vec3::Zero()});
  ASSERT_TRUE(counter.waitFor(1));
  const auto calls = est.calls();
  ASSERT_EQ(calls.size(), 3u);
  EXPECT_EQ(calls[0].kind, 'g');
  EXPECT_EQ(calls[1].kind, 'g');
  EXPECT_EQ(calls[1].t_ns, 15 * kMs);
  EXPECT_EQ(calls[2].kind, 'i');
  pipeline.stop();
}

TEST(OnlinePipeline, AFrameStopsWaitingForALateGyroAfterTheTimeout) {
  ScriptedEstimator est;
  OnlineOptions options;
  options.gyro_wait_ms = 20;
  OutputCounter counter;
  OnlinePipeline pipeline(est, options, counter.callback());
  pipeline.start();
  pipeline.addGyro({0, Vec3::Zero(), Vec3::Zero()});
  pipeline.addImage(10 * kMs, greyImage());
  ASSERT_TRUE(counter.waitFor(1));
  const auto calls = est.calls();
  ASSERT_EQ(calls.size(), 2u);
  EXPECT_EQ(calls[1].kind, 'i');
  pipeline.stop();
}

TEST(OnlinePipeline, LatencyIncludesTheProcessingTime) {
  ScriptedEstimator est;
  est.work_ = 30ms;
  double latency = -1;
  OnlinePipeline pipeline(est, {}, [&](const OnlineOutput& o) { latency = o.latency_ms; });
  pipeline.start();
  pipeline.addImage(0, greyImage());
  pipeline.stop();
  EXPECT_GE(latency, 30.0);
  EXPECT_EQ(pipeline.stats().latency_ms.at(0), latency);
  EXPECT_EQ(pipeline.stats().latencyMedianMs(), latency);
}

// A run of hours (ovo_soak, ovo_live_camera, the API without its trajectory) keeps the recent
// latencies only: the last latency_history to twice that.
TEST(OnlinePipeline, KeepsOnlyTheRecentLatenciesWhenAskedTo) {
  ScriptedEstimator est;
  OnlineOptions options;
  options.latency_history = 5;
  options.image_queue_depth = 64;  // not started: all 40 wait, none is dropped
  std::vector<double> latencies;
  std::mutex mutex;
  OnlinePipeline pipeline(est, options, [&](const OnlineOutput& o) {
    std::lock_guard lock(mutex);
    latencies.push_back(o.latency_ms);
  });
  for (int i = 0; i < 40; ++i) pipeline.addImage(i * kMs, greyImage());
  pipeline.stop();
  const OnlineStats s = pipeline.stats();
  ASSERT_EQ(s.frames_processed, 40);
  ASSERT_EQ(latencies.size(), 40u);
  ASSERT_GE(s.latency_ms.size(), 5u);
  ASSERT_LT(s.latency_ms.size(), 10u);
  EXPECT_TRUE(std::equal(s.latency_ms.rbegin(), s.latency_ms.rend(), latencies.rbegin()));
  // By default every frame's is kept (ovo run --realtime writes them per frame).
  OnlineOptions keep_all;
  keep_all.image_queue_depth = 64;
  OnlinePipeline all(est, keep_all, [](const OnlineOutput&) {});
  for (int i = 0; i < 40; ++i) all.addImage((100 + i) * kMs, greyImage());
  all.stop();
  EXPECT_EQ(all.stats().latency_ms.size(), 40u);
}

TEST(OnlinePipeline, RejectsMeasurementsThatDoNotMoveForwardInTime) {
  ScriptedEstimator est;
  OnlinePipeline pipeline(est, {}, {});
  EXPECT_TRUE(pipeline.addImage(10, greyImage()));
  EXPECT_FALSE(pipeline.addImage(10, greyImage()));
  EXPECT_FALSE(pipeline.addImage(5, greyImage()));
  EXPECT_TRUE(pipeline.addGyro({3, Vec3::Zero(), Vec3::Zero()}));
  EXPECT_FALSE(pipeline.addGyro({3, Vec3::Zero(), Vec3::Zero()}));
  pipeline.stop();
  EXPECT_FALSE(pipeline.addImage(20, greyImage()));  // after stop
  EXPECT_EQ(pipeline.stats().rejected, 4);
  EXPECT_EQ(pipeline.stats().frames_processed, 1);
}

TEST(OnlinePipeline, ProcessesWhatWasQueuedWhenStoppedWithoutStart) {
  ScriptedEstimator est;
  int outputs = 0;
  OnlinePipeline pipeline(est, {}, [&](const OnlineOutput&) { ++outputs; });
  pipeline.addImage(1, greyImage());
  pipeline.addImage(2, greyImage());
  pipeline.stop();
  pipeline.stop();  // idempotent
  EXPECT_EQ(outputs, 2);
  EXPECT_EQ(est.finish_calls_, 1);
}

TEST(OnlinePipeline, ConvertsColourToGreyAndRefusesOtherPixelTypes) {
  ScriptedEstimator est;
  OnlinePipeline pipeline(est, {}, {});
  pipeline.start();
  pipeline.addImage(1, cv::Mat(24, 32, CV_8UC3, cv::Scalar(10, 20, 30)));
  EXPECT_THROW(pipeline.addImage(2, cv::Mat(24, 32, CV_16UC1)), Error);
  EXPECT_THROW(pipeline.addImage(3, cv::Mat()), Error);
  pipeline.stop();
  EXPECT_EQ(est.last_type_, CV_8UC1);
}

TEST(OnlinePipeline, StopRethrowsWhatTheFrontendThrew) {
  ScriptedEstimator est;
  est.throw_in_track_at_ = 2;
  OnlinePipeline pipeline(est, {}, {});
  pipeline.start();
  pipeline.addImage(1, greyImage());
  pipeline.addImage(2, greyImage());
  pipeline.addImage(3, greyImage());
  EXPECT_THROW(pipeline.stop(), Error);
  EXPECT_EQ(est.finish_calls_, 0);
}

TEST(OnlinePipeline, StopRethrowsWhatTheEstimatorThrew) {
  ScriptedEstimator est;
  est.throw_at_ = 2;
  OnlinePipeline pipeline(est, {}, {});
  pipeline.start();
  pipeline.addImage(1, greyImage());
  pipeline.addImage(2, greyImage());
  EXPECT_THROW(pipeline.stop(), Error);
  EXPECT_EQ(est.finish_calls_, 0);
}

// Every online entry point (ovo run --realtime, the live API, ovo_live_camera) gives the window
// the same solve budget, and a configuration that sets its own keeps it.
TEST(OnlineSolveBudget, TheWindowGetsItUnlessConfiguredAndOtherEstimatorsDoNot) {
  Config window;
  applyOnlineSolveBudget(window, "window");
  EXPECT_DOUBLE_EQ(window.get<double>("window.max_solver_time_s", -1.0), kOnlineSolveBudgetS);
  Config own;
  own.applyOverride("window.max_solver_time_s=0.2");
  applyOnlineSolveBudget(own, "window");
  EXPECT_DOUBLE_EQ(own.get<double>("window.max_solver_time_s", -1.0), 0.2);
  Config kf;
  applyOnlineSolveBudget(kf, "kf");
  EXPECT_FALSE(kf.has("window.max_solver_time_s"));
}

}  // namespace
}  // namespace ovo::app
