// The synthetic vineyard that the camera and the LiDAR see: a planar sloped terrain, rows of vines
// (see-through leaf layers, trunks, posts, wires), headland track, meadow, distant hills and a
// cloudy sky, plus optional walking people and test markers; optionally uneven ground (a height
// field on the plane) and leaves swaying in the wind. Rays are intersected analytically and
// shaded with band-limited procedural textures; a pixel's angular footprint drives analytic
// anti-aliasing (box-filtered silhouettes, alpha-composited coverage, texture octaves faded below
// two pixels). World W: z up (gravity -z); row i runs along +x at y = i * row_spacing_m, x in [0,
// row_length_m].
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "common/types.hpp"
#include "sim/height_field.hpp"
#include "sim/scenario.hpp"

namespace ovo::sim {

/// A person walking a straight line on the ground during [t_begin_s, t_end_s].
struct Walker {
  Vec2 start_xy_W = Vec2::Zero();     // ground position at t_begin_s (m)
  Vec2 velocity_xy_W = Vec2::Zero();  // m/s
  double t_begin_s = 0.0, t_end_s = 0.0;
  float shirt_tone = 0.7f, trousers_tone = 0.2f;  // grey levels / 255
};

/// A uniformly bright sphere (a target for projection tests).
struct Marker {
  Vec3 centre_W = Vec3::Zero();
  double radius_m = 0.05;
  float tone = 1.0f;
};

class VineyardWorld {
 public:
  VineyardWorld(const WorldOptions& options, std::uint64_t seed);

  const WorldOptions& options() const { return opt_; }
  /// Ground height z at (x, y): the plane z = grade * x + side_tilt * y plus the height field.
  double groundHeight(double x_W, double y_W) const {
    return field_ ? planeHeight(x_W, y_W) + field_->height(x_W, y_W) : planeHeight(x_W, y_W);
  }
  /// True when p_W lies on the ground (within 0.1 mm: a ray's hit on it, not a leaf or post).
  bool onGround(const Vec3& p_W) const {
    return std::abs(p_W.z() - groundHeight(p_W.x(), p_W.y())) < 1e-4;
  }
  /// The terrain plane's height at (x, y) (the ground without the height field).
  double planeHeight(double x_W, double y_W) const { return gx_ * x_W + gy_ * y_W; }
  /// Unit normal of the terrain plane (points up).
  const Vec3& groundNormal() const { return normal_W_; }
  /// Unit normal of the ground at (x, y), the height field included (points up).
  Vec3 groundNormalAt(double x_W, double y_W) const;
  /// Slope of the terrain plane: dz/dx, dz/dy.
  Vec2 planeGradient() const { return Vec2(gx_, gy_); }
  /// The height field on the plane; null when the ground is the plane.
  const std::shared_ptr<const HeightField>& heightField() const { return field_; }
  /// Displacement (along the row, up; metres) of the leaves at (x, h above the ground) of a canopy
  /// layer at time t_s: smooth in space and time, at most wind_amplitude_m long; zero without wind.
  Vec2 leafSway(int row, int layer, double x, double h, double t_s) const;
  /// Terrain frame T: x along the rows (up the grade), z = terrain normal, origin at W's origin.
  const Mat3& R_W_T() const { return R_W_T_; }
  double rowY(int row) const { return row * opt_.row_spacing_m; }
  /// Centre line between rows k and k + 1.
  double interrowY(int k) const { return (k + 0.5) * opt_.row_spacing_m; }

  void setWalkers(std::vector<Walker> walkers) { walkers_ = std::move(walkers); }
  const std::vector<Walker>& walkers() const { return walkers_; }
  void setMarkers(std::vector<Marker> markers) { markers_ = std::move(markers); }

  /// Grey radiance (display units, 1 = white) along the unit ray d_W from o_W at time t_s, filtered
  /// over a pixel of angular width footprint_rad.
  float radiance(const Vec3& o_W, const Vec3& d_W, double footprint_rad, double t_s) const;

  /// Distance along the unit ray to the first opaque surface (leaf coverage >= 0.5; trunks, posts,
  /// ground, people), as a LiDAR beam sees it; nullopt when nothing is closer than max_range_m.
  std::optional<double> firstOpaqueHit(const Vec3& o_W, const Vec3& d_W, double max_range_m,
                                       double t_s) const;

  struct Hit {
    double t;     // distance along the ray (m)
    float alpha;  // coverage in [0, 1]
    float tone;   // grey radiance
  };
  static constexpr int kMaxHits = 64;
  struct HitList {
    Hit hits[kMaxHits];
    int n = 0;
    float transmittance = 1.0f;  // product of (1 - alpha) so far
    double t_max = 0.0;          // farthest hit so far
    double t_opaque = 1e30;      // nothing beyond this distance shows
    void add(double t, float alpha, float tone) {
      if (n < kMaxHits && alpha > 1e-3f && t < t_opaque) {
        hits[n++] = {t, alpha, tone};
        transmittance *= 1.0f - alpha;
        t_max = std::max(t_max, t);
        if (transmittance < 2e-3f) t_opaque = t_max;
      }
    }
  };

 private:
  struct Plant {
    double x;       // trunk position along the row
    double dy;      // lateral offset of the trunk
    double radius;  // trunk radius
    bool missing;   // a gap in the row
  };

  void collect(const Vec3& o, const Vec3& d, double fp, double t_s, double t_limit,
               HitList* out) const;
  void collectRow(int row, const Vec3& o, const Vec3& d, double fp, double t0, double t1,
                  double t_limit, double t_s, HitList* out) const;
  /// Distance along the unit ray to the uneven ground (the height field on the plane), below
  /// t_max; kFar when none.
  double roughGroundHit(const Vec3& o, const Vec3& d, double t_max) const;
  void addVerticalCylinder(const Vec3& o, const Vec3& d, double fp, double t_limit, double cx,
                           double cy, double radius, double height, float tone,
                           std::uint32_t texture_seed, HitList* out) const;
  float layerCoverage(int row, int layer, double x, double h, double fp_m, double t_s,
                      float* tone) const;
  /// y of leaf layer k of a row (k < canopy_layers) or of the row's centre line (k = layers).
  double rowLineY(int row, int k) const;
  /// groundHeight(x, rowLineY(row, k)), from a table on uneven ground.
  double rowGroundHeight(int row, int k, double x) const;
  float groundTone(double x, double y, double fp_m) const;
  float skyTone(const Vec3& d, double fp) const;
  float backdropTone(double arc_m, double z, double fp_m) const;

  WorldOptions opt_;
  std::uint64_t seed_;
  std::uint32_t tex_seed_;
  double gx_, gy_;
  Vec3 normal_W_;
  Mat3 R_W_T_;
  Vec3 sun_W_;
  Vec2 backdrop_centre_;
  double shadow_shift_y_;
  std::vector<std::vector<Plant>> plants_;  // per row
  std::vector<double> post_x_;              // along every row
  std::vector<Walker> walkers_;
  std::vector<Marker> markers_;
  std::shared_ptr<const HeightField> field_;  // null: flat ground
  // The field along the leaf layers' lines (k < canopy_layers) and the row's centre line
  // (k = canopy_layers) of every row, from x = row_ground_x0_ at kRowGroundStep.
  static constexpr double kRowGroundStep = 0.01;
  std::vector<std::vector<double>> row_ground_;
  double row_ground_x0_ = 0.0;
};

}  // namespace ovo::sim
