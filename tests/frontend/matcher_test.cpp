// Matcher known answers: sub-pixel shifts, circle check, Delaunay filter, prediction, bucketing.
#include "frontend/matcher.hpp"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "frontend/delaunay.hpp"
#include "tests/frontend/test_images.hpp"

namespace ovo::frontend {
namespace {

using synth::shifted;
using synth::texture;

struct ShiftResult {
  int matches = 0;
  Vec2 mean_error = Vec2::Zero();
  double mean_abs_error = 0.0;
  int wrong = 0;  // more than 1 px from the true flow
};

ShiftResult matchShift(const cv::Mat& prev_img, const cv::Mat& cur_img, const Vec2& shift,
                       const DetectorOptions& det, const MatcherOptions& mopt,
                       const MatchPrediction* prediction = nullptr, double wrong_px = 1.0) {
  FeatureFrame prev, cur;
  extractFeatures(prev_img, det, cv::Mat(), &prev);
  extractFeatures(cur_img, det, cv::Mat(), &cur);
  Matcher matcher(mopt);
  const auto matches = matcher.match(prev, cur, prediction);
  ShiftResult r;
  r.matches = static_cast<int>(matches.size());
  for (const auto& m : matches) {
    const Vec2 err = (m.px_cur - m.px_prev) - shift;
    if (err.norm() > wrong_px) {
      ++r.wrong;
      if (std::getenv("OVO_DEBUG_MATCHES"))
        printf("wrong %.1f %.1f -> %.1f %.1f cost %u\n", m.px_prev.x(), m.px_prev.y(), m.px_cur.x(),
               m.px_cur.y(), m.cost);
      continue;
    }
    r.mean_error += err;
    r.mean_abs_error += err.norm();
  }
  const int good = r.matches - r.wrong;
  if (good > 0) {
    r.mean_error /= good;
    r.mean_abs_error /= good;
  }
  std::printf("  matches %d, wrong %d, mean error (%.3f, %.3f) px, mean |error| %.3f px\n",
              r.matches, r.wrong, r.mean_error.x(), r.mean_error.y(), r.mean_abs_error);
  return r;
}

TEST(Matcher, RecoversSubPixelShiftWithCostParabola) {
  const cv::Mat img = texture(640, 480, 1);
  const Vec2 shift(3.3, -1.7);
  const auto r = matchShift(img, shifted(img, shift.x(), shift.y()), shift, {}, {});
  EXPECT_GT(r.matches, 1000);
  // Off by more than a pixel: only the rare mismatch whose flow stays within the Delaunay
  // tolerance of its neighbours' (5 px; RANSAC removes those); none beyond it.
  EXPECT_LE(r.wrong, r.matches / 1000);
  const auto gross =
      matchShift(img, shifted(img, shift.x(), shift.y()), shift, {}, {}, nullptr, 5.0);
  EXPECT_EQ(gross.wrong, 0);
  EXPECT_LT(r.mean_error.norm(), 0.1) << r.mean_error.transpose();
  EXPECT_LT(r.mean_abs_error, 0.2);
}

TEST(Matcher, RecoversSubPixelShiftWithResponseParabola) {
  const cv::Mat img = texture(640, 480, 2);
  const Vec2 shift(3.3, -1.7);
  MatcherOptions mopt;
  mopt.subpixel = SubpixelMode::kResponse;
  const auto r = matchShift(img, shifted(img, shift.x(), shift.y()), shift, {}, mopt);
  EXPECT_GT(r.matches, 1000);
  EXPECT_LE(r.wrong, r.matches / 200);
  EXPECT_LT(r.mean_error.norm(), 0.1) << r.mean_error.transpose();
  EXPECT_LT(r.mean_abs_error, 0.2);
}

TEST(Matcher, HalfResolutionRecoversShift) {
  const cv::Mat img = texture(640, 480, 3, 3.0);
  const Vec2 shift(-7.6, 4.2);
  DetectorOptions det;
  det.half_resolution = true;
  const auto r = matchShift(img, shifted(img, shift.x(), shift.y()), shift, det, {});
  EXPECT_GT(r.matches, 200);
  EXPECT_LE(r.wrong, r.matches / 100);
  EXPECT_LT(r.mean_error.norm(), 0.15) << r.mean_error.transpose();
}

TEST(Matcher, CircleCheckAndDelaunayRejectAnOccludedPatch) {
  // The current image is the shifted texture with a 200x150 patch of unrelated texture pasted in:
  // features there have no true match. Gross outliers (flow off by more than the Delaunay
  // tolerance) are what these two filters must remove; near misses inside the sparse prior's
  // window are left to RANSAC.
  const cv::Mat img = texture(640, 480, 4);
  const Vec2 shift(5.0, 2.0);
  cv::Mat cur = shifted(img, shift.x(), shift.y());
  texture(200, 150, 99).copyTo(cur(cv::Rect(300, 200, 200, 150)));
  MatcherOptions circle_only;
  circle_only.delaunay_filter = false;
  circle_only.sparse_pass = false;
  const auto r_circle = matchShift(img, cur, shift, {}, circle_only, nullptr, 5.0);
  MatcherOptions with_delaunay = circle_only;
  with_delaunay.delaunay_filter = true;
  const auto r_both = matchShift(img, cur, shift, {}, with_delaunay, nullptr, 5.0);
  EXPECT_GT(r_both.matches, 800);
  EXPECT_GT(r_circle.wrong, 0) << "the test should plant outliers that pass the circle check";
  EXPECT_LT(r_circle.wrong, r_circle.matches / 30) << "circle check lets outliers through";
  EXPECT_EQ(r_both.wrong, 0);
}

TEST(Matcher, RotationPredictionShiftsTheSearchWindow) {
  // A 60 px motion is outside a 25 px window unless the prediction moves the window.
  const cv::Mat img = texture(640, 480, 5);
  const Vec2 shift(60.0, -12.0);
  const cv::Mat cur_img = shifted(img, shift.x(), shift.y());
  MatcherOptions mopt;
  mopt.search_radius_px = 25;
  mopt.search_radius_predicted_px = 25;
  const auto unpredicted = matchShift(img, cur_img, shift, {}, mopt);
  EXPECT_LT(unpredicted.matches - unpredicted.wrong, 20);

  FeatureFrame prev, cur;
  extractFeatures(img, {}, cv::Mat(), &prev);
  extractFeatures(cur_img, {}, cv::Mat(), &cur);
  MatchPrediction pred;
  for (int i = 0; i < prev.size(); ++i) pred.cur_px_of_prev.push_back(prev.pixel(i) + shift);
  for (int j = 0; j < cur.size(); ++j) pred.prev_px_of_cur.push_back(cur.pixel(j) - shift);
  pred.prev_valid.assign(prev.size(), 1);
  pred.cur_valid.assign(cur.size(), 1);
  const auto predicted = matchShift(img, cur_img, shift, {}, mopt, &pred);
  EXPECT_GT(predicted.matches, 1000);
  EXPECT_EQ(predicted.wrong, 0);
}

TEST(Matcher, EachFeatureMatchedAtMostOnce) {
  const cv::Mat img = texture(320, 240, 6);
  FeatureFrame prev, cur;
  extractFeatures(img, {}, cv::Mat(), &prev);
  extractFeatures(shifted(img, 1.5, 0.5), {}, cv::Mat(), &cur);
  const auto matches = Matcher().match(prev, cur);
  ASSERT_GT(matches.size(), 100u);
  std::vector<int> prev_used(prev.size()), cur_used(cur.size());
  for (const auto& m : matches) {
    EXPECT_EQ(++prev_used[m.prev], 1);
    EXPECT_EQ(++cur_used[m.cur], 1);
    EXPECT_EQ(prev.features[m.prev].cls, cur.features[m.cur].cls);
  }
}

TEST(Matcher, QueryCapSearchesHighestPriorityFeaturesFirst) {
  // One query per class and bin: the matched previous features must be exactly the prioritised
  // ones wherever a prioritised feature found its match (and never a feature of lower priority in
  // a group that holds a prioritised one).
  const cv::Mat img = texture(320, 240, 7);
  FeatureFrame prev, cur;
  extractFeatures(img, {}, cv::Mat(), &prev);
  extractFeatures(shifted(img, 2.0, 1.0), {}, cv::Mat(), &cur);
  std::vector<int> priority(prev.size(), 0);
  for (int i = 0; i < prev.size(); i += 3) priority[i] = 5;  // e.g. features on old tracks
  MatcherOptions capped;
  capped.max_queries_per_bin = 1;
  MatchStats stats;
  const auto matches = Matcher(capped).match(prev, cur, nullptr, &stats, &priority);
  const int groups = static_cast<int>(prev.bin_begin.size()) - 1;
  int non_empty = 0;
  for (int g = 0; g < groups; ++g) non_empty += prev.bin_begin[g + 1] > prev.bin_begin[g];
  EXPECT_EQ(stats.queries, non_empty);
  ASSERT_GT(matches.size(), 20u);
  std::vector<int> group_of(prev.size());
  for (int g = 0; g < groups; ++g)
    for (int i = prev.bin_begin[g]; i < prev.bin_begin[g + 1]; ++i) group_of[i] = g;
  for (const auto& m : matches) {
    const int g = group_of[m.prev];
    bool group_has_priority = false;
    for (int i = prev.bin_begin[g]; i < prev.bin_begin[g + 1]; ++i)
      group_has_priority |= priority[i] > 0;
    if (group_has_priority) {
      EXPECT_GT(priority[m.prev], 0) << "feature " << m.prev;
    }
    const Vec2 flow = m.px_cur - m.px_prev;
    EXPECT_LT((flow - Vec2(2.0, 1.0)).norm(), 1.0);
  }
  // Uncapped, every feature is a query and more matches are found.
  MatchStats all_stats;
  const auto all = Matcher().match(prev, cur, nullptr, &all_stats, &priority);
  EXPECT_EQ(all_stats.queries, prev.size());
  EXPECT_GT(all.size(), 2 * matches.size());
}

TEST(Delaunay, TrianglesOfASquareWithCentre) {
  const std::vector<Vec2> pts = {{0, 0}, {10, 0}, {10, 10}, {0, 10}, {5, 5}};
  const auto tris = delaunayTriangles(pts);
  ASSERT_EQ(tris.size(), 4u);
  for (const auto& t : tris) {
    EXPECT_TRUE(t[0] == 4 || t[1] == 4 || t[2] == 4);  // every triangle uses the centre
  }
}

TEST(Delaunay, SupportFilterRemovesPlantedFlowOutliers) {
  std::vector<Vec2> px, flow;
  for (int v = 0; v < 12; ++v)
    for (int u = 0; u < 15; ++u) {
      px.emplace_back(20.0 + 40.0 * u + 3.0 * ((u * 7 + v * 3) % 5), 20.0 + 40.0 * v);
      flow.emplace_back(3.0 + 0.1 * u, -1.0);
    }
  const std::vector<int> outliers = {16 + 1, 15 * 5 + 7, 15 * 8 + 3, 15 * 10 + 12};
  for (int i : outliers) flow[i] = Vec2(25.0, 9.0);
  const auto keep = delaunaySupportFilter(px, flow, 5.0, 4);
  for (int i : outliers) EXPECT_EQ(keep[i], 0) << i;
  int kept = 0;
  for (auto k : keep) kept += k;
  // Points on the convex hull have few edges and may drop; the interior must stay.
  EXPECT_GE(kept, static_cast<int>(0.9 * (px.size() - outliers.size())));
}

TEST(Bucketing, KeepsHighestPriorityThenLowestCostPerBucket) {
  std::vector<Match> matches(5);
  matches[0].px_cur = {10, 10}, matches[0].cost = 50;
  matches[1].px_cur = {20, 30}, matches[1].cost = 10;
  matches[2].px_cur = {40, 5}, matches[2].cost = 30;
  matches[3].px_cur = {60, 10}, matches[3].cost = 90;  // another bucket
  matches[4].px_cur = {45, 45}, matches[4].cost = 20;
  const std::vector<int> age = {1, 1, 5, 1, 1};
  const auto keep = bucketMatches(matches, age, 50, 2);
  EXPECT_EQ(keep, (std::vector<std::uint8_t>{0, 1, 1, 1, 0}));
}

}  // namespace
}  // namespace ovo::frontend
