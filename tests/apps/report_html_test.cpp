// report.html and its SVG plots: known data-to-pixel mapping, top-view axis choice, trajectory
// comparison with known errors, well-formed SVG without NaN, and (when Debian's chromium is
// installed) a headless browser that renders the page with every plot.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>

#include "apps/report.hpp"
#include "apps/svg_plot.hpp"
#include "tests/test_support.hpp"

namespace ovo::app {
namespace {

namespace fs = std::filesystem;

// A small XML well-formedness check: balanced, properly nested tags, quoted attributes, known
// entities only, no stray '<' or '&'. Returns "" when well-formed, else what is wrong.
std::string xmlProblem(const std::string& xml) {
  std::vector<std::string> stack;
  std::size_t i = 0;
  auto entityOk = [&](std::size_t at) {
    static const std::regex entity("^&(amp|lt|gt|quot|apos|#[0-9]+|#x[0-9a-fA-F]+);");
    return std::regex_search(xml.substr(at, 12), entity);
  };
  while (i < xml.size()) {
    if (xml[i] == '&') {
      if (!entityOk(i)) return "bad entity at " + std::to_string(i);
      ++i;
      continue;
    }
    if (xml[i] != '<') {
      ++i;
      continue;
    }
    if (xml.compare(i, 2, "<?") == 0) {
      const auto e = xml.find("?>", i);
      if (e == std::string::npos) return "unterminated <?";
      i = e + 2;
      continue;
    }
    if (xml.compare(i, 4, "<!--") == 0) {
      const auto e = xml.find("-->", i);
      if (e == std::string::npos) return "unterminated comment";
      i = e + 3;
      continue;
    }
    const bool closing = xml.compare(i, 2, "</") == 0;
    std::size_t j = i + (closing ? 2 : 1);
    std::size_t name_end = j;
    while (name_end < xml.size() && (std::isalnum(static_cast<unsigned char>(xml[name_end])) ||
                                     xml[name_end] == '-' || xml[name_end] == ':'))
      ++name_end;
    const std::string name = xml.substr(j, name_end - j);
    if (name.empty()) return "empty tag name at " + std::to_string(i);
    j = name_end;
    bool self_closing = false;
    for (;;) {
      while (j < xml.size() && std::isspace(static_cast<unsigned char>(xml[j]))) ++j;
      if (j >= xml.size()) return "unterminated tag " + name;
      if (xml[j] == '>') break;
      if (xml.compare(j, 2, "/>") == 0) {
        self_closing = true;
        ++j;
        break;
      }
      if (closing) return "attribute in closing tag " + name;
      std::size_t a = j;
      while (a < xml.size() && xml[a] != '=' && !std::isspace(static_cast<unsigned char>(xml[a])))
        ++a;
      if (a >= xml.size() || xml[a] != '=' || a == j) return "attribute without value in " + name;
      const char q = xml[a + 1];
      if (q != '"' && q != '\'') return "unquoted attribute in " + name;
      const auto e = xml.find(q, a + 2);
      if (e == std::string::npos) return "unterminated attribute in " + name;
      const std::string value = xml.substr(a + 2, e - a - 2);
      if (value.find('<') != std::string::npos) return "'<' in an attribute of " + name;
      for (std::size_t k = value.find('&'); k != std::string::npos; k = value.find('&', k + 1))
        if (!entityOk(a + 2 + k)) return "bad entity in an attribute of " + name;
      j = e + 1;
    }
    if (closing) {
      if (stack.empty() || stack.back() != name)
        return "</" + name + "> does not close <" + (stack.empty() ? "" : stack.back()) + ">";
      stack.pop_back();
    } else if (!self_closing) {
      stack.push_back(name);
    }
    i = j + 1;
  }
  return stack.empty() ? "" : "<" + stack.back() + "> not closed";
}

// Every top-level <svg>...</svg> of an HTML page.
std::vector<std::string> svgElements(const std::string& html) {
  std::vector<std::string> out;
  std::size_t pos = 0;
  while ((pos = html.find("<svg", pos)) != std::string::npos) {
    int depth = 0;
    std::size_t k = pos;
    for (;;) {
      const auto open = html.find("<svg", k), close = html.find("</svg>", k);
      if (close == std::string::npos) return out;
      if (open != std::string::npos && open < close) {
        ++depth;
        k = open + 4;
      } else {
        --depth;
        k = close + 6;
        if (depth == 0) break;
      }
    }
    out.push_back(html.substr(pos, k - pos));
    pos = k;
  }
  return out;
}

// No NaN/inf in any number: the only letters allowed next to digits are in known words.
bool hasNonFiniteNumber(const std::string& svg) {
  static const std::regex bad("(^|[^a-zA-Z])(nan|inf|NaN|Inf|-nan|-inf)([^a-zA-Z]|$)");
  return std::regex_search(svg, bad);
}

Trajectory circle(int n, double radius_m, double z_m = 0.0) {
  Trajectory t;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n;
    StampedPose p;
    p.t_ns = fromSeconds(0.1 * i);
    p.T_W_B.translation() = Vec3(radius_m * std::cos(a), radius_m * std::sin(a), z_m);
    p.T_W_B.linear() = Eigen::AngleAxisd(a + M_PI / 2, Vec3::UnitZ()).toRotationMatrix();
    t.push_back(p);
  }
  return t;
}

TEST(SvgPlot, PlotFrameMapsTheDataRangeOntoThePlotArea) {
  PlotOptions o;
  o.width_px = 400;
  o.height_px = 300;
  const PlotFrame f = plotFrame({{"a", {0, 10}, {0, 5}}}, o);
  EXPECT_LT(f.x_min, 0.0);
  EXPECT_GT(f.x_max, 10.0);
  // Corners of the shown range go to the corners of the plot area; y grows upwards.
  EXPECT_NEAR(f.toPx(f.x_min, f.y_min).x(), f.left_px, 1e-9);
  EXPECT_NEAR(f.toPx(f.x_min, f.y_min).y(), f.top_px + f.height_px, 1e-9);
  EXPECT_NEAR(f.toPx(f.x_max, f.y_max).x(), f.left_px + f.width_px, 1e-9);
  EXPECT_NEAR(f.toPx(f.x_max, f.y_max).y(), f.top_px, 1e-9);
  EXPECT_LT(f.toPx(0, 5).y(), f.toPx(0, 0).y());
}

TEST(SvgPlot, EqualAspectGivesBothAxesTheSameScale) {
  PlotOptions o;
  o.width_px = 500;
  o.height_px = 300;
  o.equal_aspect = true;
  const PlotFrame f = plotFrame({{"a", {0, 1}, {0, 20}}}, o);
  EXPECT_NEAR((f.x_max - f.x_min) / f.width_px, (f.y_max - f.y_min) / f.height_px, 1e-12);
  EXPECT_LE(f.y_min, 0.0);
  EXPECT_GE(f.y_max, 20.0);
}

TEST(SvgPlot, NiceTicksAreRoundAndInsideTheRange) {
  EXPECT_EQ(niceTicks(0.0, 9.3, 5), (std::vector<double>{0, 2, 4, 6, 8}));
  const auto t = niceTicks(-1.2, 3.7, 5);
  ASSERT_EQ(t.size(), 5u);
  EXPECT_DOUBLE_EQ(t.front(), -1.0);
  EXPECT_DOUBLE_EQ(t.back(), 3.0);
  EXPECT_TRUE(niceTicks(1.0, 1.0).empty());
  // A narrow range still gets at least two labelled ticks.
  const auto narrow = niceTicks(0.0028, 0.0045, 3);
  ASSERT_GE(narrow.size(), 2u);
  EXPECT_GE(narrow.front(), 0.0028);
  EXPECT_LE(narrow.back(), 0.0045);
}

TEST(SvgPlot, NonFiniteValuesBreakTheLineAndNeverReachTheSvg) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  PlotOptions o;
  o.title = "A & B <test>";
  const std::string svg =
      svgLinePlot({{"s", {0, 1, 2, 3, 4, 5}, {0, 1, nan, 3, inf, 5}, "#123456"}}, o);
  EXPECT_EQ(xmlProblem(svg), "");
  EXPECT_FALSE(hasNonFiniteNumber(svg)) << svg;
  // [0, 1] and [3] and [5]: three polylines.
  std::size_t n = 0;
  for (std::size_t p = svg.find("<polyline"); p != std::string::npos;
       p = svg.find("<polyline", p + 1))
    ++n;
  EXPECT_EQ(n, 3u);
  EXPECT_NE(svg.find("A &amp; B &lt;test&gt;"), std::string::npos);
}

TEST(SvgPlot, TopViewOfAGravityAlignedWorldIsTheXyPlane) {
  const TopView v = chooseTopView(circle(40, 5.0));
  EXPECT_EQ(v.a_name, "x");
  EXPECT_EQ(v.b_name, "y");
  EXPECT_TRUE(v.axis_a.cross(v.axis_b).isApprox(v.up));
}

TEST(SvgPlot, TopViewOfACameraFrameWorldLooksDownItsYAxis) {
  // KITTI-style world: the path lies in x-z, y points down.
  Trajectory t = circle(40, 5.0);
  for (auto& p : t) {
    const Vec3 q = p.T_W_B.translation();
    p.T_W_B.translation() = Vec3(q.x(), 0.0, q.y());
  }
  const TopView v = chooseTopView(t);
  EXPECT_EQ(v.a_name, "x");
  EXPECT_EQ(v.b_name, "z");
  EXPECT_TRUE(v.up.isApprox(-Vec3::UnitY()));
  EXPECT_TRUE(v.axis_a.cross(v.axis_b).isApprox(v.up));  // seen from above, not mirrored
  // A straight drive along z (camera forward) still looks down -y; one along x looks down z.
  Trajectory straight_z, straight_x;
  for (int i = 0; i < 20; ++i) {
    StampedPose p;
    p.T_W_B.translation() = Vec3(0.01 * (i % 2), 0.0, i);
    straight_z.push_back(p);
    p.T_W_B.translation() = Vec3(i, 0.0, 0.05 * i);
    straight_x.push_back(p);
  }
  EXPECT_TRUE(chooseTopView(straight_z).up.isApprox(-Vec3::UnitY()));
  EXPECT_TRUE(chooseTopView(straight_x).up.isApprox(Vec3::UnitZ()));
}

TEST(SvgPlot, ComparisonOfARigidlyMovedCopyHasNoPositionError) {
  const Trajectory gt = circle(50, 4.0);
  SE3 T = SE3::Identity();
  T.linear() = Eigen::AngleAxisd(0.7, Vec3::UnitZ()).toRotationMatrix();
  T.translation() = Vec3(3, -2, 1);
  Trajectory est = gt;
  for (auto& p : est) p.T_W_B = T * p.T_W_B;
  const auto c = compareTrajectories(gt, est);
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(c->alignment, "SE(3)");
  ASSERT_EQ(c->pos_err_m.size(), 50u);
  for (std::size_t i = 0; i < 50; ++i) {
    EXPECT_NEAR(c->pos_err_m[i], 0.0, 1e-9);
    EXPECT_NEAR(c->yaw_err_deg[i], 0.0, 1e-7);
  }
  EXPECT_NEAR(c->t_s.back(), 4.9, 1e-9);
}

TEST(SvgPlot, YawErrorHasTheSignOfTheHeadingOffset) {
  // Same positions, every orientation turned 10 degrees to the left (about +z).
  const Trajectory gt = circle(30, 4.0);
  Trajectory est = gt;
  const Mat3 R = Eigen::AngleAxisd(10.0 * M_PI / 180.0, Vec3::UnitZ()).toRotationMatrix();
  for (auto& p : est) p.T_W_B.linear() = R * p.T_W_B.linear();
  const auto c = compareTrajectories(gt, est);
  ASSERT_TRUE(c.has_value());
  for (const double yaw : c->yaw_err_deg) EXPECT_NEAR(yaw, 10.0, 1e-6);
}

TEST(SvgPlot, AnEstimateThatNeverMovedIsShownByItsFirstPose) {
  const Trajectory gt = circle(30, 4.0);
  Trajectory est = gt;
  for (auto& p : est) p.T_W_B = SE3::Identity();
  const auto c = compareTrajectories(gt, est);
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(c->alignment, "first pose");
  EXPECT_NEAR(c->pos_err_m.front(), 0.0, 1e-9);
  EXPECT_NEAR(c->pos_err_m[15], 8.0, 1e-9);  // across the circle
}

ReportInputs sampleReport() {
  ReportInputs in;
  in.estimator = "window";
  in.dataset = "/data/<vineyard> & co";
  in.mode = "offline";
  in.groundtruth = circle(60, 5.0);
  in.estimate = in.groundtruth;
  for (std::size_t i = 0; i < in.estimate.size(); ++i) {
    in.estimate[i].T_W_B.translation() *= 1.02;
    in.bias_estimate.push_back({in.estimate[i].t_ns, Vec3(0.001, -0.002, 0.003) * (i / 60.0)});
    in.bias_truth.push_back({in.estimate[i].t_ns, Vec3(0.001, -0.002, 0.003)});
    const bool keyframe = i % 4 == 0;
    in.timing.push_back(
        {in.estimate[i].t_ns, 12.0 + i % 5, keyframe ? 60.0 : 3.0, 40.0 + i % 7, keyframe});
  }
  // CPU and memory once a second: 20 ms of CPU a frame, memory growing by 1 MiB a second.
  for (int k = 0; k < 10; ++k) in.resources.push_back({1.0 * k, 6 * k, 0.12 * k, 80.0 + k});
  in.metrics = {{"frames", 60},
                {"ate_rmse_m", 0.05},
                {"time_offset_s", 0.0191},
                {"time_offset_estimated", true},
                {"timing", {{"wall_s", 1.5}, {"keyframe_ms_p90", 61.5}, {"cpu_s", 2.25}}}};
  in.config_yaml = "window:\n  size: 10   # <keyframes> & more\n";
  return in;
}

TEST(Report, HasEveryPlotAsWellFormedSvgWithTheMetricsAndTheConfiguration) {
  const std::string html = renderReportHtml(sampleReport());
  const auto svgs = svgElements(html);
  // Top view, position error, yaw error; position, heading and scale error against the
  // distance; gyro bias, timing, CPU per frame, memory.
  ASSERT_EQ(svgs.size(), 10u);
  for (const auto& svg : svgs) {
    EXPECT_EQ(xmlProblem(svg), "") << svg.substr(0, 200);
    EXPECT_FALSE(hasNonFiniteNumber(svg));
  }
  EXPECT_NE(html.find("Gyro bias estimate vs truth"), std::string::npos);
  EXPECT_NE(html.find("timing.wall_s"), std::string::npos);
  EXPECT_NE(html.find("ate_rmse_m"), std::string::npos);
  // Issue 43: the keyframes' cost plotted apart, the run's costs as tiles.
  EXPECT_NE(html.find("keyframe (solve + marginalisation)"), std::string::npos);
  EXPECT_NE(html.find("keyframe solve p90"), std::string::npos);
  EXPECT_NE(html.find("CPU (user + system)"), std::string::npos);
  // Issue 59: drift against the distance driven, CPU and memory over the run.
  EXPECT_NE(html.find("Drift against the distance driven"), std::string::npos);
  EXPECT_NE(html.find("Scale error over the last 25 m"), std::string::npos);
  EXPECT_NE(html.find("distance driven [m]"), std::string::npos);
  EXPECT_NE(html.find("CPU per frame (user + system, all threads)"), std::string::npos);
  EXPECT_NE(html.find("Resident memory"), std::string::npos);
  // Issue 42: the window's estimate of the camera-gyro time offset, in ms.
  EXPECT_NE(html.find("19.1 ms"), std::string::npos);
  EXPECT_NE(html.find("camera-gyro time offset (estimated)"), std::string::npos);
  EXPECT_NE(html.find("# &lt;keyframes&gt; &amp; more"), std::string::npos);
  EXPECT_NE(html.find("/data/&lt;vineyard&gt; &amp; co"), std::string::npos);
  // Self-contained: no scripts, no links to anything outside the page.
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("href="), std::string::npos);
  EXPECT_EQ(html.find("src="), std::string::npos);
}

TEST(Report, WithoutGroundTruthShowsTheEstimateAlone) {
  ReportInputs in = sampleReport();
  in.groundtruth.clear();
  in.bias_truth.clear();
  in.metrics = {{"frames", 60}};
  const std::string html = renderReportHtml(in);
  const auto svgs = svgElements(html);
  ASSERT_EQ(svgs.size(), 5u);  // top view, gyro bias, timing, CPU, memory
  EXPECT_EQ(html.find("Drift against the distance driven"), std::string::npos);
  for (const auto& svg : svgs) EXPECT_EQ(xmlProblem(svg), "");
  EXPECT_NE(html.find("no ground truth"), std::string::npos);
}

std::optional<std::string> findChromium() {
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"}) {
    const std::string cmd = std::string("command -v ") + name + " >/dev/null 2>&1";
    if (std::system(cmd.c_str()) == 0) return std::string(name);
  }
  return std::nullopt;
}

std::string runCapture(const std::string& cmd) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  pclose(p);
  return out;
}

TEST(Report, RendersInHeadlessChromiumWithEveryPlot) {
  const auto chromium = findChromium();
  if (!chromium)
    GTEST_SKIP() << "chromium not installed (Debian package `chromium`; scripts/setup.sh test "
                    "installs it)";
  const fs::path dir = test::tempDir();
  writeReport(dir / "report.html", sampleReport());
  const std::string flags =
      " --headless --no-sandbox --disable-gpu --disable-quic --no-first-run"
      " --disable-background-networking --disable-component-update --disable-sync"
      " --enable-logging=stderr --v=0 --user-data-dir='" +
      (dir / "profile").string() + "'";
  const std::string url = "'file://" + (dir / "report.html").string() + "'";
  const std::string dom = runCapture("timeout 120 " + *chromium + flags + " --dump-dom " + url +
                                     " 2>'" + (dir / "stderr.txt").string() + "'");
  ASSERT_NE(dom.find("</html>"), std::string::npos) << "chromium printed no DOM";
  EXPECT_EQ(svgElements(dom).size(), 10u);
  EXPECT_NE(dom.find("<polyline"), std::string::npos);
  EXPECT_NE(dom.find("ovo run: window"), std::string::npos);
  // The browser's console reports no error for the page.
  std::ifstream err(dir / "stderr.txt");
  std::stringstream err_text;
  err_text << err.rdbuf();
  EXPECT_EQ(err_text.str().find("CONSOLE"), std::string::npos) << err_text.str();

  const fs::path png = dir / "report.png";
  runCapture("timeout 120 " + *chromium + flags + " --window-size=1300,1800 --screenshot='" +
             png.string() + "' " + url + " 2>/dev/null");
  ASSERT_TRUE(fs::exists(png));
  EXPECT_GT(fs::file_size(png), 20'000u);  // a real page, not a blank one
}

}  // namespace
}  // namespace ovo::app
