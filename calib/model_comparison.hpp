// How far two calibrations of one camera disagree: the angle between their bearings over the
// reference's valid image. Checkerboards fix a camera frame only up to a rotation about the
// optical axis where the model can rotate its image axes (OCamCalib's affine), so that roll is
// aligned first and reported.
#pragma once

#include "camera/camera.hpp"

namespace ovo::calib {

struct BearingComparison {
  double max_deg = 0.0;  // largest angle between bearings after the roll alignment
  double rms_deg = 0.0;
  double roll_deg = 0.0;           // rotation of `other`'s frame about z that aligns it (degrees)
  double max_unaligned_deg = 0.0;  // largest angle without the roll alignment
  int pixels = 0;                  // pixels compared (valid in the reference)
  int missing = 0;                 // of those, pixels `other` cannot unproject
};

/// Compares `other` to `reference` on a grid of pixels every step_px, valid in the reference;
/// with align_roll the best rotation about the optical axis is applied to `other`'s bearings
/// first (closed form). max_off_axis_deg > 0 leaves out pixels whose reference bearing is
/// farther off-axis (e.g. beyond the calibration boards' coverage).
BearingComparison compareBearings(const camera::Camera& reference, const camera::Camera& other,
                                  int step_px = 4, bool align_roll = true,
                                  double max_off_axis_deg = 0.0);

}  // namespace ovo::calib
