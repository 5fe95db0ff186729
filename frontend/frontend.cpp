#include "frontend/frontend.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>

#include "common/error.hpp"
#include "frontend/essential.hpp"
#include "frontend/mask.hpp"
#include "frontend/timing.hpp"

namespace ovo::frontend {
namespace {

// Features per task where per-feature work (bearings, predictions) is spread over the cores.
constexpr int kPerFeatureGrain = 512;

}  // namespace

FrontendOptions readFrontendOptions(const Config& cfg) {
  FrontendOptions o;
  DetectorOptions& d = o.detector;
  d.nms_n = cfg.getIntInRange("frontend.nms_n", d.nms_n, 1, 20);
  d.nms_n_sparse = cfg.getIntInRange("frontend.nms_n_sparse", d.nms_n_sparse, 1, 50);
  d.nms_tau = cfg.getIntInRange("frontend.nms_tau", d.nms_tau, 0, 10000);
  d.margin_px = cfg.getIntInRange("frontend.margin_px", d.margin_px, 0, 1000);
  d.bin_size_px = cfg.getIntInRange("frontend.bin_size_px", d.bin_size_px, 4, 10000);
  d.bin_max_features =
      cfg.getIntInRange("frontend.bin_max_features", d.bin_max_features, 0, 100000);
  d.half_resolution = cfg.get<bool>("frontend.half_resolution", d.half_resolution);
  MatcherOptions& m = o.matcher;
  m.search_radius_px = cfg.getIntInRange("frontend.search_radius_px", m.search_radius_px, 1, 10000);
  m.search_radius_predicted_px = cfg.getIntInRange("frontend.search_radius_predicted_px",
                                                   m.search_radius_predicted_px, 1, 10000);
  m.sparse_pass = cfg.get<bool>("frontend.sparse_pass", m.sparse_pass);
  m.flow_margin_px = cfg.getIntInRange("frontend.flow_margin_px", m.flow_margin_px, 0, 1000);
  m.max_cost_ratio = cfg.getInRange("frontend.max_cost_ratio", m.max_cost_ratio, 0.0, 1.0);
  const std::string subpixel =
      cfg.getChoice("frontend.subpixel", "cost", {"none", "cost", "response"});
  m.subpixel = *parseSubpixelMode(subpixel);
  m.max_refine_steps = cfg.getIntInRange("frontend.max_refine_steps", m.max_refine_steps, 0, 20);
  m.min_cost_contrast = cfg.getInRange("frontend.min_cost_contrast", m.min_cost_contrast, 0.0, 1.0);
  m.max_queries_per_bin =
      cfg.getIntInRange("frontend.max_queries_per_bin", m.max_queries_per_bin, 0, 100000);
  m.delaunay_filter = cfg.get<bool>("frontend.delaunay_filter", m.delaunay_filter);
  m.delaunay_flow_tol_px =
      cfg.getInRange("frontend.delaunay_flow_tol_px", m.delaunay_flow_tol_px, 0.0, 1000.0);
  m.delaunay_min_support =
      cfg.getIntInRange("frontend.delaunay_min_support", m.delaunay_min_support, 0, 100);
  o.tracker.max_history =
      cfg.getIntInRange("frontend.max_track_history", o.tracker.max_history, 0, 1000000);
  o.relative_pose = readRelativePoseOptions(cfg);
  o.mask_border_px = cfg.getIntInRange("frontend.mask_border_px", o.mask_border_px, 0, 1000);
  o.bucket_size_px = cfg.getIntInRange("frontend.bucket_size_px", o.bucket_size_px, 1, 10000);
  o.bucket_max_matches =
      cfg.getIntInRange("frontend.bucket_max_matches", o.bucket_max_matches, 0, 100000);
  o.use_rotation_prior = cfg.get<bool>("frontend.use_rotation_prior", o.use_rotation_prior);
  o.break_tracks_on_outliers =
      cfg.get<bool>("frontend.break_tracks_on_outliers", o.break_tracks_on_outliers);
  o.track_epipolar_gate_rad =
      cfg.getInRange("frontend.track_epipolar_gate_rad", o.track_epipolar_gate_rad, 0.0, 1.0);
  TrackRefineOptions& t = o.track_refine;
  t.enabled = cfg.get<bool>("frontend.track_refine", t.enabled);
  t.half_window_px =
      cfg.getIntInRange("frontend.track_refine_half_window_px", t.half_window_px, 1, 7);
  t.sigma_px = cfg.getInRange("frontend.track_refine_sigma_px", t.sigma_px, 0.3, 20.0);
  t.max_shift_px = cfg.getInRange("frontend.track_refine_max_shift_px", t.max_shift_px, 0.0, 10.0);
  t.max_iterations =
      cfg.getIntInRange("frontend.track_refine_max_iterations", t.max_iterations, 1, 100);
  t.min_gradient =
      cfg.getInRange("frontend.track_refine_min_gradient", t.min_gradient, 0.0, 1000.0);
  t.forward_backward_px =
      cfg.getInRange("frontend.track_refine_forward_backward_px", t.forward_backward_px, 0.0, 10.0);
  t.required = cfg.get<bool>("frontend.track_refine_required", t.required);
  return o;
}

Frontend::Frontend(const camera::Camera& camera, const FrontendOptions& options)
    : camera_(camera),
      options_(options),
      mask_(buildValidMask(camera, options.mask_border_px)),
      bearing_table_(buildBearingTable(camera)),
      matcher_(options.matcher),
      tracker_(options.tracker),
      relative_pose_(options.relative_pose),
      step_refiner_(options.track_refine) {}

void Frontend::reset() {
  has_prev_ = false;
  tracker_.reset();
  prev_px_.clear();
  prev_grey_.release();
  prev_bearing_.clear();
  prev_feature_bearing_.clear();
}

Vec3 Frontend::bearingOf(const Vec2& px) const {
  const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
  const int w = camera::width(camera_), h = camera::height(camera_);
  if (u == px.x() && v == px.y() && u >= 0 && v >= 0 && u < w && v < h) {
    const float* b =
        bearing_table_.data() + 3 * (static_cast<std::size_t>(v) * w + static_cast<std::size_t>(u));
    return Vec3(b[0], b[1], b[2]).normalized();
  }
  return camera::unproject(camera_, px).value_or(Vec3::Zero());
}

void Frontend::featureBearings(const FeatureFrame& frame, std::vector<Vec3>* bearings) const {
  bearings->resize(frame.size());
  // Independent per feature (mostly waiting on the bearing table): over the cores.
  tbb::parallel_for(tbb::blocked_range<int>(0, frame.size(), kPerFeatureGrain),
                    [&](const tbb::blocked_range<int>& range) {
                      for (int i = range.begin(); i != range.end(); ++i)
                        (*bearings)[i] = bearingOf(frame.pixel(i));
                    });
}

void Frontend::predict(const Mat3& R_cur_prev, MatchPrediction* prediction) const {
  const auto predictAll = [&](const std::vector<Vec3>& bearings, const Mat3& R,
                              std::vector<Vec2>* px, std::vector<std::uint8_t>* valid) {
    const int n = static_cast<int>(bearings.size());
    px->resize(n);
    valid->assign(n, 0);
    tbb::parallel_for(tbb::blocked_range<int>(0, n, kPerFeatureGrain),
                      [&](const tbb::blocked_range<int>& range) {
                        for (int i = range.begin(); i != range.end(); ++i) {
                          const Vec3& b = bearings[i];
                          if (b.isZero()) continue;
                          const auto p = camera::project(camera_, R * b);
                          if (!p) continue;
                          (*px)[i] = *p;
                          (*valid)[i] = 1;
                        }
                      });
  };
  predictAll(prev_feature_bearing_, R_cur_prev, &prediction->cur_px_of_prev,
             &prediction->prev_valid);
  predictAll(cur_feature_bearing_, R_cur_prev.transpose(), &prediction->prev_px_of_cur,
             &prediction->cur_valid);
}

FrontendResult Frontend::process(Timestamp t_ns, const cv::Mat& grey,
                                 const std::optional<Mat3>& R_cur_prev_prior) {
  const int w = camera::width(camera_), h = camera::height(camera_);
  if (grey.type() != CV_8UC1 || grey.cols != w || grey.rows != h) {
    fail("frontend: expected a {}x{} 8-bit grey image, got {}x{} of OpenCV type {}", w, h,
         grey.cols, grey.rows, grey.type());
  }
  StageClock clock;
  FrontendResult result;
  FrontendTimings& wall = result.timings;
  FrontendTimings& cpu = result.cpu_timings;
  result.frame_index = ++frame_index_;
  result.t_ns = t_ns;

  ExtractTimings extract;
  extractFeatures(grey, options_.detector, mask_, &cur_, &extract);
  wall.filter_ms = extract.filter_ms;
  wall.nms_ms = extract.nms_ms;
  cpu.filter_ms = extract.filter_cpu_ms;
  cpu.nms_ms = extract.nms_cpu_ms;
  result.num_features = cur_.size();
  cur_feature_bearing_.clear();
  double extract_wall_ms = 0.0, extract_cpu_ms = 0.0;
  clock.lap(&extract_wall_ms, &extract_cpu_ms);

  // Match with the previous frame (under a query cap, older tracks are searched first), then
  // bucket (older tracks first).
  std::vector<Match> matches;
  std::vector<std::uint8_t> used;
  if (has_prev_) {
    MatchPrediction prediction;
    const bool predicted = R_cur_prev_prior && options_.use_rotation_prior;
    if (predicted) {
      if (prev_feature_bearing_.size() != static_cast<std::size_t>(prev_.size()))
        featureBearings(prev_, &prev_feature_bearing_);  // the previous frame had no prior
      featureBearings(cur_, &cur_feature_bearing_);
      predict(*R_cur_prev_prior, &prediction);
    }
    std::vector<int> prev_age(prev_.size());
    for (int i = 0; i < prev_.size(); ++i) prev_age[i] = tracker_.current(i).age;
    matches = matcher_.match(prev_, cur_, predicted ? &prediction : nullptr, &result.match_stats,
                             &prev_age);
    std::vector<int> age(matches.size());
    for (std::size_t k = 0; k < matches.size(); ++k) age[k] = prev_age[matches[k].prev];
    used = bucketMatches(matches, age, options_.bucket_size_px, options_.bucket_max_matches);
  }
  result.num_matches_before_bucketing = static_cast<int>(matches.size());
  clock.lap(&wall.match_ms, &cpu.match_ms);

  // Observation pixels: a matched feature continues its predecessor's pixel by the measured flow
  // (so cost-mode refinement stays consistent along a track); others keep their own position.
  const bool refined = options_.matcher.subpixel == SubpixelMode::kResponse;
  std::vector<Vec2> px(cur_.size());
  std::vector<int> prev_index(cur_.size(), -1), cls(cur_.size());
  for (int j = 0; j < cur_.size(); ++j) {
    px[j] = cur_.pixel(j, refined);
    cls[j] = static_cast<int>(cur_.features[j].cls);
  }
  for (const Match& m : matches) {
    px[m.cur] = prev_px_[m.prev] + (m.px_cur - m.px_prev);
    prev_index[m.cur] = m.prev;
  }
  if (options_.track_refine.enabled && !prev_grey_.empty()) {
    // Each step is independent: split over the cores (the estimator stage mostly waits), then
    // applied in match order.
    std::vector<std::optional<Vec2>> refined_px(matches.size());
    std::vector<char> ends_track(matches.size(), 0);
    const double fb_px = options_.track_refine.forward_backward_px;
    const bool require = options_.track_refine.required;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, matches.size(), 256),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        for (std::size_t k = range.begin(); k != range.end(); ++k) {
                          const Match& m = matches[k];
                          refined_px[k] =
                              step_refiner_.refine(prev_grey_, prev_px_[m.prev], grey, px[m.cur]);
                          if (fb_px > 0.0 && refined_px[k]) {
                            const auto back = step_refiner_.refine(grey, *refined_px[k], prev_grey_,
                                                                   prev_px_[m.prev]);
                            if (!back || (*back - prev_px_[m.prev]).norm() > fb_px)
                              ends_track[k] = 1;
                          }
                          if (require && !refined_px[k]) ends_track[k] = 1;
                        }
                      });
    for (std::size_t k = 0; k < matches.size(); ++k) {
      if (ends_track[k]) {
        prev_index[matches[k].cur] = -1;  // the track ends; the feature starts a new one
        px[matches[k].cur] = cur_.pixel(matches[k].cur, refined);
      } else if (refined_px[k]) {
        px[matches[k].cur] = *refined_px[k];
      }
    }
  }
  std::vector<Vec3> bearings(cur_.size());
  tbb::parallel_for(tbb::blocked_range<int>(0, cur_.size(), kPerFeatureGrain),
                    [&](const tbb::blocked_range<int>& range) {
                      for (int j = range.begin(); j != range.end(); ++j) {
                        // An unmatched feature keeps its detected pixel, whose bearing is known.
                        bearings[j] = prev_index[j] < 0 && !refined && !cur_feature_bearing_.empty()
                                          ? cur_feature_bearing_[j]
                                          : bearingOf(px[j]);
                        if (bearings[j].isZero() && prev_index[j] >= 0) {
                          // The flow pushed it off the model's domain.
                          px[j] = cur_.pixel(j, refined);
                          bearings[j] = bearingOf(px[j]);
                          prev_index[j] = -1;
                        }
                      }
                    });
  clock.lap(&wall.track_ms, &cpu.track_ms);

  // Relative pose on the bucketed matches.
  std::vector<int> used_matches;
  for (std::size_t k = 0; k < matches.size(); ++k) {
    if (used[k] && prev_index[matches[k].cur] >= 0) used_matches.push_back(static_cast<int>(k));
  }
  FrameMatches& fm = result.matches;
  for (const int k : used_matches) {
    const Match& m = matches[k];
    fm.bearings_prev.push_back(prev_bearing_[m.prev]);
    fm.bearings_cur.push_back(bearings[m.cur]);
    fm.px_prev.push_back(prev_px_[m.prev]);
    fm.px_cur.push_back(px[m.cur]);
  }
  if (has_prev_) {
    result.relative_pose = relative_pose_.estimate(fm.bearings_prev, fm.bearings_cur);
    const auto status = result.relative_pose->status;
    const bool consensus = status == RelativePoseResult::Status::kOk ||
                           status == RelativePoseResult::Status::kLowParallax;
    if (options_.break_tracks_on_outliers && consensus &&
        result.relative_pose->inliers.size() == used_matches.size()) {
      for (std::size_t i = 0; i < used_matches.size(); ++i) {
        if (!result.relative_pose->inliers[i]) prev_index[matches[used_matches[i]].cur] = -1;
      }
    }
    // A track must not continue through a match that the frame's motion explains poorly: a
    // mismatch, or a jump to a neighbouring feature, would otherwise offset every later
    // observation of the track (the estimators' landmarks see the whole history).
    const double gate = options_.track_epipolar_gate_rad;
    if (options_.break_tracks_on_outliers && gate > 0.0 &&
        status == RelativePoseResult::Status::kOk) {
      const Mat3 E =
          essentialFromMotion(result.relative_pose->R_cur_prev, result.relative_pose->t_cur_prev);
      for (const Match& m : matches) {
        const int j = m.cur;
        if (prev_index[j] >= 0 &&
            !(sphereError(E, prev_bearing_[m.prev], bearings[j]) <= gate * gate))
          prev_index[j] = -1;
      }
    }
  }
  clock.lap(&wall.ransac_ms, &cpu.ransac_ms);

  tracker_.update(result.frame_index, t_ns, px, bearings, cls, prev_index);
  const auto& ids = tracker_.currentIds();
  for (const int k : used_matches) fm.track_ids.push_back(ids[matches[k].cur]);
  result.observations = tracker_.currentObservations();
  std::swap(prev_, cur_);
  std::swap(prev_feature_bearing_, cur_feature_bearing_);
  if (options_.track_refine.enabled) grey.copyTo(prev_grey_);
  prev_px_ = std::move(px);
  prev_bearing_ = std::move(bearings);
  has_prev_ = true;
  clock.lap(&wall.track_ms, &cpu.track_ms);
  wall.total_ms = extract_wall_ms + wall.match_ms + wall.ransac_ms + wall.track_ms;
  cpu.total_ms = extract_cpu_ms + cpu.match_ms + cpu.ransac_ms + cpu.track_ms;
  return result;
}

}  // namespace ovo::frontend
