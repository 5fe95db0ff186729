// The threaded online pipeline with a scripted estimator: measurement order, dropping the oldest
// frames when behind, waiting for the gyro, latency, errors and shutdown. Blocking is controlled
// by gates, never by timing assumptions.
#include "apps/online_pipeline.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "common/error.hpp"

namespace ovo::app {
namespace {

using namespace std::chrono_literals;

// Records every call in order; addImage can be held at a gate and can throw.
class ScriptedEstimator final : public estimator::Estimator {
 public:
  struct Call {
    char kind;  // 'g' gyro, 's' scan, 'i' image
    Timestamp t_ns;
  };

  std::string name() const override { return "scripted"; }
  void addGyro(const ImuSample& s) override { record('g', s.t_ns); }
  void addScan(const LidarScan& s) override { record('s', s.t_ns); }
  estimator::FrameEstimate addImage(Timestamp t_ns, const cv::Mat& grey) override {
    record('i', t_ns);
    {
      std::unique_lock lock(mutex_);
      last_type_ = grey.type();
      ++images_entered_;
      changed_.notify_all();
      changed_.wait(lock, [&] { return gate_open_; });
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
  void waitImagesEntered(int n) {
    std::unique_lock lock(mutex_);
    ASSERT_TRUE(changed_.wait_for(lock, 10s, [&] { return images_entered_ >= n; }));
  }
  std::vector<Call> calls() const {
    std::lock_guard lock(mutex_);
    return calls_;
  }

  std::chrono::milliseconds work_{0};
  Timestamp throw_at_ = -1;
  int finish_calls_ = 0;
  int last_type_ = -1;

 private:
  void record(char kind, Timestamp t) {
    std::lock_guard lock(mutex_);
    calls_.push_back({kind, t});
  }
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool gate_open_ = true;
  int images_entered_ = 0;
  std::vector<Call> calls_;
};

cv::Mat greyImage() { return cv::Mat(24, 32, CV_8UC1, cv::Scalar(100)); }

constexpr Timestamp kMs = 1'000'000;

TEST(OnlinePipeline, FeedsGyroAndScansInTimeOrderBeforeTheImageTheyPrecede) {
  ScriptedEstimator est;
  OnlineOptions options;
  options.image_queue_depth = 1000;  // nothing dropped here
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
  EXPECT_EQ(gyro.size(), 201u);  // every sample exactly once, the tail after stop()
  EXPECT_EQ(images.size(), 20u);
  EXPECT_EQ(outputs, images);
  EXPECT_EQ(est.finish_calls_, 1);
  const OnlineStats s = pipeline.stats();
  EXPECT_EQ(s.frames_in, 20);
  EXPECT_EQ(s.frames_processed, 20);
  EXPECT_EQ(s.frames_dropped, 0);
  EXPECT_EQ(s.gyro_in, 201);
  EXPECT_EQ(s.scans_in, 10);
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
  EXPECT_EQ(dropped_seen.back(), 17);
  EXPECT_EQ(s.latency_ms.size(), 3u);
}

TEST(OnlinePipeline, AFrameWaitsForTheGyroSampleAfterItsTime) {
  ScriptedEstimator est;
  OnlineOptions options;
  options.gyro_wait_ms = 60'000;  // wait for the gyro, however long
  std::mutex m;
  std::condition_variable cv;
  int outputs = 0;
  OnlinePipeline pipeline(est, options, [&](const OnlineOutput&) {
    std::lock_guard lock(m);
    ++outputs;
    cv.notify_all();
  });
  pipeline.start();
  pipeline.addGyro({0, Vec3::Zero(), Vec3::Zero()});
  pipeline.addImage(10 * kMs, greyImage());
  std::this_thread::sleep_for(50ms);  // give the pipeline a chance to (wrongly) go ahead
  pipeline.addGyro({15 * kMs, Vec3::Zero(), Vec3::Zero()});
  {
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, 10s, [&] { return outputs == 1; }));
  }
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
  std::mutex m;
  std::condition_variable cv;
  int outputs = 0;
  OnlinePipeline pipeline(est, options, [&](const OnlineOutput&) {
    std::lock_guard lock(m);
    ++outputs;
    cv.notify_all();
  });
  pipeline.start();
  pipeline.addGyro({0, Vec3::Zero(), Vec3::Zero()});
  pipeline.addImage(10 * kMs, greyImage());
  {
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, 10s, [&] { return outputs == 1; }));
  }
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

}  // namespace
}  // namespace ovo::app
