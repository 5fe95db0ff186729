// Track bookkeeping and the Frontend end to end on synthetic and real images.
#include "frontend/tracker.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "camera/calib_io.hpp"
#include "frontend/frontend.hpp"
#include "frontend/mask.hpp"
#include "tests/frontend/test_images.hpp"
#include "tests/test_support.hpp"

namespace ovo::frontend {
namespace {

TEST(TrackManager, MatchedFeaturesKeepTheirIdAndAge) {
  TrackManager tracks;
  const std::vector<Vec3> b3(3, Vec3::UnitZ());
  tracks.update(0, 0, {{1, 1}, {2, 2}, {3, 3}}, b3, {0, 1, 2}, {-1, -1, -1});
  const auto ids0 = tracks.currentIds();
  EXPECT_EQ(std::set<std::uint64_t>(ids0.begin(), ids0.end()).size(), 3u);
  // Frame 1: feature 0 continues previous 2, feature 1 is new, feature 2 continues previous 0.
  tracks.update(1, 10, {{3.5, 3}, {9, 9}, {1.5, 1}}, b3, {2, 3, 0}, {2, -1, 0});
  const auto ids1 = tracks.currentIds();
  EXPECT_EQ(ids1[0], ids0[2]);
  EXPECT_EQ(ids1[2], ids0[0]);
  EXPECT_NE(ids1[1], ids0[0]);
  EXPECT_NE(ids1[1], ids0[1]);
  EXPECT_NE(ids1[1], ids0[2]);
  EXPECT_EQ(tracks.find(ids0[1]), nullptr);      // ended
  EXPECT_TRUE(tracks.finishedTracks().empty());  // it lived one frame only
  const Track* t = tracks.find(ids0[2]);
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->age, 2);
  ASSERT_EQ(t->history.size(), 2u);
  EXPECT_EQ(t->history[0].frame_index, 0);
  EXPECT_EQ(t->history[1].px, Vec2(3.5, 3));
  EXPECT_EQ(t->history[1].t_ns, 10);
  // Frame 2: only the new track continues; the two age-2 tracks finish.
  tracks.update(2, 20, {{9, 10}}, {Vec3::UnitZ()}, {3}, {1});
  EXPECT_EQ(tracks.currentIds()[0], ids1[1]);
  EXPECT_EQ(tracks.finishedTracks().size(), 2u);
  const auto obs = tracks.currentObservations();
  ASSERT_EQ(obs.size(), 1u);
  EXPECT_EQ(obs[0].age, 2);
  EXPECT_EQ(obs[0].feature_class, 3);
}

TEST(TrackManager, HistoryCapKeepsTheNewestButCountsAge) {
  TrackManager tracks(TrackerOptions{2});
  tracks.update(0, 0, {{0, 0}}, {Vec3::UnitZ()}, {0}, {-1});
  for (int k = 1; k < 5; ++k) tracks.update(k, k, {{double(k), 0}}, {Vec3::UnitZ()}, {0}, {0});
  const Track* t = tracks.find(tracks.currentIds()[0]);
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->age, 5);
  ASSERT_EQ(t->history.size(), 2u);
  EXPECT_EQ(t->history[0].frame_index, 3);
  EXPECT_EQ(t->last().frame_index, 4);
}

TEST(TrackManager, CappedHistoryHoldsExactlyTheNewestSightingsEveryFrame) {
  // The cap drops old sightings in blocks internally; what a reader sees is always the newest 3.
  TrackManager tracks(TrackerOptions{3});
  tracks.update(0, 0, {{0, 0}}, {Vec3::UnitZ()}, {0}, {-1});
  for (int k = 1; k < 12; ++k) {
    tracks.update(k, 10 * k, {{double(k), 0}}, {Vec3::UnitZ()}, {0}, {0});
    const TrackHistory& h = tracks.current(0).history;
    ASSERT_EQ(h.size(), static_cast<std::size_t>(std::min(k + 1, 3)));
    for (std::size_t i = 0; i < h.size(); ++i) {
      EXPECT_EQ(h[i].frame_index, k + 1 - static_cast<int>(h.size()) + static_cast<int>(i));
    }
    EXPECT_EQ(h.rbegin()->frame_index, k);
    EXPECT_EQ(std::prev(h.rend())->frame_index, h.front().frame_index);
  }
}

TEST(TrackManager, DefaultHistoryCoversTheVoChainAndKfSpans) {
  // vo.max_reference_frames = 6 and kf.lidar_baseline_s = 0.6 s at 20 Hz (12 frames).
  EXPECT_GE(TrackerOptions{}.max_history, 13);
}

TEST(TrackManager, NewTracksStartCleanAfterLongTracksEnd) {
  // Long tracks end and new ones take their place (reusing their storage): a new track has one
  // observation, age 1, its own class and a fresh id; the finished tracks keep their history.
  TrackManager tracks;
  const std::vector<Vec3> b2(2, Vec3::UnitZ());
  tracks.update(0, 0, {{0, 0}, {5, 5}}, b2, {1, 2}, {-1, -1});
  for (int k = 1; k < 4; ++k)
    tracks.update(k, k, {{double(k), 0}, {5, 5.0 + k}}, b2, {1, 2}, {0, 1});
  const auto old_ids = tracks.currentIds();
  tracks.update(4, 4, {{50, 50}, {60, 60}}, b2, {0, 3}, {-1, -1});
  ASSERT_EQ(tracks.finishedTracks().size(), 2u);
  for (const Track& t : tracks.finishedTracks()) EXPECT_EQ(t.history.size(), 4u);
  tracks.update(5, 5, {{51, 50}, {70, 70}}, b2, {0, 2}, {0, -1});
  for (int j = 0; j < 2; ++j) {
    const Track& t = tracks.current(j);
    EXPECT_GT(t.id, old_ids[0]);
    EXPECT_GT(t.id, old_ids[1]);
  }
  EXPECT_EQ(tracks.current(0).age, 2);
  EXPECT_EQ(tracks.current(0).history.size(), 2u);
  EXPECT_EQ(tracks.current(0).feature_class, 0);
  EXPECT_EQ(tracks.current(1).age, 1);
  ASSERT_EQ(tracks.current(1).history.size(), 1u);
  EXPECT_EQ(tracks.current(1).last().px, Vec2(70, 70));
  EXPECT_EQ(tracks.current(1).feature_class, 2);
  EXPECT_EQ(tracks.find(old_ids[0]), nullptr);
}

TEST(TrackManager, ALongTracksBufferIsNotLentWholeToANewTrack) {
  // A track that lived 40 frames had room for up to twice the 32 newest sightings; when it ends,
  // the new track that takes its buffer gets one with little room (a pool of such buffers made a
  // long run's memory grow).
  TrackManager tracks;
  const std::vector<Vec3> b(1, Vec3::UnitZ());
  tracks.update(0, 0, {{0, 0}}, b, {0}, {-1});
  for (int k = 1; k < 40; ++k) tracks.update(k, k, {{double(k), 0}}, b, {0}, {0});
  ASSERT_GE(tracks.current(0).history.capacity(), 32u);
  tracks.update(40, 40, {{50, 50}}, b, {0}, {-1});  // the long track ends
  tracks.update(41, 41, {{60, 60}}, b, {0}, {-1});  // a new track takes its buffer
  EXPECT_EQ(tracks.current(0).history.size(), 1u);
  EXPECT_LE(tracks.current(0).history.capacity(), 8u);
  ASSERT_EQ(tracks.finishedTracks().size(), 0u);
  // The new track grows as any other.
  for (int k = 42; k < 80; ++k) tracks.update(k, k, {{double(k), 0}}, b, {0}, {0});
  EXPECT_EQ(tracks.current(0).history.size(), 32u);
  EXPECT_EQ(tracks.current(0).history.back().frame_index, 79);
}

camera::Camera pinhole640() {
  return camera::PinholeRadtanCamera(500, 500, 319.5, 239.5, 640, 480);
}

TEST(Frontend, TracksKeepTheirIdsAcrossFramesOfATranslatingTexture) {
  const cv::Mat big = synth::texture(800, 600, 11);
  const Vec2 step(2.4, 1.3);  // px per frame
  Frontend frontend(pinhole640(), FrontendOptions{});
  std::vector<FrontendResult> results;
  for (int k = 0; k < 4; ++k) {
    const cv::Mat moved = synth::shifted(big, k * step.x(), k * step.y());
    cv::Mat grey = moved(cv::Rect(80, 60, 640, 480)).clone();
    results.push_back(frontend.process(k * 100'000'000LL, grey));
  }
  EXPECT_FALSE(results[0].relative_pose.has_value());
  ASSERT_TRUE(results[3].relative_pose.has_value());
  EXPECT_GT(results[3].matches.size(), 300u);
  // Tracks seen in all four frames moved by the known flow in every step.
  int long_tracks = 0;
  double max_err = 0.0;
  for (const auto& obs : results[3].observations) {
    if (obs.age < 4) continue;
    const Track* t = frontend.tracks().find(obs.track_id);
    ASSERT_NE(t, nullptr);
    ASSERT_EQ(t->history.size(), 4u);
    for (int k = 1; k < 4; ++k) {
      EXPECT_EQ(t->history[k].frame_index, k);
      const Vec2 flow = t->history[k].px - t->history[k - 1].px;
      max_err = std::max(max_err, (flow - step).norm());
    }
    EXPECT_NEAR(t->last().bearing_C.norm(), 1.0, 1e-9);
    ++long_tracks;
  }
  EXPECT_GT(long_tracks, 500);
  EXPECT_LT(max_err, 1.0);
  // Ids are unique within a frame.
  std::set<std::uint64_t> ids;
  for (const auto& obs : results[3].observations) EXPECT_TRUE(ids.insert(obs.track_id).second);
}

TEST(Frontend, MaskKeepsFeaturesInsideTheFisheyeCircle) {
  // Equidistant fisheye whose model domain ends at 100 degrees off-axis: a circle inside the image.
  camera::KannalaBrandtParams p;
  p.fx = p.fy = 120.0;
  p.cx = 319.5;
  p.cy = 239.5;
  p.width = 640;
  p.height = 480;
  const camera::Camera cam = camera::KannalaBrandtCamera(p);
  FrontendOptions options;
  options.mask_border_px = 6;
  Frontend frontend(cam, options);
  const cv::Mat& mask = frontend.mask();
  int masked_out = 0;
  for (int v = 0; v < 480; v += 3)
    for (int u = 0; u < 640; u += 3) {
      if (!mask.at<std::uint8_t>(v, u)) {
        ++masked_out;
        continue;
      }
      for (int dv = -6; dv <= 6; dv += 6)
        for (int du = -6; du <= 6; du += 6)
          ASSERT_TRUE(camera::isValid(cam, Vec2(u + du, v + dv))) << u << "," << v;
    }
  const auto result = frontend.process(0, synth::texture(640, 480, 12));
  ASSERT_GT(result.num_features, 100);
  for (const auto& obs : result.observations) {
    EXPECT_TRUE(mask.at<std::uint8_t>(int(obs.px.y()), int(obs.px.x())));
    EXPECT_NEAR(obs.bearing_C.norm(), 1.0, 1e-6);
  }
  std::printf("  masked-out fraction %.2f, features %d\n", masked_out / (214.0 * 160.0),
              result.num_features);
}

TEST(FrontendRealData, KittiFramesZeroToTwoGiveHundredsOfMatchesAndForwardMotion) {
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000002.png");
  const cv::Mat f0 = cv::imread(test::sharedData("kitti07-first160/image_0/000000.png").string(),
                                cv::IMREAD_GRAYSCALE);
  const cv::Mat f1 = cv::imread(test::sharedData("kitti07-first160/image_0/000002.png").string(),
                                cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(f0.cols, 1226);
  const camera::Camera cam =
      camera::PinholeRadtanCamera(707.0912, 707.0912, 601.8873, 183.1104, f0.cols, f0.rows);
  FrontendOptions options;
  options.relative_pose.backend = "serial";
  Frontend frontend(cam, options);
  frontend.process(0, f0);
  const auto r = frontend.process(100'000'000, f1);
  std::printf(
      "  KITTI 0->2: features %d, circle matches %d, after Delaunay %d, bucketed %zu, "
      "inliers %d, status %s\n",
      r.num_features, r.match_stats.circle_matches, r.num_matches_before_bucketing,
      r.matches.size(), r.relative_pose->num_inliers,
      std::string(toString(r.relative_pose->status)).c_str());
  EXPECT_GT(r.num_matches_before_bucketing, 300);
  EXPECT_GT(r.matches.size(), 200u);
  ASSERT_EQ(r.relative_pose->status, RelativePoseResult::Status::kOk);
  EXPECT_GT(r.relative_pose->num_inliers, static_cast<int>(r.matches.size() * 7 / 10));
  // The car drives forward: X_cur = R X_prev + t with t along -z.
  EXPECT_LT(r.relative_pose->t_cur_prev.z(), -0.9);
}

TEST(FrontendRealData, OcamSampleShiftedImageRecoversTheShift) {
  OVO_REQUIRE_DATA("ocam-scaramuzza-sample/test_fisheye.jpg");
  const camera::Camera cam =
      camera::loadCamera(test::sharedData("ocam-scaramuzza-sample/calib_results_fisheye.txt"));
  const cv::Mat img = cv::imread(
      test::sharedData("ocam-scaramuzza-sample/test_fisheye.jpg").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(img.cols, camera::width(cam));
  const Vec2 shift(2.6, -1.4);
  Frontend frontend(cam, FrontendOptions{});
  frontend.process(0, img);
  const auto r = frontend.process(1, synth::shifted(img, shift.x(), shift.y()));
  // The checkerboard's long straight edges give features whose descriptors repeat along the edge
  // (aperture problem): a fifth of these matches slide along an edge and are left to RANSAC, so
  // this checks the median flow and a large majority of exact matches.
  ASSERT_GT(r.matches.size(), 200u);
  std::vector<double> flow_u, flow_v;
  Vec2 mean = Vec2::Zero();
  int wrong = 0;
  for (std::size_t k = 0; k < r.matches.size(); ++k) {
    const Vec2 flow = r.matches.px_cur[k] - r.matches.px_prev[k];
    flow_u.push_back(flow.x());
    flow_v.push_back(flow.y());
    if ((flow - shift).norm() > 1.0) {
      ++wrong;
      if (std::getenv("OVO_DEBUG_MATCHES"))
        std::printf("wrong %.1f %.1f -> %.1f %.1f  err %.1f %.1f\n", r.matches.px_prev[k].x(),
                    r.matches.px_prev[k].y(), r.matches.px_cur[k].x(), r.matches.px_cur[k].y(),
                    (flow - shift).x(), (flow - shift).y());
    }
    mean += flow;
  }
  mean /= static_cast<double>(r.matches.size());
  if (const char* dump = std::getenv("OVO_DEBUG_DUMP")) {
    cv::Mat vis;
    cv::cvtColor(img, vis, cv::COLOR_GRAY2BGR);
    for (std::size_t k = 0; k < r.matches.size(); ++k) {
      const Vec2 flow = r.matches.px_cur[k] - r.matches.px_prev[k];
      const bool bad = (flow - shift).norm() > 1.0;
      cv::circle(vis, cv::Point(r.matches.px_cur[k].x(), r.matches.px_cur[k].y()), 3,
                 bad ? cv::Scalar(0, 0, 255) : cv::Scalar(0, 255, 0));
    }
    cv::imwrite(dump, vis);
  }
  std::printf("  ocam sample: features %d, matches %d (bucketed %zu), mean flow (%.3f, %.3f)\n",
              r.num_features, r.num_matches_before_bucketing, r.matches.size(), mean.x(), mean.y());
  const auto median = [](std::vector<double> x) {
    std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
    return x[x.size() / 2];
  };
  std::printf("  median flow (%.3f, %.3f), %d of %zu off by more than 1 px\n", median(flow_u),
              median(flow_v), wrong, r.matches.size());
  EXPECT_GT(r.num_matches_before_bucketing, 500);
  EXPECT_LT(wrong, static_cast<int>(r.matches.size()) * 3 / 10);
  // Sharp real edges pull the SSD parabola towards whole pixels (about 0.17 px here, against
  // 0.02 px on the smooth synthetic texture).
  EXPECT_NEAR(median(flow_u), shift.x(), 0.25);
  EXPECT_NEAR(median(flow_v), shift.y(), 0.25);
}

}  // namespace
}  // namespace ovo::frontend
