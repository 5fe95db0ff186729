// End to end on a short real KITTI clip: `ovo run --realtime` reports latency and dropped frames,
// `ovo run` writes report.html, and ovo_live_camera runs a video file with a gyro csv on stdin,
// ends cleanly at Ctrl-C and fails clearly without a camera.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>

#include "camera/calib_io.hpp"
#include "common/config.hpp"
#include "io/dataset.hpp"
#include "tests/apps/online_test_data.hpp"

namespace ovo::test {
namespace {

namespace fs = std::filesystem;

#define OVO_REQUIRE_PROGRAM(path) \
  if (!fs::exists(path)) GTEST_SKIP() << "not built: " << (path).string()

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// `ovo run --dataset data --estimator window --quiet <extra> --out dir/name`; the run must succeed.
void runWindowInto(const fs::path& data, const fs::path& dir, const std::string& name,
                   const std::string& extra) {
  std::string out;
  const int code = runShell("'" + ovoBinaryPath().string() + "' run --dataset '" + data.string() +
                                "' --estimator window --quiet " + extra + " --out '" +
                                (dir / name).string() + "'",
                            dir, &out);
  EXPECT_EQ(code, 0) << out;
}

TEST(OnlineRun, RealtimeReplayReportsLatencyAndDroppedFrames) {
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  OVO_REQUIRE_PROGRAM(ovoBinaryPath());
  const fs::path dir = tempDir();
  const fs::path data = makeMiniKitti(dir / "kitti", 20);
  std::string out;
  const int code = runShell("'" + ovoBinaryPath().string() + "' run --dataset '" + data.string() +
                                "' --estimator vo --realtime --rate 2 --quiet --out '" +
                                (dir / "run").string() + "'",
                            dir, &out);
  ASSERT_EQ(code, 0) << out;
  const auto m = nlohmann::json::parse(slurp(dir / "run" / "metrics.json"));
  ASSERT_TRUE(m.contains("latency_ms_median")) << m.dump(2);
  ASSERT_TRUE(m.contains("latency_ms_p99"));
  ASSERT_TRUE(m.contains("frames_dropped"));
  EXPECT_EQ(m["frames_in"].get<int>(), 20);
  EXPECT_EQ(m["frames"].get<int>() + m["frames_dropped"].get<int>(), 20);
  EXPECT_GT(m["latency_ms_median"].get<double>(), 0.0);
  EXPECT_GE(m["latency_ms_p99"].get<double>(), m["latency_ms_median"].get<double>());
  EXPECT_NEAR(m["realtime_rate"].get<double>(), 2.0, 1e-12);
  const std::string report = slurp(dir / "run" / "report.html");
  EXPECT_NE(report.find("latency (online)"), std::string::npos);
}

TEST(OnlineRun, OfflineRunWritesAReportWithTheGroundTruthPlots) {
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  OVO_REQUIRE_PROGRAM(ovoBinaryPath());
  const fs::path dir = tempDir();
  const fs::path data = makeMiniKitti(dir / "kitti", 8);
  std::string out;
  const int code = runShell("'" + ovoBinaryPath().string() + "' run --dataset '" + data.string() +
                                "' --estimator vo --quiet --out '" + (dir / "run").string() + "'",
                            dir, &out);
  ASSERT_EQ(code, 0) << out;
  const std::string report = slurp(dir / "run" / "report.html");
  std::size_t svgs = 0;
  for (auto p = report.find("<svg"); p != std::string::npos; p = report.find("<svg", p + 1)) ++svgs;
  // Top view, position error, yaw error; position, heading and scale error against the
  // distance; timing, CPU per frame, memory (vo has no gyro bias).
  EXPECT_EQ(svgs, 9u);
  EXPECT_NE(report.find("Drift against the distance driven"), std::string::npos);
  EXPECT_NE(report.find("Resident memory"), std::string::npos);
  EXPECT_NE(report.find("ground truth"), std::string::npos);
  EXPECT_EQ(report.find("latency"), std::string::npos);  // offline: no latency
}

// --threads 1 (issue 43's one-core mode): the same poses as the default two-stage run, the
// limit recorded in metrics.json. (That the process then keeps one core busy was checked by hand:
// one thread at 99 %, two near idle; timings are not asserted in tests.)
TEST(OnlineRun, OneThreadGivesTheSamePoses) {
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  OVO_REQUIRE_PROGRAM(ovoBinaryPath());
  const fs::path dir = tempDir();
  const fs::path data = makeMiniKitti(dir / "kitti", 12);
  runWindowInto(data, dir, "all", "");
  runWindowInto(data, dir, "one", "--threads 1");
  EXPECT_EQ(slurp(dir / "one" / "trajectory.txt"), slurp(dir / "all" / "trajectory.txt"));
  const auto m = nlohmann::json::parse(slurp(dir / "one" / "metrics.json"));
  EXPECT_EQ(m["timing"]["threads"].get<int>(), 1);
  EXPECT_EQ(nlohmann::json::parse(slurp(dir / "all" / "metrics.json"))["timing"]["threads"], 0);
}

// --realtime gives the window a time budget per solve (issue 43) unless the configuration sets
// one; the run's config.yaml says which was used. (On vineyard_row, 2 cores or one, the 0.04 s
// budget changed the ATE by at most 0.13 mm: a safety net for slower computers.)
TEST(OnlineRun, RealtimeWindowSolvesWithinATimeBudget) {
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  OVO_REQUIRE_PROGRAM(ovoBinaryPath());
  const fs::path dir = tempDir();
  const fs::path data = makeMiniKitti(dir / "kitti", 6);
  const auto budgetOf = [&](const std::string& extra, const std::string& name) {
    runWindowInto(data, dir, name, extra);
    const Config used = Config::load(dir / name / "config.yaml");
    return used.get<double>("window.max_solver_time_s", -1.0);
  };
  EXPECT_DOUBLE_EQ(budgetOf("--realtime --rate 4", "online"), 0.04);
  EXPECT_DOUBLE_EQ(budgetOf("--realtime --rate 4 --set window.max_solver_time_s=0.2", "set"), 0.2);
  EXPECT_EQ(budgetOf("", "offline"), -1.0);  // offline: the built-in default (none), not written
}

TEST(LiveCamera, FailsWithAClearMessageWhenThereIsNoCamera) {
  OVO_REQUIRE_DATA("romovi-fisheye-calib/calib_results.txt");
  OVO_REQUIRE_PROGRAM(liveCameraBinaryPath());
  const fs::path dir = tempDir();
  std::string out;
  const int code = runShell("'" + liveCameraBinaryPath().string() + "' --camera 97 --calib '" +
                                sharedData("romovi-fisheye-calib/calib_results.txt").string() +
                                "' --no-gyro < /dev/null",
                            dir, &out);
  EXPECT_EQ(code, 2) << out;
  EXPECT_NE(out.find("cannot open camera 97"), std::string::npos) << out;
}

// A short MJPG video of the first KITTI frames, its pinhole sensor.yaml and a gyro csv.
struct LiveInputs {
  fs::path video, calib, gyro;
  int frames = 0;
};
std::optional<LiveInputs> makeLiveInputs(const fs::path& dir, int frames) {
  const io::Dataset data = io::loadDataset(makeMiniKitti(dir / "kitti", frames));
  LiveInputs in;
  in.frames = frames;
  in.video = dir / "clip.avi";
  in.calib = dir / "sensor.yaml";
  in.gyro = dir / "gyro.csv";
  const cv::Mat first = io::loadImageGrey(data.images.front());
  cv::VideoWriter writer(in.video.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0,
                         first.size(), true);
  if (!writer.isOpened()) return std::nullopt;
  for (const auto& e : data.images) {
    cv::Mat bgr;
    cv::cvtColor(io::loadImageGrey(e), bgr, cv::COLOR_GRAY2BGR);
    writer.write(bgr);
  }
  writer.release();
  camera::writeSensorYaml(in.calib, *data.camera, data.rig.T_B_C, 10.0);
  std::ofstream gyro(in.gyro);
  gyro << "#t_ns,wx,wy,wz\n";
  for (int i = 0; i <= 200 * frames / 10 + 20; ++i) {
    gyro << i * 5'000'000LL << ",0.001,-0.002,0.0005\n";
    if (i == 3) gyro << "not,a,number\n";   // line 6 of the stream: warned about and skipped
    if (i == 5) gyro << "5000000,0,0,0\n";  // line 9: an old stamp, warned about and skipped
  }
  return in;
}

TEST(LiveCamera, RunsAVideoFileWithGyroFromStdinAndPrintsPoses) {
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  OVO_REQUIRE_PROGRAM(liveCameraBinaryPath());
  const fs::path dir = tempDir();
  const auto in = makeLiveInputs(dir, 12);
  if (!in) GTEST_SKIP() << "OpenCV cannot write an MJPG .avi here";
  std::string out;
  const fs::path err_file = dir / "stderr.txt";
  // (In a subshell: runShell's own 2>&1 would otherwise take standard error back.)
  const int code =
      runShell("('" + liveCameraBinaryPath().string() + "' --camera '" + in->video.string() +
                   "' --calib '" + in->calib.string() + "' --estimator vo --rate 2 < '" +
                   in->gyro.string() + "' 2> '" + err_file.string() + "')",
               dir, &out);
  const std::string err = slurp(err_file);
  ASSERT_EQ(code, 0) << out << err;
  // Messages go to standard error; standard output is the pose stream alone.
  EXPECT_NE(err.find("stdin:6: expected t_ns,wx,wy,wz"), std::string::npos) << err;
  EXPECT_NE(err.find("stdin:9: gyro time stamp 5000000 is not after the previous one"),
            std::string::npos)
      << err;
  EXPECT_NE(err.find("12 frames in"), std::string::npos) << err;
  // Pose lines: 8 numbers, times 0.0, 0.1, ... (frame index / 10 fps).
  std::istringstream lines(out);
  std::string line;
  int poses = 0;
  double last_t = -1;
  while (std::getline(lines, line)) {
    std::istringstream ls(line);
    double v[8];
    int n = 0;
    while (n < 8 && ls >> v[n]) ++n;
    ASSERT_EQ(n, 8) << "not a pose line on standard output: " << line;
    EXPECT_GT(v[0], last_t);
    last_t = v[0];
    ++poses;
  }
  EXPECT_GE(poses, 2);
  EXPECT_LE(poses, 12);
  EXPECT_NEAR(last_t, 1.1, 1e-6);  // the newest frame is never the one dropped
}

// A gyro stream none of whose lines can be used (here: angles in degrees with a unit) leaves the
// run vision-only; that is an error, not a quiet exit 0.
TEST(LiveCamera, FailsWhenNoGyroLineCanBeUsed) {
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  OVO_REQUIRE_PROGRAM(liveCameraBinaryPath());
  const fs::path dir = tempDir();
  const auto in = makeLiveInputs(dir, 6);
  if (!in) GTEST_SKIP() << "OpenCV cannot write an MJPG .avi here";
  {
    std::ofstream gyro(in->gyro);
    for (int i = 0; i < 10; ++i) gyro << i * 5'000'000LL << ",0.1 deg/s,0,0\n";
  }
  std::string out;
  const int code = runShell("'" + liveCameraBinaryPath().string() + "' --camera '" +
                                in->video.string() + "' --calib '" + in->calib.string() +
                                "' --estimator vo --rate 5 < '" + in->gyro.string() + "'",
                            dir, &out);
  EXPECT_EQ(code, 2) << out;
  EXPECT_NE(out.find("no gyro sample came on standard input (10 lines skipped)"), std::string::npos)
      << out;
  EXPECT_NE(out.find("--no-gyro"), std::string::npos) << out;
}

TEST(LiveCamera, EndsCleanlyOnCtrlC) {
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  OVO_REQUIRE_PROGRAM(liveCameraBinaryPath());
  const fs::path dir = tempDir();
  const auto in = makeLiveInputs(dir, 12);
  if (!in) GTEST_SKIP() << "OpenCV cannot write an MJPG .avi here";
  std::string out;
  // At 0.1x the clip would take 12 s; SIGINT after 3 s must end it with the summary, exit 0.
  const int code =
      runShell("timeout --preserve-status -s INT 3 '" + liveCameraBinaryPath().string() +
                   "' --camera '" + in->video.string() + "' --calib '" + in->calib.string() +
                   "' --estimator vo --rate 0.1 < '" + in->gyro.string() + "'",
               dir, &out);
  EXPECT_EQ(code, 0) << out;
  EXPECT_NE(out.find("frames in"), std::string::npos) << out;
}

// Signals that follow each other closely (a user's repeated Ctrl-C, or `timeout` signalling the
// process and then its group) must all land on the clean stop: none may find a library's one-shot
// handler reset to the default action and kill the run.
TEST(LiveCamera, ABurstOfInterruptsStillEndsCleanly) {
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  OVO_REQUIRE_PROGRAM(liveCameraBinaryPath());
  const fs::path dir = tempDir();
  const auto in = makeLiveInputs(dir, 12);
  if (!in) GTEST_SKIP() << "OpenCV cannot write an MJPG .avi here";
  const fs::path poses = dir / "poses.txt";
  std::string out;
  // Started in the background at 0.1x (12 s). Once its second pose is out (at most 30 s; the
  // OpenCL runtime, whose LLVM installs the one-shot handler, has then started), 50 SIGINTs back
  // to back; `wait` gives the run's own exit status (130 if a signal killed it).
  const int code = runShell(
      "('" + liveCameraBinaryPath().string() + "' --camera '" + in->video.string() + "' --calib '" +
          in->calib.string() + "' --estimator vo --rate 0.1 < '" + in->gyro.string() + "' > '" +
          poses.string() + "' 2>&1 & pid=$!; i=0; until grep -q '^0\\.1' '" + poses.string() +
          "' || [ $i -ge 300 ]; do sleep 0.1; i=$((i+1)); done; "
          "for k in $(seq 50); do kill -INT $pid 2>/dev/null; done; wait $pid)",
      dir, &out);
  std::ifstream log(poses);
  const std::string printed((std::istreambuf_iterator<char>(log)), {});
  EXPECT_EQ(code, 0) << printed;
  EXPECT_NE(printed.find("frames in"), std::string::npos) << printed;
  EXPECT_NE(printed.find("0.000000000 "), std::string::npos) << printed;  // it ran before the stop
}

}  // namespace
}  // namespace ovo::test
