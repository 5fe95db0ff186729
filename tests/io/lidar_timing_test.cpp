// The LiDAR CSV with and without per-beam times, and the rig's camera timing keys.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>

#include "io/dataset.hpp"
#include "io/dataset_writer.hpp"
#include "tests/test_support.hpp"

namespace ovo::io {
namespace {

namespace fs = std::filesystem;
using test::errorOf;

std::vector<LidarScan> someScans(double time_increment_s) {
  std::vector<LidarScan> scans(2);
  for (std::size_t k = 0; k < scans.size(); ++k) {
    LidarScan& s = scans[k];
    s.t_ns = 1'000'000'000 + static_cast<Timestamp>(k) * 100'000'000;
    s.angle_min_rad = -2.356194490192345;
    s.angle_increment_rad = 0.008726646259971648;
    s.range_min_m = 0.1;
    s.range_max_m = 12.0;
    s.time_increment_s = time_increment_s;
    s.ranges_m = {1.2345678901234567, std::numeric_limits<double>::quiet_NaN(), 3.0 + 0.1 * k,
                  11.999999999999998};
  }
  return scans;
}

fs::path writeScans(const fs::path& out, const std::vector<LidarScan>& scans) {
  DatasetWriter writer(out);
  writer.writeLidar(scans);
  writer.commit();
  return out / "lidar0" / "data.csv";
}

void expectSame(const std::vector<LidarScan>& a, const std::vector<LidarScan>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].t_ns, b[k].t_ns);
    EXPECT_EQ(a[k].angle_min_rad, b[k].angle_min_rad);
    EXPECT_EQ(a[k].angle_increment_rad, b[k].angle_increment_rad);
    EXPECT_EQ(a[k].range_min_m, b[k].range_min_m);
    EXPECT_EQ(a[k].range_max_m, b[k].range_max_m);
    EXPECT_EQ(a[k].time_increment_s, b[k].time_increment_s);
    ASSERT_EQ(a[k].ranges_m.size(), b[k].ranges_m.size());
    for (std::size_t i = 0; i < a[k].ranges_m.size(); ++i)
      EXPECT_TRUE(a[k].ranges_m[i] == b[k].ranges_m[i] ||
                  (std::isnan(a[k].ranges_m[i]) && std::isnan(b[k].ranges_m[i])));
  }
}

TEST(LidarTiming, PerBeamTimesRoundTripExactly) {
  const std::vector<LidarScan> scans = someScans(0.1 * 0.5 / 360.0);
  const fs::path csv = writeScans(test::tempDir() / "out", scans);
  bool beam_times = false;
  const std::vector<LidarScan> back = readLidarCsv(csv, &beam_times);
  EXPECT_TRUE(beam_times);
  expectSame(scans, back);
  Dataset ds;
  ds.scans = back;
  EXPECT_TRUE(lidarTimingNotes(ds).empty());
}

TEST(LidarTiming, InstantaneousScansKeepThePlainLayoutAndReadWithANote) {
  const std::vector<LidarScan> scans = someScans(0.0);
  const fs::path csv = writeScans(test::tempDir() / "out", scans);
  std::ifstream in(csv);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header,
            "#timestamp [ns],angle_min [rad],angle_increment [rad],range_min [m],range_max [m],"
            "ranges [m]...");
  bool beam_times = true;
  const std::vector<LidarScan> back = readLidarCsv(csv, &beam_times);
  EXPECT_FALSE(beam_times);
  expectSame(scans, back);
  Dataset ds;
  ds.scans = back;
  const auto notes = lidarTimingNotes(ds);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_CONTAINS(notes[0], "taken as instantaneous");
}

TEST(LidarTiming, AnOldFileWithoutHeaderOrTimesStillReads) {
  const fs::path csv = test::tempDir() / "data.csv";
  test::writeTextFile(csv,
                      "1000000000,-1.5,0.5,0.1,30,1.0,nan,2.5\n1100000000,-1.5,0.5,0.1,30,1,2,3\n");
  bool beam_times = true;
  const std::vector<LidarScan> scans = readLidarCsv(csv, &beam_times);
  EXPECT_FALSE(beam_times);
  ASSERT_EQ(scans.size(), 2u);
  EXPECT_EQ(scans[0].time_increment_s, 0.0);
  EXPECT_EQ(scans[0].range_min_m, 0.1);
  EXPECT_EQ(scans[0].ranges_m.size(), 3u);
  EXPECT_EQ(scans[1].ranges_m[2], 3.0);
}

std::string repeat(const std::string& s, int n) {
  std::string out;
  for (int i = 0; i < n; ++i) out += s;
  return out;
}

TEST(LidarTiming, BadTimedFilesNameTheLine) {
  const std::string header =
      "#timestamp [ns],angle_min [rad],angle_increment [rad],time_increment [s],range_min [m],"
      "range_max [m],ranges [m]...\n";
  const struct {
    const char* name;
    std::string content;
    const char* expected;
  } cases[] = {
      {"short", header + "1000000000,-1.5,0.5,0.0001,0.1,30\n",
       "data.csv:2: expected t[ns], angle_min, angle_increment, time_increment, range_min"},
      {"bad_time", header + "1000000000,-1.5,0.5,abc,0.1,30,1,2\n",
       "data.csv:2: expected a number for time_increment [s]"},
      // 2 ms a beam over 541 beams: a scan of a second: milliseconds taken for seconds.
      {"too_long", header + "1000000000,-1.5,0.5,0.002,0.1,30" + repeat(",1", 541) + "\n",
       "data.csv:2: time_increment 0.002 s makes the scan's 541 beams last over 1 s"},
      {"ms", header + "1000000000,-1.5,0.5,0.6,0.1,30,1,2,3\n",
       "data.csv:2: time_increment 0.6 s makes the scan's 3 beams last over 1 s"},
  };
  for (const auto& c : cases) {
    const fs::path csv = test::tempDir() / c.name / "data.csv";
    test::writeTextFile(csv, c.content);
    EXPECT_CONTAINS(errorOf([&] { readLidarCsv(csv); }), c.expected) << c.name;
  }
}

TEST(LidarTiming, RigCameraTimingKeysRoundTripAndAreCheckedAndLeftOutWhenZero) {
  RigInfo rig;
  rig.has_rig_file = true;
  rig.camera_time_offset_s = -0.02;
  rig.camera_rolling_shutter_s = 0.027;
  const fs::path out = test::tempDir() / "out";
  {
    DatasetWriter writer(out);
    writer.writeRig(rig);
    writer.commit();
  }
  const RigInfo back = readRigYaml(out / "rig.yaml");
  EXPECT_EQ(back.camera_time_offset_s, -0.02);
  EXPECT_EQ(back.camera_rolling_shutter_s, 0.027);
  // Zero: not written (rig files of datasets made before stay as they were), read as zero.
  const fs::path out0 = test::tempDir() / "out0";
  {
    DatasetWriter writer(out0);
    writer.writeRig(RigInfo{});
    writer.commit();
  }
  std::ifstream in(out0 / "rig.yaml");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text.find("time_offset_s"), std::string::npos);
  EXPECT_EQ(text.find("rolling_shutter_s"), std::string::npos);
  EXPECT_EQ(readRigYaml(out0 / "rig.yaml").camera_time_offset_s, 0.0);
  const fs::path bad = test::tempDir() / "bad.yaml";
  test::writeTextFile(bad, "camera: {rate_hz: 20.0, time_offset_s: 3}\n");
  EXPECT_CONTAINS(errorOf([&] { readRigYaml(bad); }), "camera.time_offset_s");
  test::writeTextFile(bad, "camera: {rate_hz: 20.0, rolling_shutter_s: -0.01}\n");
  EXPECT_CONTAINS(errorOf([&] { readRigYaml(bad); }), "camera.rolling_shutter_s");
}

}  // namespace
}  // namespace ovo::io
