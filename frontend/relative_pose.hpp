// Relative pose between two fisheye/pinhole views from bearing matches: 8-point on the sphere
// inside a reproducible RANSAC whose scoring runs on a selectable backend (DESIGN sections 4, 5).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "common/config.hpp"
#include "common/types.hpp"

namespace ovo::frontend {

class Ransac;

// Convention: points X_prev in the previous camera frame map to X_cur = R_cur_prev X_prev +
// t_cur_prev; E = [t_cur_prev]x R_cur_prev, so bearing_cur^T E bearing_prev = 0 (DESIGN section 4).
struct RelativePoseOptions {
  std::string backend = "auto";  // serial | threads | opencl | auto (ransac.backend)
  int max_iterations = 2000;     // fixed hypothesis count unless adaptive
  bool adaptive = false;      // stop once `confidence` is reached (decided per block of hypotheses)
  double confidence = 0.999;  // probability of having drawn one all-inlier sample (adaptive only)
  double inlier_threshold_rad =
      1e-3;  // angular error threshold on the sphere (~0.3 px at 305 px/rad)
  std::uint64_t seed = 42;
  int min_inliers = 20;           // fewer: kNoConsensus
  double min_parallax_deg = 0.3;  // below: kLowParallax (rotation still returned, t = 0)
  bool operator==(const RelativePoseOptions&) const = default;
};
/// Reads the keys under "ransac." (backend, max_iterations, adaptive, confidence,
/// inlier_threshold_rad, seed, min_inliers, min_parallax_deg).
RelativePoseOptions readRelativePoseOptions(const Config& cfg);

struct RelativePoseResult {
  enum class Status {
    kOk,
    kTooFewMatches,
    kLowParallax,
    kNoConsensus
  } status = Status::kNoConsensus;
  Mat3 R_cur_prev = Mat3::Identity();
  Vec3 t_cur_prev = Vec3::Zero();     // unit length when kOk
  std::vector<std::uint8_t> inliers;  // one flag per match
  int num_inliers = 0;
  int iterations = 0;                // hypotheses evaluated
  double median_parallax_deg = 0.0;  // rotation-compensated, over the inliers
};

/// Holds the RANSAC backend (buffers reused across frames). Not thread-safe: one per thread.
class RelativePoseEstimator {
 public:
  explicit RelativePoseEstimator(const RelativePoseOptions& options);
  ~RelativePoseEstimator();
  RelativePoseEstimator(RelativePoseEstimator&&) noexcept;
  RelativePoseEstimator& operator=(RelativePoseEstimator&&) noexcept;

  /// bearings_prev[i] and bearings_cur[i] are unit vectors of match i in the previous and current
  /// camera frames. Never returns NaN; degenerate input is reported through the status.
  RelativePoseResult estimate(const std::vector<Vec3>& bearings_prev,
                              const std::vector<Vec3>& bearings_cur);

  const RelativePoseOptions& options() const { return options_; }
  /// The scoring backend actually used ("serial", "threads" or "opencl"; `auto` resolved).
  std::string_view backendName() const;

 private:
  RelativePoseOptions options_;
  std::unique_ptr<Ransac> ransac_;
};

std::string_view toString(RelativePoseResult::Status s);

}  // namespace ovo::frontend
