// The scan that goes with a frame, and the LiDAR's pose when it took it.
#include "estimator/window/scans.hpp"

#include <cstdlib>

namespace ovo::estimator {

void ScanTimeline::add(LidarScan scan, Timestamp keep_from_ns) {
  scan.t_ns += shift_;
  scans_.push_back(std::move(scan));
  while (scans_.size() > 2 && scans_.front().t_ns < keep_from_ns) scans_.erase(scans_.begin());
}

void ScanTimeline::setShift(Timestamp shift_ns) {
  for (LidarScan& s : scans_) s.t_ns += shift_ns - shift_;
  shift_ = shift_ns;
}

const LidarScan* ScanTimeline::at(Timestamp t_ns) const {
  const LidarScan* best = nullptr;
  for (const LidarScan& s : scans_)
    if (std::llabs(s.t_ns - t_ns) <= tol_ &&
        (!best || std::llabs(s.t_ns - t_ns) < std::llabs(best->t_ns - t_ns)))
      best = &s;
  return best;
}

std::optional<ScanChoice> ScanTimeline::choose(Timestamp t_ns, const GyroRotation& gyro) const {
  if (const LidarScan* s = at(t_ns)) return ScanChoice{s, std::nullopt};
  if (!(max_age_s_ > 0.0)) return std::nullopt;
  const LidarScan* latest = nullptr;  // the latest scan before the frame, within the age
  for (const LidarScan& s : scans_)
    if (s.t_ns < t_ns && t_ns - s.t_ns <= fromSeconds(max_age_s_)) latest = &s;
  if (latest == nullptr) return std::nullopt;
  const auto R = gyro(latest->t_ns, t_ns);
  if (!R) return std::nullopt;
  return ScanChoice{latest, *R};
}

std::optional<FrameScan> ScanTimeline::scanFor(Timestamp t_ns, const SE3& T_W_B, const Vec3& v_W,
                                               const FrameLog& frames, const SE3& T_B_L,
                                               const GyroRotation& gyro) const {
  const auto choice = choose(t_ns, gyro);
  if (!choice) return std::nullopt;
  if (!choice->R_Bscan_Bframe) return FrameScan{choice->scan, T_B_L};
  const LidarScan* latest = choice->scan;
  const Vec3 p_W_scan =
      frames.positionAt(latest->t_ns, t_ns, T_W_B.translation(),
                        T_W_B.translation() - v_W * toSeconds(t_ns - latest->t_ns));
  SE3 T_Bt_Bs = SE3::Identity();
  T_Bt_Bs.linear() = choice->R_Bscan_Bframe->transpose();
  T_Bt_Bs.translation() = T_W_B.linear().transpose() * (p_W_scan - T_W_B.translation());
  return FrameScan{latest, T_Bt_Bs * T_B_L};
}

bool ScanTimeline::expectedAfter(Timestamp t_ns, Timestamp last_t_ns) const {
  if (last_t_ns <= 0 || t_ns <= last_t_ns) return false;
  const Timestamp next_frame = t_ns + (t_ns - last_t_ns);
  std::optional<Timestamp> next_scan;
  for (const LidarScan& s : scans_)
    if (s.t_ns > t_ns + tol_) {
      next_scan = s.t_ns;
      break;
    }
  if (!next_scan && scans_.size() >= 2) {
    const Timestamp last = scans_.back().t_ns, period = last - scans_[scans_.size() - 2].t_ns;
    if (period > 0) next_scan = last + period;
  }
  return next_scan && std::llabs(*next_scan - next_frame) <= tol_;
}

}  // namespace ovo::estimator
