#include "sim/simulation.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>

#include "camera/calib_io.hpp"
#include "common/error.hpp"
#include "sim/lidar.hpp"
#include "sim/random.hpp"

namespace ovo::sim {

camera::Camera makeCamera(const CameraOptions& o) {
  if (o.model == "pinhole") {
    const double f = 0.5 * o.pinhole_width / std::tan(0.5 * o.pinhole_hfov_deg * M_PI / 180.0);
    return camera::PinholeRadtanCamera(f, f, 0.5 * (o.pinhole_width - 1),
                                       0.5 * (o.pinhole_height - 1), o.pinhole_width,
                                       o.pinhole_height);
  }
  if (o.calibration.empty())
    fail("camera.calibration: no calibration file given for camera model '{}'", o.model);
  return camera::loadCamera(o.calibration);
}

Simulation::Simulation(const Scenario& scenario)
    : Simulation(scenario, makeCamera(scenario.camera)) {}

Simulation::Simulation(const Scenario& scenario, const camera::Camera& camera)
    : scenario_(scenario), camera_(camera) {
  build();
}

void Simulation::build() {
  const Scenario& s = scenario_;
  world_ = std::make_unique<VineyardWorld>(s.world, s.seed);
  T_B_C_ = cameraMountTransform(s.camera.mount);
  T_B_L_ = lidarMountTransform(s.lidar.mount);
  double min_duration = 0.0;
  if (s.frames > 0) {
    min_duration = (s.frames - 1) / s.camera.rate_hz;
  } else if (s.duration_s > 0.0) {
    min_duration = s.duration_s;
  }
  trajectory_ = planTrajectory(s.trajectory, *world_, s.seed, min_duration);
  if (s.frames > 0) {
    frames_ = s.frames;
  } else {
    const double length = s.duration_s > 0.0 ? s.duration_s : trajectory_.duration();
    frames_ = static_cast<int>(std::floor(length * s.camera.rate_hz + 1e-9)) + 1;
  }
  Rng rng(subSeed(s.seed, 6));
  for (double& p : gain_phase_) p = rng.uniform(0.0, 2.0 * M_PI);
  // People crossing the inter-row a few metres ahead of the robot.
  std::vector<Walker> walkers;
  for (int i = 0; i < s.nuisance.people; ++i) {
    const double t_mid = rng.uniform(0.15, 0.85) * duration();
    const SE3 T_W_B = trajectory_.T_W_B(t_mid);
    const Vec3 ahead = T_W_B * Vec3(rng.uniform(3.0, 6.0), 0.0, 0.0);
    Vec2 across(T_W_B.linear()(0, 1), T_W_B.linear()(1, 1));
    across = across.normalized() * (rng.uniform() < 0.5 ? 1.0 : -1.0);
    const double speed = rng.uniform(1.0, 1.5);
    Walker w;
    w.t_begin_s = t_mid - 2.0 / speed;
    w.t_end_s = t_mid + 2.0 / speed;
    w.start_xy_W = Vec2(ahead.x(), ahead.y()) - 2.0 * across;
    w.velocity_xy_W = speed * across;
    w.shirt_tone = static_cast<float>(rng.uniform(0.15, 0.9));
    w.trousers_tone = static_cast<float>(rng.uniform(0.1, 0.4));
    walkers.push_back(w);
  }
  world_->setWalkers(std::move(walkers));
  renderer_ = std::make_unique<Renderer>(camera_, s.render);
}

Timestamp Simulation::frameOffsetNs(int k) const {
  return static_cast<Timestamp>(std::llround(k * 1e9 / scenario_.camera.rate_hz));
}

double Simulation::frameTime(int k) const { return static_cast<double>(frameOffsetNs(k)) * 1e-9; }

double Simulation::exposureGain(double t) const {
  const NuisanceOptions& n = scenario_.nuisance;
  if (!n.exposure_changes) return 1.0;
  const double w = 2.0 * M_PI / n.exposure_period_s;
  const double x = 0.5 * std::sin(w * t + gain_phase_[0]) +
                   0.3 * std::sin(1.73 * w * t + gain_phase_[1]) +
                   0.2 * std::sin(2.91 * w * t + gain_phase_[2]);
  return 1.0 + n.exposure_amplitude * x;
}

cv::Mat Simulation::renderFrame(int k) const {
  const NuisanceOptions& n = scenario_.nuisance;
  const double t = frameTime(k);
  cv::Mat radiance;
  if (n.motion_blur && n.exposure_time_s > 0.0) {
    radiance = cv::Mat::zeros(renderer_->height(), renderer_->width(), CV_32F);
    for (int i = 0; i < n.blur_samples; ++i) {
      const double ti = t + n.exposure_time_s * ((i + 0.5) / n.blur_samples - 0.5);
      radiance += renderer_->renderRadiance(*world_, trajectory_.T_W_B(ti) * T_B_C_, ti);
    }
    radiance /= n.blur_samples;
  } else {
    radiance = renderer_->renderRadiance(*world_, trajectory_.T_W_B(t) * T_B_C_, t);
  }
  const float gain = static_cast<float>(255.0 * exposureGain(t));
  cv::Mat out(radiance.rows, radiance.cols, CV_8U);
  const std::uint64_t frame_seed =
      subSeed(scenario_.seed, 1'000'000 + static_cast<std::uint64_t>(k));
  const cv::Mat& valid = renderer_->validMask();
  tbb::parallel_for(
      tbb::blocked_range<int>(0, radiance.rows, 8), [&](const tbb::blocked_range<int>& rows) {
        for (int v = rows.begin(); v < rows.end(); ++v) {
          Rng rng(subSeed(frame_seed, static_cast<std::uint64_t>(v)));
          const float* in = radiance.ptr<float>(v);
          const std::uint8_t* ok = valid.ptr<std::uint8_t>(v);
          std::uint8_t* o = out.ptr<std::uint8_t>(v);
          for (int u = 0; u < radiance.cols; ++u) {
            if (!ok[u]) {
              o[u] = 0;
              continue;
            }
            double g = gain * in[u];
            if (n.image_noise)
              g += std::sqrt(n.noise_sigma * n.noise_sigma + n.shot_noise * std::max(0.0, g)) *
                   rng.approxNormal();
            o[u] = static_cast<std::uint8_t>(std::clamp(std::lround(g), 0L, 255L));
          }
        }
      });
  return out;
}

std::vector<ImuSample> Simulation::imu(std::vector<GyroBiasSample>* true_gyro_bias) const {
  return simulateImu(trajectory_, scenario_.imu, duration(), scenario_.start_time_ns,
                     scenario_.seed, true_gyro_bias);
}

std::vector<LidarScan> Simulation::lidar() const {
  const int every =
      static_cast<int>(std::lround(scenario_.camera.rate_hz / scenario_.lidar.rate_hz));
  std::vector<double> stamps;
  for (int k = 0; k < frames_; k += every) stamps.push_back(frameTime(k));
  std::vector<LidarScan> scans(stamps.size());
  tbb::parallel_for(std::size_t{0}, stamps.size(), [&](std::size_t i) {
    const double t = stamps[i];
    scans[i] = simulateScan(*world_, trajectory_.T_W_B(t) * T_B_L_, t,
                            frameStamp(static_cast<int>(i) * every), scenario_.lidar,
                            subSeed(scenario_.seed, 2'000'000 + i));
  });
  return scans;
}

ovo::Trajectory Simulation::groundTruth() const {
  ovo::Trajectory gt;
  gt.reserve(frames_);
  for (int k = 0; k < frames_; ++k) gt.push_back({frameStamp(k), trajectory_.T_W_B(frameTime(k))});
  return gt;
}

double Simulation::cameraHeightM() const {
  const Vec3 p_W = (trajectory_.T_W_B(0.0) * T_B_C_).translation();
  return world_->groundNormal().dot(p_W);  // the terrain plane passes through W's origin
}

}  // namespace ovo::sim
