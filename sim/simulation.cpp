#include "sim/simulation.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
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
  time_offset_ns_ = fromSeconds(s.camera.time_offset_s);
  if (s.camera.auto_exposure) computeAutoExposure();
}

void Simulation::computeAutoExposure() {
  // The meter: the mean radiance of every 16th pixel across and down (each frame's on its own,
  // in parallel), times the light's gain and the auto-exposure's gain. The controller steps the
  // gain for the next frame when the metered brightness is off the first frame's by more than
  // three quarters of a step, at most auto_exposure_rate_hz times a second.
  const CameraOptions& c = scenario_.camera;
  std::vector<double> meter(frames_);
  tbb::parallel_for(0, frames_, [&](int k) {
    const double t = frameTime(k);
    meter[k] =
        exposureGain(t) * renderer_->meanRadiance(*world_, trajectory_.T_W_B(t) * T_B_C_, t, 16);
  });
  auto_exposure_.assign(frames_, 1.0);
  const double deadband = 0.75 * std::log1p(c.auto_exposure_step);
  const double target = std::max(frames_ > 0 ? meter[0] : 1.0, 1e-6);
  double gain = 1.0, last_step_s = -1e30;
  for (int k = 0; k < frames_; ++k) {
    auto_exposure_[k] = gain;
    const double error = std::log(std::max(meter[k] * gain, 1e-9) / target);
    const double t = frameTime(k);
    if (std::abs(error) > deadband && t - last_step_s >= 1.0 / c.auto_exposure_rate_hz - 1e-9) {
      gain =
          error > 0.0 ? gain / (1.0 + c.auto_exposure_step) : gain * (1.0 + c.auto_exposure_step);
      last_step_s = t;
    }
  }
}

double Simulation::autoExposureGain(int k) const {
  return auto_exposure_.empty() ? 1.0 : auto_exposure_.at(k);
}

double Simulation::rowTime(int k, int v) const {
  return frameTime(k) + scenario_.camera.rolling_shutter_s * v / renderer_->height();
}

bool Simulation::frameDropped(int k) const {
  const double p = scenario_.camera.frame_drop_probability;
  if (p <= 0.0) return false;
  Rng rng(subSeed(subSeed(scenario_.seed, 12), static_cast<std::uint64_t>(k)));
  return rng.uniform() < p;
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
  const double readout = scenario_.camera.rolling_shutter_s;
  // The frame's view at time ti: at once, or row v at ti + v / rows * readout (rolling shutter).
  const auto render = [&](double ti) {
    if (readout <= 0.0)
      return renderer_->renderRadiance(*world_, trajectory_.T_W_B(ti) * T_B_C_, ti);
    const int rows = renderer_->height();
    std::vector<SE3> poses(rows);
    std::vector<double> times(rows);
    for (int v = 0; v < rows; ++v) {
      times[v] = ti + readout * v / rows;
      poses[v] = trajectory_.T_W_B(times[v]) * T_B_C_;
    }
    return renderer_->renderRadiance(*world_, poses, times);
  };
  cv::Mat radiance;
  if (n.motion_blur && n.exposure_time_s > 0.0) {
    radiance = cv::Mat::zeros(renderer_->height(), renderer_->width(), CV_32F);
    for (int i = 0; i < n.blur_samples; ++i) {
      const double ti = t + n.exposure_time_s * ((i + 0.5) / n.blur_samples - 0.5);
      radiance += render(ti);
    }
    radiance /= n.blur_samples;
  } else {
    radiance = render(t);
  }
  const float gain = auto_exposure_.empty()
                         ? static_cast<float>(255.0 * exposureGain(t))
                         : static_cast<float>(255.0 * exposureGain(t) * auto_exposure_[k]);
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
  const double dt_beam = scenario_.lidar.timeIncrementS();
  tbb::parallel_for(std::size_t{0}, stamps.size(), [&](std::size_t i) {
    const double t = stamps[i];
    const Timestamp t_ns = frameTrueStamp(static_cast<int>(i) * every);
    const std::uint64_t seed = subSeed(scenario_.seed, 2'000'000 + i);
    if (dt_beam > 0.0) {
      scans[i] = simulateSweptScan(
          *world_, [&](double tb) { return trajectory_.T_W_B(tb) * T_B_L_; }, t, t_ns, dt_beam,
          scenario_.lidar, seed);
    } else {
      scans[i] =
          simulateScan(*world_, trajectory_.T_W_B(t) * T_B_L_, t, t_ns, scenario_.lidar, seed);
    }
  });
  return scans;
}

ovo::Trajectory Simulation::groundTruth() const {
  std::vector<Timestamp> stamps;
  stamps.reserve(2 * frames_);
  for (int k = 0; k < frames_; ++k) {
    stamps.push_back(frameTrueStamp(k));
    if (time_offset_ns_ != 0) stamps.push_back(frameStamp(k));
  }
  std::sort(stamps.begin(), stamps.end());
  stamps.erase(std::unique(stamps.begin(), stamps.end()), stamps.end());
  ovo::Trajectory gt;
  gt.reserve(stamps.size());
  for (Timestamp t_ns : stamps) {
    const double t = static_cast<double>(t_ns - scenario_.start_time_ns) * 1e-9;
    gt.push_back({t_ns, trajectory_.T_W_B(t)});
  }
  return gt;
}

std::optional<Vec3> Simulation::castRay(const SE3& T_W_C, const Vec3& d_C, double t_s,
                                        double max_range_m) const {
  const Vec3 d_W = T_W_C.linear() * d_C.normalized();
  const auto t = world_->firstOpaqueHit(T_W_C.translation(), d_W, max_range_m, t_s);
  if (!t) return std::nullopt;
  return Vec3(T_W_C.translation() + *t * d_W);
}

std::optional<Vec3> Simulation::castPixel(const SE3& T_W_C, const Vec2& px, double t_s,
                                          double max_range_m) const {
  const auto b = camera::unproject(camera_, px);
  if (!b) return std::nullopt;
  return castRay(T_W_C, *b, t_s, max_range_m);
}

double Simulation::cameraHeightM() const {
  const Vec3 p_W = (trajectory_.T_W_B(0.0) * T_B_C_).translation();
  if (!world_->heightField())
    return world_->groundNormal().dot(p_W);  // the terrain plane passes through W's origin
  // Uneven ground: above the ground's tangent plane below the body.
  Vec3 ground, normal;
  trajectory_.groundContact(0.0, &ground, &normal);
  return normal.dot(p_W - ground);
}

}  // namespace ovo::sim
