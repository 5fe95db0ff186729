// How the window core handles standstills: the test of each frame (standstill.hpp), the
// still frames (the pose held once the robot has settled; the still frame kept as a reference to
// restart from), and the zero-rate update of the gyro bias when a still streak ends.
#include <algorithm>
#include <cmath>

#include "common/so3.hpp"
#include "estimator/window/core.hpp"

namespace ovo::estimator {

bool WindowCore::still(const VisualFrame& frame,
                       const std::unordered_map<TrackId, TrackObservation>& obs,
                       const Prediction& pred) const {
  StillEvidence ev;
  ev.has_observations = !frame.observations.empty();
  if (frame.median_flow_px >= 0.0)
    ev.flow_px = frame.median_flow_px;
  else if (const auto flow = medianFlowPx(obs, last_obs_))
    ev.flow_px = *flow;
  ev.rate_radps = pred.rate_radps;
  if (use_gyro_) {
    GyroScatter scatter;
    for (const ImuSample& g : gyro_.around(last_t_, frame.t_ns))
      if (g.t_ns > last_t_ && g.t_ns <= frame.t_ns) scatter.add(g.gyro_radps);
    ev.gyro_samples = scatter.count;
    if (scatter.count >= 3) ev.gyro_spread_radps = scatter.spread();
  }
  return isStill(ev, use_gyro_, initialized_, options_);
}

int WindowCore::processStill(const VisualFrame& frame, const Prediction& pred,
                             const std::unordered_map<TrackId, TrackObservation>& obs,
                             FrameEstimate& e) {
  int ref_kf = -1;
  e.T_W_B = last_T_W_B_;
  // A robot coming to rest creeps on below the flow threshold: for standstill_settle_s the
  // still frames are still placed against the landmarks, then the pose is held (tracks chained
  // over still frames creep while the robot stands).
  if (initialized_ && !map_.empty() &&
      toSeconds(frame.t_ns - *still_since_) < options_.standstill_settle_s) {
    std::vector<TrackId> ids;
    std::size_t landmarks_seen = 0;
    if (const auto ref = refineAgainstMap(obs, pred, &ids, &landmarks_seen)) e.T_W_B = ref->T_W_B;
  }
  e.tracked = initialized_ || !reference_;
  e.status = "standstill";
  velocity_W_.setZero();
  if (initialized_ && !map_.empty()) ref_kf = map_.keyframes.back()->id;
  if (initialized_) still_reference_ = makeReference(frame, e.T_W_B);
  // Zero-rate update: the raw gyro rotation of a still frame is bias * dt plus noise. Taken on
  // the gyro's clock as the frames' stamps give it (not moved by the time offset: the robot is
  // still either way, and the samples up to the stamp are there when the frame is).
  if (auto pi0 = preintegrateOnGyroClock(last_t_, frame.t_ns, Vec3::Zero());
      pi0 && pi0->status() == factors::GyroPreintegration::Status::kOk) {
    still_bias_.add(frame.t_ns, so3::log(pi0->deltaR()), pred.dt);
    if (!initialized_)
      if (auto z = still_bias_.estimate(options_.standstill_min_bias_s)) bias_ = z->bias_radps;
  }
  if (!initialized_) {
    // Held before initialisation: the pose is known, and the two-view reference moves to
    // the last still frame so that no translation is lost when the robot starts.
    e.tracked = true;
    if (canReference(frame.t_ns)) startReference(frame, e.T_W_B);
    if (ground_chain_) ground_chain_->restart(frame, e.T_W_B);
    starter_.standstill();
  }
  return ref_kf;
}

double WindowCore::walkedBiasSigma(double sigma_radps, double dt_s) const {
  return std::sqrt(sigma_radps * sigma_radps +
                   model_.bias_random_walk * model_.bias_random_walk * dt_s);
}

void WindowCore::endStandstill(Timestamp t_ns) {
  still_bias_.endStreak();
  if (!initialized_) {  // the streaks before initialisation add up
    if (auto z = still_bias_.estimate(options_.standstill_min_bias_s)) bias_ = z->bias_radps;
    return;
  }
  const auto z = still_bias_.estimate(options_.standstill_min_bias_s);
  still_bias_.reset();
  if (!z || map_.empty() || !use_gyro_) return;
  Keyframe& kf = *map_.keyframes.back();
  // The bias walks between the keyframe and the end of the standstill.
  const double walk_s = std::max(0.0, toSeconds(t_ns - kf.t_ns));
  const double sigma = walkedBiasSigma(z->sigma_radps, walk_s);
  addZeroRate(kf, z->bias_radps, sigma);
  recent_zero_rate_ = {t_ns, *z};
  note("standstill: gyro bias from its mean rate (zero-rate factor on the last keyframe)");
}

}  // namespace ovo::estimator
