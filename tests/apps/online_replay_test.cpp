// `ovo run --realtime`'s replay clock: which sensor times it runs over.
#include "apps/online_replay.hpp"

#include <gtest/gtest.h>

namespace ovo::app {
namespace {

constexpr Timestamp kEpoch = 1'700'000'000'000'000'000;  // 2023, in ns

io::Dataset framesAt(std::initializer_list<Timestamp> times) {
  io::Dataset d;
  for (Timestamp t : times) d.images.push_back({t, "frame.png"});
  return d;
}

ImuSample gyroAt(Timestamp t) {
  ImuSample s;
  s.t_ns = t;
  return s;
}

TEST(ReplaySpan, RunsFromTheFirstFrameToTheLast) {
  io::Dataset d = framesAt({kEpoch + 50'000'000, kEpoch + 100'000'000, kEpoch + 150'000'000});
  d.imu = {gyroAt(kEpoch), gyroAt(kEpoch + 200'000'000)};
  const ReplaySpan span = replaySpan(d);
  EXPECT_EQ(span.begin_ns, kEpoch + 50'000'000);
  EXPECT_EQ(span.end_ns, kEpoch + 150'000'000);
  EXPECT_EQ(span.clamp(kEpoch + 120'000'000), kEpoch + 120'000'000);
}

TEST(ReplaySpan, AStrayGyroStampDecadesEarlyOrLateIsHandedOverAtOnce) {
  // A driver's first sample stamped 0 in an epoch-stamped recording: the replay clock started
  // there and slept 54 years before the first frame.
  io::Dataset d = framesAt({kEpoch, kEpoch + 50'000'000});
  d.imu = {gyroAt(0), gyroAt(kEpoch), gyroAt(kEpoch + 50'000'000), gyroAt(4 * kEpoch)};
  const ReplaySpan span = replaySpan(d);
  EXPECT_EQ(span.clamp(0), kEpoch);                        // due at once, at the start
  EXPECT_EQ(span.clamp(4 * kEpoch), kEpoch + 50'000'000);  // due with the last frame
  EXPECT_EQ(span.clamp(kEpoch + 25'000'000) - span.begin_ns, 25'000'000);
}

TEST(ReplaySpan, WithoutFramesCoversEverySensor) {
  io::Dataset d;
  d.imu = {gyroAt(kEpoch + 10), gyroAt(kEpoch + 30)};
  LidarScan scan;
  scan.t_ns = kEpoch;
  d.scans = {scan};
  const ReplaySpan span = replaySpan(d);
  EXPECT_EQ(span.begin_ns, kEpoch);
  EXPECT_EQ(span.end_ns, kEpoch + 30);
  EXPECT_EQ(replaySpan(io::Dataset{}).clamp(kEpoch), 0);  // nothing to replay
}

}  // namespace
}  // namespace ovo::app
