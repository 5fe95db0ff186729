// The camera-gyro time offset as a state: the gyro factor between two keyframes with the offset
// as a fourth block, and the offset's prior (VINS-Mono estimates the same offset online; there it
// shifts the features, here the gyro interval, which needs no feature velocities).
#pragma once

#include <ceres/sized_cost_function.h>

#include <memory>

#include "factors/gyro_preintegration.hpp"

namespace ovo::factors {

/// Gyro factor with the time offset td (s; image stamp minus the gyro clock's time of the image,
/// the rig.yaml camera.time_offset_s convention). Keyframes i and j are at image stamps t_i, t_j,
/// so the gyro saw their rotation over [t_i - td, t_j - td]. The preintegration was made over
/// [t_i - td_lin, t_j - td_lin]; for td near td_lin (d = td_lin - td, the interval's shift),
///   dR(td) = Exp(-w_i d) dR_ij(b_g) Exp(w_j d),   w = (measured rate at the ends) - b_g,
/// exact for a rate constant over each end's shift. Residual as GyroFactor's:
///   r = S Log( dR(td)^T R_W_Bi^T R_W_Bj ).
/// Blocks: q_W_Bi[4], q_W_Bj[4], b_g_i[3], td[1]. A constant rate leaves td unobservable (the
/// rotation over a shifted interval is the same); angular acceleration makes it observable.
class GyroTimeOffsetFactor final : public ceres::SizedCostFunction<3, 4, 4, 3, 1> {
 public:
  GyroTimeOffsetFactor(std::shared_ptr<const GyroPreintegration> preintegration, double td_lin_s)
      : preint_(std::move(preintegration)), td_lin_s_(td_lin_s) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  std::shared_ptr<const GyroPreintegration> preint_;
  double td_lin_s_;
};

}  // namespace ovo::factors
