// ovo::Odometry (api/ovo.hpp) over the estimator interface (estimator/estimator.hpp): offline, the
// measurements go to the estimator in the order the offline runner uses (estimator::
// feedUntilImage: an image after the gyro up to and including the first sample at or after the
// estimator's measurementsUntil(its time), scans up to that time before it); live, through the
// threaded app::OnlinePipeline.
#include <cmath>
#include <deque>
#include <limits>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <variant>

#include "api/ovo.hpp"
#include "apps/offline_runner.hpp"
#include "apps/online_pipeline.hpp"
#include "apps/run_budget.hpp"
#include "camera/calib_io.hpp"
#include "common/config.hpp"
#include "common/error.hpp"
#include "common/so3.hpp"
#include "estimator/estimator.hpp"
#include "io/bag_dataset.hpp"
#include "io/dataset.hpp"

namespace ovo {

namespace {

Pose toPose(const StampedPose& p, bool tracked, bool keyframe) {
  Pose out;
  out.t_ns = p.t_ns;
  const Vec3 t = p.T_W_B.translation();
  const Quat q(p.T_W_B.linear());
  out.position_m = {t.x(), t.y(), t.z()};
  out.orientation_xyzw = {q.x(), q.y(), q.z(), q.w()};
  out.tracked = tracked;
  out.is_keyframe = keyframe;
  return out;
}

Pose toPose(const estimator::FrameEstimate& f) {
  return toPose({f.t_ns, f.T_W_B}, f.tracked, f.is_keyframe);
}

/// Poses further apart than this give no twist (a gap: the change is no velocity).
constexpr Timestamp kMaxTwistGapNs = 1'000'000'000;

/// p's twist in its body frame from the previous pose of its stream: v_B = R^T (p - p_prev) / dt,
/// w_B = Log(R_prev^T R) / dt.
void setTwist(Pose& p, const Pose& prev) {
  const Timestamp dt_ns = p.t_ns - prev.t_ns;
  if (dt_ns <= 0 || dt_ns > kMaxTwistGapNs) return;
  const double dt = toSeconds(dt_ns);
  const auto rotation = [](const Pose& x) {
    const auto& q = x.orientation_xyzw;
    return Quat(q[3], q[0], q[1], q[2]).normalized().toRotationMatrix();
  };
  const Mat3 R = rotation(p), R_prev = rotation(prev);
  const Vec3 dp = Vec3(p.position_m[0], p.position_m[1], p.position_m[2]) -
                  Vec3(prev.position_m[0], prev.position_m[1], prev.position_m[2]);
  const Vec3 v = R.transpose() * dp / dt;
  const Vec3 w = so3::log(R_prev.transpose() * R) / dt;
  p.velocity_body_mps = {v.x(), v.y(), v.z()};
  p.angular_velocity_body_radps = {w.x(), w.y(), w.z()};
}

bool finite(const Scan& s) {
  return std::isfinite(s.angle_min_rad) && std::isfinite(s.angle_increment_rad) &&
         std::isfinite(s.time_increment_s) && !std::isnan(s.range_min_m) &&
         !std::isnan(s.range_max_m);
}

estimator::SensorSetup setupFromRig(const std::filesystem::path& rig_file,
                                    const OdometryOptions& options) {
  const io::RigInfo rig = io::readRigYaml(rig_file);
  const std::filesystem::path calib = io::rigCameraCalibration(rig, rig_file);
  std::optional<SE3> T_B_C_calib;
  if (calib.extension() == ".yaml") T_B_C_calib = camera::readSensorYamlExtrinsics(calib);
  estimator::SensorSetup setup = app::sensorSetupFromRig(
      rig, camera::loadCamera(calib), io::cameraExtrinsics(rig, T_B_C_calib, rig_file));
  setup.has_gyro = options.use_gyro;
  setup.has_lidar = options.use_lidar;
  estimator::applyNoiseFloors(setup);
  return setup;
}

LidarScan toScan(const Scan& s) {
  LidarScan out;
  out.t_ns = s.t_ns;
  out.angle_min_rad = s.angle_min_rad;
  out.angle_increment_rad = s.angle_increment_rad;
  out.range_min_m = s.range_min_m;
  out.range_max_m = s.range_max_m;
  out.time_increment_s = s.time_increment_s;
  out.ranges_m.reserve(s.ranges_m.size());
  for (float r : s.ranges_m)
    out.ranges_m.push_back(std::isfinite(r) ? r : std::numeric_limits<double>::quiet_NaN());
  return out;
}

cv::Mat toGrey(const cv::Mat& image, const camera::Camera& cam) {
  cv::Mat grey;
  if (image.type() == CV_8UC1)
    grey = image.clone();
  else if (image.type() == CV_8UC3)
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else if (image.type() == CV_8UC4)
    cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  else
    fail("Odometry::addImage: expected an 8-bit grey, BGR or BGRA image");
  if (grey.cols != camera::width(cam) || grey.rows != camera::height(cam))
    fail("Odometry::addImage: the image is {}x{}, the camera calibration is for {}x{}", grey.cols,
         grey.rows, camera::width(cam), camera::height(cam));
  return grey;
}

}  // namespace

struct Odometry::Impl {
  explicit Impl(estimator::SensorSetup s)
      : setup(std::move(s)), image_shift_ns(fromSeconds(setup.time_offset_s)) {}
  estimator::SensorSetup setup;
  // The rig's camera.time_offset_s: an image's stamp less this is its time on the gyro clock,
  // the time the estimator is given; the poses go out at the stamps as given.
  Timestamp image_shift_ns = 0;
  std::unique_ptr<estimator::Estimator> est;
  PoseCallback on_pose;
  bool finished = false;
  std::optional<app::OnlinePipeline> pipeline;  // realtime

  // Offline: images and scans waiting for the gyro sample at or after the image time.
  using Item = std::variant<std::pair<Timestamp, cv::Mat>, LidarScan>;
  std::deque<Item> waiting;
  bool any_image = false, any_gyro = false, any_scan = false;
  Timestamp last_image = 0, last_gyro = 0, last_scan = 0;
  mutable std::mutex mutex;
  std::vector<Pose> poses;  // as update() returned them (the recent past without the trajectory)
  bool keep_trajectory = true;
  Status status;  // under mutex; frames_dropped and error are read from the pipeline

  void process(const Item& item) {
    if (const auto* scan = std::get_if<LidarScan>(&item)) {
      est->addScan(*scan);
      return;
    }
    const auto& [t, grey] = std::get<std::pair<Timestamp, cv::Mat>>(item);
    deliver(est->addImage(t, grey));
  }
  // On the thread that runs the estimator (the caller's offline, the pipeline's live).
  void deliver(const estimator::FrameEstimate& f) {
    Pose p = toPose(f);
    p.t_ns += image_shift_ns;
    // The estimator's counters when they may have changed: a keyframe's solve, a change of state.
    std::optional<estimator::EstimatorStats> stats;
    if (f.is_keyframe || status.frames_processed == 0 || f.tracked != status.tracking)
      stats = est->stats();
    {
      std::lock_guard lock(mutex);
      ++status.frames_processed;
      status.tracking = f.tracked;
      status.reason = f.tracked ? std::string() : f.status;
      status.frame_ms = f.frontend_ms + f.estimator_ms;
      if (f.is_keyframe) status.solve_ms = f.estimator_ms;
      if (stats) {
        status.tracking_losses = stats->tracking_losses;
        status.solve_failures = stats->solve_failures;
        status.time_offset_s = setup.time_offset_s + stats->time_offset_s.value_or(0.0);
        status.time_offset_estimated = stats->time_offset_s.has_value();
      }
      p.t_gyro_clock_ns = f.t_ns - fromSeconds(status.time_offset_s - setup.time_offset_s);
      if (!poses.empty()) setTwist(p, poses.back());
      poses.push_back(p);
      if (!keep_trajectory)
        estimator::trimHistory(poses, p.t_ns - fromSeconds(estimator::kRecentHistoryS),
                               [](const Pose& q) { return q.t_ns; });
    }
    if (on_pose) on_pose(p);
  }
  // A measurement not taken (status().refused).
  bool refuse() {
    std::lock_guard lock(mutex);
    ++status.refused;
    return false;
  }
  // Offline: processes the waiting items in order up to the first image whose measurements run
  // past `t_gyro` (all images when nullopt). Scans after the last image wait for the next one; at
  // the end they are dropped, as the offline runner never feeds them.
  void drain(std::optional<Timestamp> t_gyro) {
    std::size_t images = 0;
    for (const Item& item : waiting)
      images += std::holds_alternative<std::pair<Timestamp, cv::Mat>>(item);
    while (images > 0) {
      const Item& front = waiting.front();
      if (const auto* image = std::get_if<std::pair<Timestamp, cv::Mat>>(&front)) {
        if (t_gyro && est->measurementsUntil(image->first) > *t_gyro) return;
        --images;
      }
      process(front);
      waiting.pop_front();
    }
  }
};

Odometry::Odometry(const std::string& rig_file, const OdometryOptions& options,
                   PoseCallback on_pose)
    : impl_(std::make_unique<Impl>(setupFromRig(rig_file, options))) {
  Config config;
  if (!options.config_file.empty()) config = Config::load(options.config_file);
  config.applyOverrides(options.settings);
  app::applyBudget(config, options.budget, options.estimator);
  if (options.realtime) app::applyOnlineSolveBudget(config, options.estimator);
  impl_->est = estimator::makeEstimator(options.estimator, impl_->setup, config);
  impl_->est->keepHistory(options.keep_trajectory);
  impl_->keep_trajectory = options.keep_trajectory;
  config.checkAllUsed();
  impl_->on_pose = std::move(on_pose);
  impl_->status.time_offset_s = impl_->setup.time_offset_s;
  if (options.realtime) {
    app::OnlineOptions online;
    if (!options.keep_trajectory) online.latency_history = app::kLongRunLatencyHistory;
    impl_->pipeline.emplace(*impl_->est, online, [impl = impl_.get()](const app::OnlineOutput& o) {
      impl->deliver(o.estimate);
    });
    impl_->pipeline->start();
  }
}

Odometry::~Odometry() {
  try {
    if (impl_->pipeline) impl_->pipeline->stop();
  } catch (...) {  // the error was the caller's to get from finish()
  }
}

bool Odometry::addImage(std::int64_t t_ns, const cv::Mat& image) {
  Impl& m = *impl_;
  if (m.finished || (m.any_image && t_ns <= m.last_image)) return m.refuse();
  cv::Mat grey = toGrey(image, m.setup.camera);
  m.any_image = true;
  m.last_image = t_ns;
  const Timestamp t_gyro_clock = t_ns - m.image_shift_ns;
  if (m.pipeline) return m.pipeline->addImage(t_gyro_clock, grey) || m.refuse();
  m.waiting.emplace_back(std::pair<Timestamp, cv::Mat>(t_gyro_clock, std::move(grey)));
  if (!m.setup.has_gyro || (m.any_gyro && m.last_gyro >= m.est->measurementsUntil(t_gyro_clock)))
    m.drain(std::nullopt);
  return true;
}

bool Odometry::addGyro(const GyroSample& sample) {
  Impl& m = *impl_;
  const ImuSample s{sample.t_ns, Vec3(sample.wx, sample.wy, sample.wz),
                    Vec3(sample.ax, sample.ay, sample.az)};
  if (m.finished || (m.any_gyro && s.t_ns <= m.last_gyro) || !s.gyro_radps.allFinite() ||
      !s.accel_mps2.allFinite())
    return m.refuse();
  m.any_gyro = true;
  m.last_gyro = s.t_ns;
  if (m.pipeline) return m.pipeline->addGyro(s) || m.refuse();
  if (!m.setup.has_gyro) return true;
  // Images waiting since before this sample: the sample is the first at or after them.
  m.est->addGyro(s);
  m.drain(sample.t_ns);
  return true;
}

bool Odometry::addScan(const Scan& scan) {
  Impl& m = *impl_;
  if (m.finished || (m.any_scan && scan.t_ns <= m.last_scan) || !finite(scan)) return m.refuse();
  m.any_scan = true;
  m.last_scan = scan.t_ns;
  LidarScan s = toScan(scan);
  if (m.pipeline) return m.pipeline->addScan(s) || m.refuse();
  if (!m.setup.has_lidar) return true;
  // Before the first waiting image whose measurements reach its time, after the gyro that image
  // waits for (as the offline runner feeds scans).
  auto it = m.waiting.begin();
  while (it != m.waiting.end()) {
    const auto* image = std::get_if<std::pair<Timestamp, cv::Mat>>(&*it);
    if (image && m.est->measurementsUntil(image->first) >= s.t_ns) break;
    ++it;
  }
  m.waiting.insert(it, std::move(s));
  return true;
}

void Odometry::finish() {
  Impl& m = *impl_;
  if (m.finished) return;
  m.finished = true;
  if (m.pipeline) {
    m.pipeline->stop();  // finishes the estimator
    return;
  }
  m.drain(std::nullopt);
  m.waiting.clear();
  m.est->finish();
}

std::vector<Pose> Odometry::trajectory() const {
  const Impl& m = *impl_;
  if (!m.finished) {
    std::lock_guard lock(m.mutex);
    return m.poses;
  }
  // The estimator's final poses (a refinement may have moved them), with the frames' flags.
  std::vector<Pose> out;
  std::lock_guard lock(m.mutex);
  const Trajectory final_poses = m.est->trajectory();
  // Final poses are at gyro-clock times: the image stamps less the rig's time offset and the
  // window's estimate on top of it.
  const Timestamp shift =
      fromSeconds(m.est->stats().time_offset_s.value_or(0.0)) + m.image_shift_ns;
  std::size_t j = 0;
  for (const StampedPose& p : final_poses) {
    const Timestamp image_t = p.t_ns + shift;
    while (j < m.poses.size() && m.poses[j].t_ns < image_t) ++j;
    const bool known = j < m.poses.size() && m.poses[j].t_ns == image_t;
    out.push_back(toPose(p, known && m.poses[j].tracked, known && m.poses[j].is_keyframe));
    out.back().t_gyro_clock_ns = p.t_ns;
    if (out.size() > 1) setTwist(out.back(), out[out.size() - 2]);
  }
  return out;
}

int Odometry::framesProcessed() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->status.frames_processed;
}

int Odometry::framesDropped() const {
  return impl_->pipeline ? impl_->pipeline->framesDropped() : 0;
}

Pose Odometry::cameraInBody() const { return toPose({0, impl_->setup.T_B_C}, true, false); }

Pose Odometry::lidarInBody() const { return toPose({0, impl_->setup.T_B_L}, true, false); }

Status Odometry::status() const {
  Status s;
  {
    std::lock_guard lock(impl_->mutex);
    s = impl_->status;
  }
  if (impl_->pipeline) {
    s.frames_dropped = impl_->pipeline->framesDropped();
    s.error = impl_->pipeline->error();
  }
  return s;
}

}  // namespace ovo
