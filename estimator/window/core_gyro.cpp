// The window core's gyro side, on its GyroFront: what the samples are trimmed to (what a later
// interval may start from), their shift onto the images' timeline by the estimated time offset,
// the preintegrations built from them (the frame's prediction, a keyframe's gyro factor and its
// refresh when the offset moves or late samples fill a gap), and the output's way back onto the
// gyro clock.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "common/so3.hpp"
#include "estimator/window/core.hpp"

namespace ovo::estimator {
namespace {

// Seconds of the last velocity that the prediction carries the robot over a gap of dt: all of it
// up to kFullCoastS (dropped frames), then decaying by decay_per_s (the fraction kept per s).
// Nothing measures the motion over a long gap; coasting through an hour at 0.8 m/s would put the
// robot 2.9 km away.
constexpr double kFullCoastS = 1.0;
double coastSeconds(double dt, double decay_per_s) {
  if (dt <= kFullCoastS || decay_per_s >= 1.0) return dt;
  if (decay_per_s <= 0.0) return kFullCoastS;
  return kFullCoastS + (1.0 - std::pow(decay_per_s, dt - kFullCoastS)) / -std::log(decay_per_s);
}

}  // namespace

void WindowCore::addGyro(const ImuSample& sample) {
  if (!options_.use_gyro) return;
  if (gyro_.add(sample) == GyroFront::Intake::kSpike)
    note(fmt::format(
        "gyro: samples whose rate jumped by more than {} rad/s in one sample were left out as "
        "spikes",
        options_.gyro_max_jump_radps));
}

std::optional<Mat3> WindowCore::gyroRotation(Timestamp t0, Timestamp t1) const {
  const auto pi = preintegrate(t0, t1, bias_);
  if (!pi || pi->status() != factors::GyroPreintegration::Status::kOk) return std::nullopt;
  return pi->deltaR();
}

Timestamp WindowCore::gyroShift() const {
  return estimatesTimeOffset(model_) ? fromSeconds(map_.time_offset_s[0]) : 0;
}

Timestamp WindowCore::measurementsUntil(Timestamp t_image) const {
  // Within the scans' tolerance of zero, the image time as it is (the feed of a camera whose
  // offset was not found to be negative, unchanged).
  const Timestamp shift = gyroShift(), tol = fromSeconds(options_.lidar_scan_time_tol_s);
  if (shift >= -tol) return t_image;
  return t_image - shift + tol;
}

std::optional<factors::GyroPreintegration> WindowCore::preintegrate(Timestamp t0, Timestamp t1,
                                                                    const Vec3& bias) const {
  // The image stamps run ahead of the gyro clock by the time offset: the gyro saw [t0, t1]
  // that much earlier.
  if (!use_gyro_) return std::nullopt;
  return gyro_.preintegrate(t0, t1, bias, gyroShift());
}

std::optional<factors::AccelInterval> WindowCore::accelInterval(Timestamp t0, Timestamp t1,
                                                                const Vec3& bias) const {
  if (!use_gyro_ || !usesAccel(model_)) return std::nullopt;
  const Timestamp shift = gyroShift();
  return factors::integrateAccel(gyro_.around(t0 - shift, t1 - shift), t0 - shift, t1 - shift,
                                 bias);
}

void WindowCore::setGravity() {
  if (map_.gravity_set || !usesAccel(model_)) return;
  for (const auto& kf : map_.keyframes) {
    if (!kf->accel_from_prev) continue;
    // The specific force's mean over the interval (the two weights add up to one), in the
    // keyframe's frame (the rise is in it, the fall in the previous keyframe's: near enough for a
    // start).
    const factors::AccelInterval& a = *kf->accel_from_prev;
    const Vec3 f_B = (a.rise_B1 + a.fall_B0) / a.dt_s;
    if (!(f_B.norm() > 1.0)) continue;
    factors::setGravityDirection(-(kf->bodyPose().linear() * f_B), map_.gravity);
    map_.gravity_set = true;
    note(fmt::format("window: gravity set from the accelerometer at keyframe {}", kf->id));
    return;
  }
}

std::optional<factors::GyroPreintegration> WindowCore::preintegrateOnGyroClock(
    Timestamp t0, Timestamp t1, const Vec3& bias) const {
  if (!use_gyro_) return std::nullopt;
  return gyro_.preintegrate(t0, t1, bias);
}

std::optional<Mat3> WindowCore::predictRotationCurPrev(Timestamp t_ns) const {
  if (!have_last_) return std::nullopt;
  auto pi = preintegrate(last_t_, t_ns, bias_);
  if (!pi || pi->status() == factors::GyroPreintegration::Status::kNoData) return std::nullopt;
  const Mat3 R_B_C = setup_.T_B_C.linear();
  return R_B_C.transpose() * pi->deltaR().transpose() * R_B_C;
}

void WindowCore::carryGyroRotation(const Keyframe& kf, FrameEstimate& e) {
  if (!options_.frame_rotation_from_gyro) return;
  const auto pi = preintegrate(kf.t_ns, e.t_ns, kf.bias());
  if (!pi || pi->status() != factors::GyroPreintegration::Status::kOk) return;
  // The rates at the span's two ends, over the last 10 ms before each.
  constexpr Timestamp kSpan = 10'000'000;
  frame_gyro_ = GyroSpan{pi->deltaR(),
                         pi->biasJacobian(),
                         pi->biasLinearization(),
                         toSeconds(gyroShift()),
                         gyroRateBefore(kf.t_ns, kSpan, kf.bias()),
                         gyroRateBefore(e.t_ns, kSpan, kf.bias())};
  e.T_W_B.linear() = so3::orthonormalize(kf.bodyPose().linear() * pi->deltaR());
}

void WindowCore::trimGyro() {
  // What a later preintegration starts from: the last frame (the next prediction, standstill
  // test, zero-rate update, and a scan up to lidar_scan_max_age_s older), the newest keyframe (the
  // next keyframe's gyro factor), a keyframe whose preintegration still waits for samples, and
  // the references the window may start from (and the scans before them: the initialiser takes
  // the reference's scan, up to lidar_scan_max_age_s older); at most kGyroKeepS back.
  Timestamp keep = last_t_;
  if (!map_.empty()) keep = std::min(keep, map_.keyframes.back()->t_ns);
  // With the time offset estimated: every keyframe of the window (its interval is integrated
  // again when the offset moves), as far back as the offset may reach.
  if (!map_.empty() && estimatesTimeOffset(model_))
    keep = std::min(keep, map_.keyframes.front()->t_ns - fromSeconds(options_.time_offset_max_s));
  for (std::size_t k = 1; k < map_.keyframes.size(); ++k) {
    const auto& pi = map_.keyframes[k]->preint_from_prev;
    if (pi && pi->status() != factors::GyroPreintegration::Status::kOk)
      keep = std::min(keep, map_.keyframes[k - 1]->t_ns);
  }
  if (reference_) keep = std::min(keep, reference_->t_ns);
  if (still_reference_) keep = std::min(keep, still_reference_->t_ns);
  keep -= fromSeconds(options_.lidar_scan_max_age_s + 0.1);
  keep = std::max(keep, last_t_ - fromSeconds(kGyroKeepS));
  gyro_.dropBefore(keep);
}

void WindowCore::refreshGyroFactors() {
  if (!use_gyro_) return;
  for (std::size_t k = 1; k < map_.keyframes.size(); ++k) {
    Keyframe& kf = *map_.keyframes[k];
    const Keyframe& prev = *map_.keyframes[k - 1];
    auto& pi = kf.preint_from_prev;
    if (!pi) continue;
    // The keyframe's accelerometer interval is made again with its gyro factor, from the same
    // samples at the same bias: when the time offset moved (a camera 40 ms early would otherwise
    // compare the positions with the specific force of another 40 ms), and when late samples
    // fill the interval.
    const auto remakeAccel = [&] {
      kf.accel_from_prev = accelInterval(prev.t_ns, kf.t_ns, pi->biasLinearization());
    };
    const Timestamp shift = gyroShift();
    // The time offset has moved on since the preintegration was made: its factor's first-order
    // shift (the rates at the ends held) is good for a few ms of angular acceleration, so the
    // interval is integrated again while the buffer still holds it.
    const bool shifted = std::abs(toSeconds(prev.t_ns - pi->tStart() - shift)) > kReshiftS;
    if (shifted && gyro_.reaches(prev.t_ns - shift) && gyro_.covers(kf.t_ns - shift)) {
      if (auto again = preintegrate(prev.t_ns, kf.t_ns, pi->biasLinearization()))
        pi = std::make_shared<factors::GyroPreintegration>(std::move(*again));
      remakeAccel();
      continue;
    }
    if (pi->status() == factors::GyroPreintegration::Status::kOk || !gyro_.covers(kf.t_ns - shift))
      continue;
    // Samples that came late (the online mode's gyro queue behind the frames): the gap the
    // preintegration was made with may be filled now.
    auto again = preintegrate(prev.t_ns, kf.t_ns, pi->biasLinearization());
    if (again && again->status() == factors::GyroPreintegration::Status::kOk) {
      pi = std::make_shared<factors::GyroPreintegration>(std::move(*again));
      remakeAccel();
    }
  }
}

Vec3 WindowCore::gyroRateBefore(Timestamp t_ns, Timestamp span, const Vec3& bias) const {
  const auto pi = preintegrate(t_ns - span, t_ns, bias);
  if (!pi || pi->status() == factors::GyroPreintegration::Status::kNoData) return Vec3::Zero();
  return so3::log(pi->deltaR()) / toSeconds(span);
}

Readout WindowCore::readoutAt(Timestamp t_ns, const SE3& T_W_B, const Vec3& bias) const {
  Readout r;
  if (!(model_.rolling_shutter_s > 0.0)) return r;
  r.rate_B = gyroRateBefore(t_ns, fromSeconds(std::max(model_.rolling_shutter_s, 0.02)), bias);
  r.velocity_B = T_W_B.linear().transpose() * velocity_W_;
  return r;
}

WindowCore::Prediction WindowCore::predict(Timestamp t_ns) {
  Prediction pred;
  pred.t_ns = t_ns;
  pred.dt = toSeconds(t_ns - last_t_);
  pred.T_W_B = last_T_W_B_;
  pred.rot_sigma = options_.rotation_prior_sigma_rad;
  if (auto pi = preintegrate(last_t_, t_ns, bias_)) {
    pred.T_W_B.linear() = so3::orthonormalize(last_T_W_B_.linear() * pi->deltaR());
    pred.rot_sigma = std::sqrt(pi->covariance().trace() / 3.0 + pred.rot_sigma * pred.rot_sigma);
    pred.rate_radps = so3::angle(pi->deltaR()) / pred.dt;
    pred.rotation_prior = pi->status() != factors::GyroPreintegration::Status::kNoData;
    // A camera stamped early (a negative time offset) needs gyro samples past its stamp, which
    // are not all there yet: the preintegration holds the last rate over that end, no gap.
    double not_yet_s = 0.0;
    if (gyro_.covers(t_ns))
      not_yet_s = std::max(0.0, toSeconds(t_ns - gyroShift() - gyro_.samples().back().t_ns));
    if (pi->status() != factors::GyroPreintegration::Status::kOk &&
        pi->gapSeconds() > not_yet_s + 1e-6) {
      if (!in_gap_) ++stats_.gyro_gaps;
      in_gap_ = true;
    } else {
      in_gap_ = false;
    }
  }
  pred.T_W_B.translation() = last_T_W_B_.translation() +
                             velocity_W_ * coastSeconds(pred.dt, options_.velocity_decay_per_s);
  return pred;
}

Trajectory WindowCore::ontoGyroClock(Trajectory poses) const {
  // The images' stamps run ahead of the gyro clock (the robot's, the truth's) by the offset
  // estimated on top of the rig's; the poses are output at the times the images were taken,
  // with the latest estimate.
  const Timestamp shift = gyroShift();
  for (auto& p : poses) p.t_ns -= shift;
  return poses;
}

}  // namespace ovo::estimator
