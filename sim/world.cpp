#include "sim/world.hpp"

#include <algorithm>
#include <cmath>

#include "sim/noise.hpp"
#include "sim/random.hpp"

namespace ovo::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kFar = 1e5;  // metres: "no hit"

// Texture seeds (offsets from the world's seed), one per procedural pattern.
enum TextureId : std::uint32_t {
  kSoil = 11,
  kPebble,
  kPebbleSmall,
  kGrass,
  kGrassEdge,
  kTuft,
  kLeaf,
  kLeafTone,
  kGrape,
  kCanopyTop,
  kBark,
  kPost,
  kCloud,
  kHill,
  kHillTone,
  kShirt,
  kTrack,
  kField,
  kWind  // four streams from here
};

}  // namespace

VineyardWorld::VineyardWorld(const WorldOptions& options, std::uint64_t seed)
    : opt_(options),
      seed_(seed),
      tex_seed_(static_cast<std::uint32_t>(subSeed(seed, 1) & 0xffffffffu)) {
  gx_ = opt_.grade_pct / 100.0;
  gy_ = opt_.side_tilt_pct / 100.0;
  normal_W_ = Vec3(-gx_, -gy_, 1.0).normalized();
  const Vec3 x_T = Vec3(1.0, 0.0, gx_).normalized();
  R_W_T_.col(0) = x_T;
  R_W_T_.col(1) = normal_W_.cross(x_T);
  R_W_T_.col(2) = normal_W_;
  const double az = opt_.sun_azimuth_deg * kDeg, el = opt_.sun_elevation_deg * kDeg;
  sun_W_ = Vec3(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  // Canopy shadow on the ground: the canopy's centre height projected along the sun direction.
  const double canopy_mid = 0.5 * (opt_.canopy_bottom_m + opt_.canopy_top_m);
  shadow_shift_y_ = -canopy_mid * std::cos(el) * std::sin(az) / std::sin(el);
  backdrop_centre_ =
      Vec2(0.5 * opt_.row_length_m, 0.5 * std::max(0, opt_.num_rows - 1) * opt_.row_spacing_m);

  Rng rng(subSeed(seed, 2));
  const int per_row =
      std::max(1, static_cast<int>(std::floor(opt_.row_length_m / opt_.plant_spacing_m)));
  const double spacing = opt_.row_length_m / per_row;
  plants_.resize(std::max(0, opt_.num_rows));
  for (auto& row : plants_) {
    row.resize(per_row);
    for (int j = 0; j < per_row; ++j) {
      Plant& p = row[j];
      p.x = (j + 0.5) * spacing + rng.uniform(-0.12, 0.12) * spacing;
      p.dy = rng.uniform(-0.03, 0.03);
      p.radius = opt_.trunk_radius_m * rng.uniform(0.75, 1.3);
      p.missing = rng.uniform() < opt_.gap_probability;
    }
  }
  const int posts =
      std::max(1, static_cast<int>(std::round(opt_.row_length_m / opt_.post_spacing_m)));
  for (int k = 0; k <= posts; ++k) post_x_.push_back(opt_.row_length_m * k / posts);
  if (opt_.ground_roughness_m > 0.0) {
    // Full amplitude over the rows and the headlands (where the robot drives) and 3 m beyond.
    const double margin = opt_.headland_m + 3.0;
    const double y_lo = -0.5 * opt_.row_spacing_m;
    const double y_hi = (std::max(opt_.num_rows, 1) - 0.5) * opt_.row_spacing_m;
    const Rect2 plateau{-margin, opt_.row_length_m + margin, y_lo - margin, y_hi + margin};
    field_ = std::make_shared<const HeightField>(opt_.ground_roughness_m, opt_.ground_wavelength_m,
                                                 subSeed(seed, 13), plateau);
    // The field along every leaf layer's line and every row's centre line, tabulated at 1 cm
    // (linear interpolation: off by less than a hundredth of a millimetre at these wavelengths),
    // since the ray caster asks for it many times a ray.
    const int nl = opt_.canopy_layers;
    row_ground_x0_ = -10.0;
    const int n = static_cast<int>(std::ceil((opt_.row_length_m + 20.0) / kRowGroundStep)) + 1;
    row_ground_.assign(static_cast<std::size_t>(opt_.num_rows) * (nl + 1), {});
    for (int row = 0; row < opt_.num_rows; ++row)
      for (int k = 0; k <= nl; ++k) {
        std::vector<double>& table = row_ground_[static_cast<std::size_t>(row) * (nl + 1) + k];
        const double y = rowLineY(row, k);
        table.resize(n);
        for (int i = 0; i < n; ++i)
          table[i] = field_->height(row_ground_x0_ + i * kRowGroundStep, y);
      }
  }
}

double VineyardWorld::rowLineY(int row, int k) const {
  const int nl = opt_.canopy_layers;
  if (k == nl || nl == 1) return rowY(row);
  return rowY(row) + opt_.canopy_width_m * (static_cast<double>(k) / (nl - 1) - 0.5);
}

double VineyardWorld::rowGroundHeight(int row, int k, double x) const {
  const double y = rowLineY(row, k);
  if (!field_) return groundHeight(x, y);
  const std::vector<double>& table =
      row_ground_[static_cast<std::size_t>(row) * (opt_.canopy_layers + 1) + k];
  const double u = (x - row_ground_x0_) / kRowGroundStep;
  if (!(u >= 0.0 && u < static_cast<double>(table.size() - 1))) return groundHeight(x, y);
  const auto i = static_cast<std::size_t>(u);
  const double f = u - static_cast<double>(i);
  return planeHeight(x, y) + table[i] + f * (table[i + 1] - table[i]);
}

Vec3 VineyardWorld::groundNormalAt(double x, double y) const {
  Vec2 g = Vec2::Zero();
  if (field_) field_->height(x, y, &g);
  return Vec3(-gx_ - g.x(), -gy_ - g.y(), 1.0).normalized();
}

Vec2 VineyardWorld::leafSway(int row, int layer, double x, double h, double t_s) const {
  const WorldOptions& o = opt_;
  if (o.wind_amplitude_m <= 0.0) return Vec2::Zero();
  // Each point's two sway components are two sines in time whose phases vary smoothly over the
  // canopy (clusters a metre apart sway independently); their amplitude weights add up to 1, so
  // each component stays within A / sqrt(2) and the displacement within A. Shoots at the top
  // sway fully, leaves at the cordon half as much.
  const std::uint32_t ws = tex_seed_ + kWind + 1009u * static_cast<std::uint32_t>(row) +
                           131u * static_cast<std::uint32_t>(layer);
  constexpr double kPhaseScale = 3.0 * M_PI;  // phase range across the canopy
  const double u = x / 1.0, v = h / 1.0;      // phase field wavelength: 1 m
  const double w = 2.0 * M_PI / o.wind_period_s;
  const double p1 = kPhaseScale * valueNoise(u, v, ws);
  const double p2 = kPhaseScale * valueNoise(u, v, ws + 1);
  const double p3 = kPhaseScale * valueNoise(u, v, ws + 2);
  const double p4 = kPhaseScale * valueNoise(u, v, ws + 3);
  const double sx = 0.6 * std::sin(w * t_s + p1) + 0.4 * std::sin(1.73 * w * t_s + p2);
  const double sz = 0.6 * std::sin(0.87 * w * t_s + p3) + 0.4 * std::sin(2.11 * w * t_s + p4);
  const double rel =
      std::clamp((h - o.canopy_bottom_m) / (o.canopy_top_m - o.canopy_bottom_m), 0.0, 1.0);
  const double a = o.wind_amplitude_m * M_SQRT1_2 * (0.5 + 0.5 * rel);
  return Vec2(a * sx, a * sz);
}

// --- textures
// -------------------------------------------------------------------------------------

float VineyardWorld::groundTone(double x, double y, double fp) const {
  const std::uint32_t s = tex_seed_;
  const double L = opt_.row_length_m, sp = opt_.row_spacing_m;
  const double y_lo = -0.5 * sp, y_hi = (opt_.num_rows - 0.5) * sp;
  const bool in_rows = opt_.num_rows > 0 && x >= 0.0 && x <= L && y >= y_lo && y <= y_hi;
  const bool in_headland = !in_rows && x >= -opt_.headland_m && x <= L + opt_.headland_m &&
                           y >= y_lo - opt_.headland_m && y <= y_hi + opt_.headland_m;

  // Grass weight: a strip along each inter-row, the whole meadow outside the field.
  float grass = 1.0f;
  if (in_rows || in_headland) {
    grass = 0.0f;
    if (in_rows && opt_.grass_width_m > 0.0) {
      const double yrel = y - (std::floor(y / sp) + 0.5) * sp;  // from the inter-row centre
      const double half = 0.5 * opt_.grass_width_m;
      if (std::abs(yrel) < half + 0.3) {
        const double edge =
            std::abs(yrel) + 0.35 * (fbm(x, y, 0.6, 3, 0.5f, fp, s + kGrassEdge) - 0.5);
        grass = smoothstep(static_cast<float>(half + 0.08), static_cast<float>(half - 0.08),
                           static_cast<float>(edge));
      }
    }
  }
  // Soil: multi-scale fractal brightness; the headland track lighter with ruts across the rows.
  float tone = 0.0f;
  if (grass < 1.0f) {
    tone = 0.47f + 1.7f * (fbm(x, y, 0.9, 7, 0.62f, fp, s + kSoil) - 0.5f);
    if (in_headland) {  // ruts along the track: across the rows at the row ends, along them beside
      const bool across = x < 0.0 || x > L;
      const double ax = across ? 4.0 : 0.25, ay = across ? 0.25 : 4.0;
      tone += 0.06f + 0.5f * (fbm(x * ax, y * ay, 1.0, 3, 0.5f, fp * 4.0, s + kTrack) - 0.5f);
    }
  }
  if (grass > 0.0f) {
    const float blades = fbm(x, y, 0.04, 3, 0.6f, fp, s + kGrass);
    const float tufts = fbm(x, y, 0.3, 3, 0.5f, fp, s + kTuft);
    const float g = 0.38f + 1.6f * (blades - 0.5f) + 1.2f * (tufts - 0.5f);
    tone = lerp(tone, g, grass);
  }
  tone += 1.4f * (fbm(x, y, 30.0, 3, 0.5f, fp, s + kField) - 0.5f);  // patches visible from afar

  // Pebbles (bright or dark), hidden by grass.
  if (grass < 1.0f) {
    std::uint32_t id = 0;
    const float big =
        discLayer(x, y, 0.11, in_headland ? 0.6f : 0.4f, 0.008, 0.032, fp, s + kPebble, &id);
    if (big > 0.0f) {
      const float u = hashUnit(id);
      const float ptone = u < 0.7f ? 0.72f + 0.25f * hashUnit(id * 747796405u) : 0.12f + 0.1f * u;
      tone = lerp(tone, ptone, big * (1.0f - grass));
    }
    const float small =
        discLayer(x + 0.37, y - 0.21, 0.045, 0.3f, 0.004, 0.011, fp, s + kPebbleSmall, &id);
    if (small > 0.0f) tone = lerp(tone, 0.8f * hashUnit(id) + 0.15f, small * (1.0f - grass));
  }

  // Soft canopy shadow band beside each row.
  if (in_rows) {
    const double yr = y - shadow_shift_y_;
    const double row_y = std::round(yr / sp) * sp;
    const double dy = std::abs(yr - row_y);
    const double half = 0.5 * opt_.canopy_width_m + 0.25;
    tone *= 1.0f - 0.35f * smoothstep(static_cast<float>(half + 0.25),
                                      static_cast<float>(half - 0.25), static_cast<float>(dy));
  }
  const float lambert = static_cast<float>(0.72 + 0.28 * std::max(0.0, normal_W_.dot(sun_W_)));
  return std::max(0.02f, tone * lambert);
}

float VineyardWorld::skyTone(const Vec3& d, double fp) const {
  float tone =
      static_cast<float>(0.80 + 0.12 * std::max(0.0, d.z()));  // brighter towards the zenith
  if (d.z() > 0.02) {
    // Clouds on a plane 1 km up.
    const double k = 1000.0 / d.z();
    const float c = fbm(d.x() * k, d.y() * k, 600.0, 6, 0.55f, fp * k / d.z(), tex_seed_ + kCloud);
    const float cloud = smoothstep(0.47f, 0.62f, c);
    tone = lerp(tone, 0.97f - 0.5f * std::max(0.0f, c - 0.6f), cloud);
  }
  // Sun glow.
  float glow = static_cast<float>(std::max(0.0, d.dot(sun_W_)));
  glow *= glow;
  glow *= glow;
  glow *= glow;
  tone += 0.08f * glow * glow;  // cos^16
  return tone;
}

float VineyardWorld::backdropTone(double arc_m, double z, double fp) const {
  const float trees = fbm(arc_m, z, 6.0, 6, 0.6f, fp, tex_seed_ + kHillTone);
  return 0.42f + 1.3f * (trees - 0.5f);
}

float VineyardWorld::layerCoverage(int row, int layer, double x, double h, double fp, double t_s,
                                   float* tone) const {
  const WorldOptions& o = opt_;
  if (o.wind_amplitude_m > 0.0) {  // the layer's content seen displaced by the sway
    const Vec2 sway = leafSway(row, layer, x, h, t_s);
    x -= sway.x();
    h -= sway.y();
  }
  const double L = o.row_length_m;
  if (x < -0.3 || x > L + 0.3) return 0.0f;
  const std::uint32_t rs = tex_seed_ + 1009u * static_cast<std::uint32_t>(row);
  // Ragged top and bottom of the canopy.
  const float ragged = valueNoise(x / 0.7, 0.5, rs + kCanopyTop) - 0.5f;
  const double top = o.canopy_top_m + 0.5 * ragged;
  const double bottom = o.canopy_bottom_m + 0.15 * ragged;
  if (h < bottom - 0.1 || h > top + 0.1) return 0.0f;
  float density = static_cast<float>(o.leaf_density);
  density *= smoothstep(static_cast<float>(bottom - 0.05), static_cast<float>(bottom + 0.12),
                        static_cast<float>(h));
  density *= smoothstep(static_cast<float>(top + 0.05), static_cast<float>(top - 0.3),
                        static_cast<float>(h));
  density *=
      smoothstep(-0.25f, 0.15f, static_cast<float>(x)) *
      smoothstep(static_cast<float>(L + 0.25), static_cast<float>(L - 0.15), static_cast<float>(x));
  // Gaps where a vine is missing.
  const auto& plants = plants_[row];
  if (!plants.empty()) {
    const double sp = L / plants.size();
    const int j =
        std::clamp(static_cast<int>(std::floor(x / sp)), 0, static_cast<int>(plants.size()) - 1);
    for (int jj = std::max(0, j - 1); jj <= std::min<int>(plants.size() - 1, j + 1); ++jj) {
      if (!plants[jj].missing) continue;
      const double dx = std::abs(x - plants[jj].x) / sp;
      density *= smoothstep(0.2f, 0.6f, static_cast<float>(dx));
    }
  }
  const int nl = o.canopy_layers;
  const bool outer = layer == 0 || layer == nl - 1;
  if (nl > 2 && !outer) density = std::min(1.0f, density * 1.25f);
  if (density < 0.01f) return 0.0f;

  const std::uint32_t ls = rs + 131u * static_cast<std::uint32_t>(layer);
  const double wl = 2.5 * o.leaf_size_m;
  const float n = fbm(x, h, wl, 5, 0.55f, fp, ls + kLeaf);
  const float th = 0.5f + 0.26f * (0.5f - density);  // the fbm's quantile of 1 - density (about)
  const float w = std::max(0.006f, static_cast<float>(0.08 * fp / o.leaf_size_m));
  float alpha = smoothstep(th - w, th + w, n);
  // Far away the leaf pattern is below a pixel: the layer becomes a uniform partial cover.
  const float far = clamp01(static_cast<float>((fp / o.leaf_size_m - 0.25) / 0.75));
  alpha = lerp(alpha, density, far);

  if (alpha <= 1e-3f) return 0.0f;
  // Leaf clusters brighter inside than at their edges, plus a per-leaf tone.
  const float inside = clamp01((n - th) / 0.12f);
  float t = 0.2f + 0.2f * inside +
            0.9f * (fbm(x, h, 0.8 * o.leaf_size_m, 2, 0.5f, fp, ls + kLeafTone) - 0.5f);
  // Grape bunches low in the canopy on the outer layers: dark blobs.
  if (outer && h < bottom + 0.4) {
    std::uint32_t id = 0;
    const float g = discLayer(x, h, 0.2, 0.4f, 0.025, 0.055, fp, ls + kGrape, &id) *
                    smoothstep(static_cast<float>(bottom + 0.42), static_cast<float>(bottom + 0.3),
                               static_cast<float>(h));
    if (g > 0.0f) {  // the bunch in front of the leaves
      const float grape_tone = 0.1f + 0.06f * hashUnit(id);
      const float a2 = g + alpha * (1.0f - g);
      t = (g * grape_tone + (1.0f - g) * alpha * t) / std::max(a2, 1e-3f);
      alpha = a2;
    }
  }
  *tone = std::max(0.03f, t);
  return alpha;
}

// --- geometry
// -------------------------------------------------------------------------------------

void VineyardWorld::addVerticalCylinder(const Vec3& o, const Vec3& d, double fp, double t_limit,
                                        double cx, double cy, double radius, double height,
                                        float tone, std::uint32_t texture_seed,
                                        HitList* out) const {
  const double h2 = d.x() * d.x() + d.y() * d.y();
  if (h2 < 1e-12) return;
  const double wx = cx - o.x(), wy = cy - o.y();
  const double t_closest = (wx * d.x() + wy * d.y()) / h2;
  if (t_closest <= 0.0) return;
  const double inv_h = 1.0 / std::sqrt(h2);
  const double dist = std::abs(wx * d.y() - wy * d.x()) * inv_h;  // horizontal distance ray-axis
  const double width = t_closest * fp;
  if (dist > radius + 0.5 * width) return;
  const float cover = boxCoverage(dist, radius, width);
  const double t_hit =
      dist < radius ? t_closest - std::sqrt(radius * radius - dist * dist) * inv_h : t_closest;
  if (t_hit <= 0.0 || t_hit >= std::min(t_limit, out->t_opaque)) return;
  const double z = o.z() + t_hit * d.z();
  const double zb = groundHeight(cx, cy);
  const float vcover = boxCoverage(z - (zb + 0.5 * height), 0.5 * height, t_hit * fp);
  const float alpha = cover * vcover;
  if (alpha < 1e-3f) return;
  // Lambert on the cylinder's normal, bark / wood grain along the axis.
  const double qx = o.x() + t_hit * d.x() - cx, qy = o.y() + t_hit * d.y() - cy;
  const double qn = std::max(std::sqrt(qx * qx + qy * qy), 1e-9);
  const double sun_h = std::sqrt(sun_W_.x() * sun_W_.x() + sun_W_.y() * sun_W_.y());
  const double lambert =
      std::max(0.0, (qx * sun_W_.x() + qy * sun_W_.y()) / (qn * std::max(sun_h, 1e-9)));
  const double angle = std::atan2(qy, qx);
  const float grain =
      fbm(angle * radius * 12.0, (z - zb) * 0.6, 0.08, 4, 0.6f, t_hit * fp * 6.0, texture_seed);
  const float shade = static_cast<float>(0.55 + 0.45 * lambert) * (tone + 1.2f * (grain - 0.5f));
  out->add(t_hit, alpha, std::max(0.02f, shade));
}

void VineyardWorld::collectRow(int row, const Vec3& o, const Vec3& d, double fp, double t0,
                               double t1, double t_limit, double t_s, HitList* out) const {
  const WorldOptions& w = opt_;
  const double y_row = rowY(row);
  const double dy = std::abs(d.y()) < 1e-12 ? 1e-12 : d.y();
  const double xa = o.x() + t0 * d.x(), xb = o.x() + t1 * d.x();
  // Height above the ground is linear along the ray: its range over the slab culls whole parts.
  const int nl = w.canopy_layers;
  const double ha = o.z() + t0 * d.z() - rowGroundHeight(row, nl, xa);
  const double hb = o.z() + t1 * d.z() - rowGroundHeight(row, nl, xb);
  // Uneven ground: the height above it may differ from the ends' by up to twice its bound.
  const double margin = field_ ? 0.05 + t1 * fp + 2.0 * field_->bound() : 0.05 + t1 * fp;
  const double h_min = std::min(ha, hb) - margin, h_max = std::max(ha, hb) + margin;
  // Leaf layers, nearest first.
  const double sway = w.wind_amplitude_m;  // leaves may sway this far beyond the canopy's extent
  if (h_max > w.canopy_bottom_m - 0.2 - sway && h_min < w.canopy_top_m + 0.4 + sway) {
    for (int i = 0; i < nl; ++i) {
      const int k = dy > 0 ? i : nl - 1 - i;
      const double y_k =
          nl == 1 ? y_row : y_row + w.canopy_width_m * (static_cast<double>(k) / (nl - 1) - 0.5);
      const double t = (y_k - o.y()) / dy;
      if (t <= 0.0 || t >= std::min(t_limit, out->t_opaque)) continue;
      const double x = o.x() + t * d.x();
      const double h = o.z() + t * d.z() - rowGroundHeight(row, k, x);
      const double cos_inc = std::max(std::abs(d.y()), 0.2);
      float tone = 0.0f;
      const float alpha = layerCoverage(row, k, x, h, t * fp / cos_inc, t_s, &tone);
      if (alpha > 0.0f) {
        const float depth =
            nl > 1 ? static_cast<float>(i) / (nl - 1) : 0.0f;  // 0 = facing the viewer
        out->add(t, alpha, tone * (1.0f - 0.35f * depth));
      }
    }
  }
  const double x_min = std::min(xa, xb) - 0.3, x_max = std::max(xa, xb) + 0.3;
  // Trunks: from the ground into the canopy.
  const double trunk_height = w.canopy_bottom_m + 0.15;
  const auto& plants = plants_[row];
  if (!plants.empty() && h_min < trunk_height) {
    const double sp = w.row_length_m / plants.size();
    const int j0 = std::max(0, static_cast<int>(std::floor(x_min / sp)) - 1);
    const int j1 = std::min<int>(plants.size() - 1, static_cast<int>(std::floor(x_max / sp)) + 1);
    for (int j = j0; j <= j1; ++j) {
      const Plant& p = plants[j];
      if (p.missing) continue;
      addVerticalCylinder(o, d, fp, t_limit, p.x, y_row + p.dy, p.radius, trunk_height, 0.3f,
                          tex_seed_ + kBark + 7u * j, out);
    }
  }
  // Posts.
  if (h_min < w.post_height_m) {
    for (std::size_t k = 0; k < post_x_.size(); ++k) {
      const double px = post_x_[k];
      if (px < x_min - 0.2 || px > x_max + 0.2) continue;
      const bool end_post = k == 0 || k + 1 == post_x_.size();
      addVerticalCylinder(o, d, fp, t_limit, px, y_row, w.post_radius_m * (end_post ? 1.6 : 1.0),
                          w.post_height_m, 0.62f, tex_seed_ + kPost + 13u * k, out);
    }
  }
  // Wires: lines along the row following the grade; closest approach between the ray and a wire.
  if (w.wire_radius_m > 0.0) {
    const double ux = R_W_T_(0, 0), uz = R_W_T_(2, 0);  // unit direction of the row, u_y = 0
    const double b = d.x() * ux + d.z() * uz;
    const double den = 1.0 - b * b;
    if (den > 1e-9) {
      for (double hw : w.wire_heights_m) {
        if (hw < h_min || hw > h_max) continue;
        const double w0x = o.x(), w0y = o.y() - y_row,
                     w0z = o.z() - (planeHeight(0.0, y_row) + hw);  // wires follow the plane
        const double dd = d.x() * w0x + d.y() * w0y + d.z() * w0z;
        const double e = ux * w0x + uz * w0z;
        const double t = (b * e - dd) / den;
        const double s = (e - b * dd) / den;
        if (t <= 0.0 || t >= std::min(t_limit, out->t_opaque)) continue;
        const double x = s * ux;
        if (x < 0.0 || x > w.row_length_m) continue;
        const double cx = w0x + t * d.x() - s * ux, cy = w0y + t * d.y(),
                     cz = w0z + t * d.z() - s * uz;
        const float alpha =
            boxCoverage(std::sqrt(cx * cx + cy * cy + cz * cz), w.wire_radius_m, t * fp);
        out->add(t, alpha, 0.72f);
      }
    }
  }
}

void VineyardWorld::collect(const Vec3& o, const Vec3& d, double fp, double t_s, double t_limit,
                            HitList* out) const {
  const WorldOptions& w = opt_;
  // Rows, nearest first (a 1-D grid over the row slabs); stop once they are opaque.
  if (w.num_rows > 0) {
    const double sp = w.row_spacing_m;
    const double half = 0.5 * w.canopy_width_m + 0.12;
    const double dy = std::abs(d.y()) < 1e-12 ? 1e-12 : d.y();
    const double y_end = o.y() + std::min(t_limit, 1e4) * dy;
    const double lo = std::min(o.y(), y_end), hi = std::max(o.y(), y_end);
    const int i0 = std::max(0, static_cast<int>(std::ceil((lo - half) / sp)));
    const int i1 = std::min(w.num_rows - 1, static_cast<int>(std::floor((hi + half) / sp)));
    for (int n = 0; n <= i1 - i0; ++n) {
      const int row = dy > 0 ? i0 + n : i1 - n;
      double ta = (rowY(row) - half - o.y()) / dy, tb = (rowY(row) + half - o.y()) / dy;
      if (ta > tb) std::swap(ta, tb);
      ta = std::max(ta, 0.0);
      tb = std::min(tb, t_limit);
      if (ta >= tb) continue;
      const double xa = o.x() + ta * d.x(), xb = o.x() + tb * d.x();
      if (std::max(xa, xb) < -0.6 || std::min(xa, xb) > w.row_length_m + 0.6) continue;
      collectRow(row, o, d, fp, ta, tb, t_limit, t_s, out);
      if (out->transmittance < 2e-3f) break;
    }
  }
  // People: a cylinder body and a sphere head.
  for (std::size_t k = 0; k < walkers_.size(); ++k) {
    const Walker& p = walkers_[k];
    if (t_s < p.t_begin_s || t_s > p.t_end_s) continue;
    const Vec2 xy = p.start_xy_W + (t_s - p.t_begin_s) * p.velocity_xy_W;
    HitList body;
    addVerticalCylinder(o, d, fp, t_limit, xy.x(), xy.y(), 0.19, 1.5, p.shirt_tone,
                        tex_seed_ + kShirt + 17u * k, &body);
    for (int i = 0; i < body.n; ++i) {
      const double z = o.z() + body.hits[i].t * d.z() - groundHeight(xy.x(), xy.y());
      const float tone = z < 0.85 ? p.trousers_tone : body.hits[i].tone;
      out->add(body.hits[i].t, body.hits[i].alpha, tone);
    }
    const Vec3 head(xy.x(), xy.y(), groundHeight(xy.x(), xy.y()) + 1.63);
    const double tc = (head - o).dot(d);
    if (tc > 0.0 && tc < t_limit) {
      const double dist = (o + tc * d - head).norm();
      out->add(tc - 0.1, boxCoverage(dist, 0.11, tc * fp), 0.45f);
    }
  }
  for (const Marker& m : markers_) {
    const double tc = (m.centre_W - o).dot(d);
    if (tc <= 0.0 || tc >= t_limit) continue;
    const double dist = (o + tc * d - m.centre_W).norm();
    if (dist > m.radius_m + tc * fp) continue;
    const double th =
        dist < m.radius_m ? tc - std::sqrt(m.radius_m * m.radius_m - dist * dist) : tc;
    out->add(th, boxCoverage(dist, m.radius_m, tc * fp), m.tone);
  }
}

float VineyardWorld::radiance(const Vec3& o, const Vec3& d, double fp, double t_s) const {
  // Ground plane z = gx x + gy y, with its horizon filtered over the pixel's angular width.
  const double denom = d.z() - gx_ * d.x() - gy_ * d.y();
  const double num = planeHeight(o.x(), o.y()) - o.z();  // < 0 above the plane
  const double sin_down = -d.dot(normal_W_);             // > 0: towards the ground
  const float ground_cover = clamp01(static_cast<float>(sin_down / fp + 0.5));
  double t_ground = kFar;
  if (field_) {
    if (ground_cover > 0.0f) t_ground = roughGroundHit(o, d, kFar);
  } else if (ground_cover > 0.0f && denom < -1e-12) {
    t_ground = std::min(kFar, num / denom);
  }

  // Rows, people and markers in front of the ground; the ground, the hills and the sky are shaded
  // only when something of them shows through.
  HitList list;
  collect(o, d, fp, t_s, t_ground, &list);
  if (list.transmittance > 1e-3f) {
    if (t_ground < kFar) {
      const Vec3 p = o + t_ground * d;
      const double fp_m = t_ground * fp / std::max(std::abs(sin_down), 0.05);
      list.add(t_ground, ground_cover, groundTone(p.x(), p.y(), fp_m));
    }
    const double to_ring =
        opt_.backdrop_distance_m - (Vec2(o.x(), o.y()) - backdrop_centre_).norm();
    if (opt_.backdrop && t_ground > to_ring) {
      // Distant hills on a vertical cylinder around the field (the ray starts inside it).
      const double R = opt_.backdrop_distance_m;
      const Vec2 oc(o.x() - backdrop_centre_.x(), o.y() - backdrop_centre_.y());
      const Vec2 dh(d.x(), d.y());
      const double a = dh.squaredNorm();
      const double b = oc.dot(dh), c = oc.squaredNorm() - R * R;
      const double disc = b * b - a * c;
      if (a > 1e-12 && disc >= 0.0 && c < 0.0) {
        const double t = (-b + std::sqrt(disc)) / a;
        if (t < t_ground) {
          const Vec3 p = o + t * d;
          const double arc =
              R * std::atan2(p.y() - backdrop_centre_.y(), p.x() - backdrop_centre_.x());
          const double hill =
              8.0 + 30.0 * (fbm(arc, 0.0, 140.0, 4, 0.5f, t * fp, tex_seed_ + kHill) - 0.5) +
              3.0 * (fbm(arc, 0.0, 9.0, 3, 0.5f, t * fp, tex_seed_ + kHill + 1) - 0.5);
          const double ztop = groundHeight(p.x(), p.y()) + hill;
          const float alpha = clamp01(static_cast<float>((ztop - p.z()) / (t * fp) + 0.5));
          if (alpha > 0.0f)
            list.add(t, alpha, lerp(backdropTone(arc, p.z(), t * fp), 0.72f, 0.35f));
        }
      }
    }
  }
  std::sort(list.hits, list.hits + list.n, [](const Hit& a, const Hit& b) { return a.t < b.t; });
  float value = 0.0f, transmit = 1.0f;
  for (int i = 0; i < list.n && transmit > 1e-3f; ++i) {
    value += transmit * list.hits[i].alpha * list.hits[i].tone;
    transmit *= 1.0f - list.hits[i].alpha;
  }
  if (transmit > 1e-3f) value += transmit * skyTone(d, fp);
  return value;
}

std::optional<double> VineyardWorld::firstOpaqueHit(const Vec3& o, const Vec3& d,
                                                    double max_range_m, double t_s) const {
  constexpr double kBeamRad = 2e-4;  // a sharp beam: leaf edges at full detail
  const double denom = d.z() - gx_ * d.x() - gy_ * d.y();
  const double num = planeHeight(o.x(), o.y()) - o.z();
  double t_best = max_range_m;
  bool hit = false;
  if (field_) {
    const double t = roughGroundHit(o, d, max_range_m);
    if (t < t_best) {
      t_best = t;
      hit = true;
    }
  } else if (denom < -1e-12 && num < 0.0) {
    const double t = num / denom;
    if (t < t_best) {
      t_best = t;
      hit = true;
    }
  }
  HitList list;
  collect(o, d, kBeamRad, t_s, t_best, &list);
  for (int i = 0; i < list.n; ++i) {
    if (list.hits[i].alpha >= 0.5f && list.hits[i].t < t_best) {
      t_best = list.hits[i].t;
      hit = true;
    }
  }
  if (!hit) return std::nullopt;
  return t_best;
}

}  // namespace ovo::sim

namespace ovo::sim {

double VineyardWorld::roughGroundHit(const Vec3& o, const Vec3& d, double t_max) const {
  const HeightField& field = *field_;
  // The ray's height above the plane is l0 + t dl; the ground is at that height h(x(t), y(t)).
  const double l0 = o.z() - planeHeight(o.x(), o.y());
  const double dl = d.z() - gx_ * d.x() - gy_ * d.y();
  const double bound = field.bound();
  t_max = std::min(t_max, kFar);
  const auto accept = [&](double t) { return t >= 0.0 && t < t_max ? t : kFar; };
  // Where the ray meets the plane: the ground outside the field's support.
  const double t_plane = dl < -1e-15 && l0 > 0.0 ? -l0 / dl : kFar;
  // The slab |height above the plane| <= bound, where the field's surface lies.
  double a = 0.0, b = t_max;
  bool a_entry = false, b_exit = false;  // a (b) is where the ray enters (leaves) the slab
  if (dl < -1e-15) {
    if ((bound - l0) / dl > a) {
      a = (bound - l0) / dl;
      a_entry = true;
    }
    if ((-bound - l0) / dl < b) {
      b = (-bound - l0) / dl;
      b_exit = true;
    }
  } else if (l0 > bound) {
    return kFar;  // above the slab and not descending
  } else if (dl > 1e-15) {
    b = std::min(b, (bound - l0) / dl);
  }
  double s0 = 0.0, s1 = 0.0;
  if (!field.supportInterval(o, d, &s0, &s1)) return accept(t_plane);
  if (t_plane < s0) return accept(t_plane);  // the plane before the field begins
  if (s0 > a) {
    a = s0;
    a_entry = false;
  }
  if (s1 < b) {
    b = s1;
    b_exit = false;
  }
  // f(t) = height above the ground along the ray; f' from the field's gradient.
  const auto f = [&](double t, double* df) {
    Vec2 g;
    const double h = field.height(o.x() + t * d.x(), o.y() + t * d.y(), &g);
    if (df) *df = dl - g.x() * d.x() - g.y() * d.y();
    return l0 + t * dl - h;
  };
  // The first sign change in [lo, hi] (f(lo) > 0 >= f(hi)) by Newton's method kept inside it.
  const auto refine = [&](double lo, double hi, double t) {
    for (int it = 0; it < 50; ++it) {
      double df = 0.0;
      const double ft = f(t, &df);
      if (std::abs(ft) < 1e-9) break;
      if (ft <= 0.0) {
        hi = t;
      } else {
        lo = t;
      }
      double next = df != 0.0 ? t - ft / df : 0.5 * (lo + hi);
      if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
      const bool done = std::abs(next - t) < 1e-7 || hi - lo < 1e-7;
      t = next;
      if (done) break;
    }
    return t;
  };
  if (a <= b) {
    const double horizontal = std::hypot(d.x(), d.y());
    // Above the ground where the ray enters the slab; elsewhere it may start under it.
    if (!a_entry && f(a, nullptr) <= 0.0) return accept(a);
    if (-dl > field.maxSlope() * horizontal) {
      // Steeper than any slope of the field: f falls all the way, one crossing at most (and
      // surely one when the ray leaves the slab below).
      if (!b_exit && f(b, nullptr) > 0.0) return t_plane > s1 ? accept(t_plane) : kFar;
      return accept(refine(a, b, std::clamp(t_plane, a, b)));
    }
    // Grazing: march in steps of an eighth of the shortest wavelength over the ground (the waves'
    // phases advanced by rotation), then refine the first sign change.
    const double step = field.minWavelength() / 8.0 / std::max(horizontal, 1e-9);
    HeightMarch march(field, o, d, a, step);
    double t0 = a;
    while (t0 < b) {
      double t1, f1;
      if (t0 + step < b) {
        march.step();
        t1 = march.t();
        f1 = l0 + t1 * dl - march.height();
      } else {
        t1 = b;
        f1 = f(b, nullptr);
      }
      if (f1 <= 0.0) return accept(refine(t0, t1, t1));
      t0 = t1;
    }
  }
  // No crossing over the field: the plane beyond it.
  return t_plane > s1 ? accept(t_plane) : kFar;
}

}  // namespace ovo::sim
