// Scoring backends (gpu/scoring.hpp) and the OpenCL layer (gpu/opencl_context.hpp): bit-identical
// counts across backends, agreement with the double-precision sphere error, errors that name the
// OpenCL call, and the `auto` fallback when no device is found.
#include "gpu/scoring.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "common/error.hpp"
#include "frontend/essential.hpp"
#include "frontend/ransac.hpp"
#include "gpu/opencl_context.hpp"
#include "tests/gpu/two_view_scene.hpp"

namespace ovo::gpu {
namespace {

bool haveOpenCl() { return OpenClContext::shared() != nullptr; }

struct SoA {
  std::vector<float> prev, cur;
  MatchesSoA view() const { return {prev.data(), cur.data(), static_cast<int>(prev.size() / 3)}; }
};

SoA toSoA(const std::vector<Vec3>& bp, const std::vector<Vec3>& bc) {
  const std::size_t n = bp.size();
  SoA s{std::vector<float>(3 * n), std::vector<float>(3 * n)};
  for (std::size_t i = 0; i < n; ++i)
    for (int r = 0; r < 3; ++r) {
      s.prev[r * n + i] = static_cast<float>(bp[i](r));
      s.cur[r * n + i] = static_cast<float>(bc[i](r));
    }
  return s;
}

// Hypotheses as RANSAC makes them (8-point on reproducible samples), plus E = 0 and the truth.
std::vector<float> makeHypotheses(const test::TwoViewScene& s, int count) {
  std::vector<float> E(9 * static_cast<std::size_t>(count), 0.0f);
  const int n = static_cast<int>(s.b_prev.size());
  for (int h = 0; h < count; ++h) {
    Mat3 M = Mat3::Zero();
    if (h == 1) {
      M = frontend::essentialFromMotion(s.R_cur_prev, s.t_cur_prev.normalized());
    } else if (h > 1 && n >= 8) {
      const auto idx = frontend::sampleIndices(9, h, n);
      std::array<Vec3, 8> bp, bc;
      for (int j = 0; j < 8; ++j) {
        bp[j] = s.b_prev[idx[j]];
        bc[j] = s.b_cur[idx[j]];
      }
      M = frontend::eightPointMinimal(bp, bc).value_or(Mat3::Zero());
    }
    for (int j = 0; j < 9; ++j) E[9 * h + j] = static_cast<float>(M(j / 3, j % 3));
  }
  return E;
}

TEST(Scoring, CpuCountsAgreeWithTheDoublePrecisionSphereError) {
  test::TwoViewSceneOptions o;
  o.num_matches = 1000;
  const auto s = test::makeTwoViewScene(o);
  const auto soa = toSoA(s.b_prev, s.b_cur);
  const auto E = makeHypotheses(s, 64);
  const double thr = 4e-3;
  std::vector<int> counts(64);
  scoreHypothesesCpu(E.data(), 0, 64, soa.view(), inlierConstant(thr), counts.data());
  EXPECT_EQ(counts[0], 0) << "E = 0 must never count";
  EXPECT_GT(counts[1], 650);
  for (int h = 0; h < 64; ++h) {
    Mat3 M;
    for (int j = 0; j < 9; ++j) M(j / 3, j % 3) = E[9 * h + j];
    int reference = 0, borderline = 0;
    for (int i = 0; i < o.num_matches; ++i) {
      const double e = frontend::sphereError(M, s.b_prev[i], s.b_cur[i]);
      reference += e < thr * thr;
      borderline += std::abs(e - thr * thr) < 1e-3 * thr * thr;
    }
    EXPECT_LE(std::abs(counts[h] - reference), borderline) << "hypothesis " << h;
  }
  // The flags of one hypothesis reproduce its count.
  std::vector<std::uint8_t> flags(o.num_matches);
  inlierFlagsCpu(&E[9], soa.view(), inlierConstant(thr), flags.data());
  EXPECT_EQ(std::count(flags.begin(), flags.end(), 1), counts[1]);
}

TEST(Scoring, AllBackendsGiveBitIdenticalCounts) {
  std::vector<std::string> names = {"serial", "threads"};
  if (haveOpenCl()) names.push_back("opencl");
  for (int n : {8, 257, 1000, 4000}) {
    test::TwoViewSceneOptions o;
    o.num_matches = n;
    o.seed = 100 + n;
    const auto s = test::makeTwoViewScene(o);
    const auto soa = toSoA(s.b_prev, s.b_cur);
    const int H = 333;  // not a multiple of the OpenCL kernel's 16 hypotheses per work-item
    const auto E = makeHypotheses(s, H);
    for (double thr : {1e-3, 4e-3}) {
      std::vector<int> reference(H);
      scoreHypothesesCpu(E.data(), 0, H, soa.view(), inlierConstant(thr), reference.data());
      for (const auto& name : names) {
        auto backend = makeScoringBackend(name);
        ASSERT_EQ(backend->name(), name);
        backend->setMatches(soa.view());
        std::vector<int> counts(H, -1);
        backend->score(E.data(), H, inlierConstant(thr), counts.data());
        EXPECT_EQ(counts, reference) << name << " n=" << n << " thr=" << thr;
        // Buffers reused with a smaller block.
        std::vector<int> part(10, -1);
        backend->score(E.data() + 9 * 5, 10, inlierConstant(thr), part.data());
        EXPECT_TRUE(std::equal(part.begin(), part.end(), reference.begin() + 5)) << name;
      }
    }
  }
}

// The device generates its own hypotheses (gpu/kernels/ransac_hypotheses.cl): they must be the
// CPU's bits, including a rank-deficient sample (zero bearings) and a pure rotation, at range
// starts that are not multiples of the 8 lanes.
TEST(Scoring, EveryBackendGeneratesTheCpuHypothesesBitForBit) {
  std::vector<std::string> names = {"serial", "threads"};
  if (haveOpenCl()) names.push_back("opencl");
  for (int variant = 0; variant < 3; ++variant) {
    test::TwoViewSceneOptions o;
    o.num_matches = variant == 0 ? 1000 : 40;
    o.noise_px = 1.0;
    o.max_off_axis_deg = 115.0;
    o.seed = 300 + variant;
    if (variant == 2) o.t_cur_prev = Vec3::Zero();  // pure rotation: degenerate samples
    auto s = test::makeTwoViewScene(o);
    if (variant == 1)
      for (int i = 0; i < 40; i += 3) s.b_cur[i] = Vec3::Zero();
    const test::SoAd soa_d = test::toSoAd(s);
    const auto soa = toSoA(s.b_prev, s.b_cur);
    for (const auto& [h0, h1] : {std::pair{0, 2000}, std::pair{13, 50}, std::pair{1001, 1002}}) {
      const std::size_t count = static_cast<std::size_t>(h1 - h0);
      std::vector<float> reference(9 * count);
      generateHypothesesCpu(soa_d.view(), 77, h0, h1, reference.data());
      for (const auto& name : names) {
        auto backend = makeScoringBackend(name);
        backend->setMatches(soa.view(), soa_d.view());
        std::vector<float> E(9 * count, -1.0f);
        backend->generate(77, h0, h1, E.data());
        EXPECT_EQ(std::memcmp(E.data(), reference.data(), E.size() * sizeof(float)), 0)
            << name << " variant " << variant << " [" << h0 << ", " << h1 << ")";
        // generateAndScore scores exactly these hypotheses.
        std::vector<int> expected(count), counts(count, -1);
        const float k = inlierConstant(4e-3);
        scoreHypothesesCpu(reference.data(), 0, h1 - h0, soa.view(), k, expected.data());
        backend->generateAndScore(77, h0, h1, k, counts.data());
        EXPECT_EQ(counts, expected) << name << " variant " << variant;
      }
    }
  }
}

TEST(Scoring, UnknownBackendIsAnError) { EXPECT_THROW(makeScoringBackend("cuda"), Error); }

TEST(OpenCl, ErrorsNameTheCallAndTheError) {
  try {
    clCheck(CL_INVALID_VALUE, "clEnqueueFoo");
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "clEnqueueFoo: CL_INVALID_VALUE");
  }
  EXPECT_EQ(clErrorName(CL_BUILD_PROGRAM_FAILURE), "CL_BUILD_PROGRAM_FAILURE");
  EXPECT_EQ(clErrorName(-12345), "CL_UNKNOWN_ERROR(-12345)");
}

TEST(OpenCl, BuildFailureReportsTheBuildLog) {
  auto ctx = OpenClContext::shared();
  if (!ctx) GTEST_SKIP() << "no OpenCL device";
  try {
    ctx->program("__kernel void broken(__global float* x) { x[0] = undeclared_name; }", "");
    FAIL() << "no throw";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("clBuildProgram: CL_BUILD_PROGRAM_FAILURE"), std::string::npos) << msg;
    EXPECT_NE(msg.find("undeclared_name"), std::string::npos) << msg;
  }
}

TEST(OpenCl, ProgramsAreBuiltOnceAndPoclHasACacheFolder) {
  auto ctx = OpenClContext::shared();
  if (!ctx) GTEST_SKIP() << "no OpenCL device";
  const std::string src = "__kernel void k(__global int* x) { x[get_global_id(0)] = 1; }";
  EXPECT_EQ(ctx->program(src, ""), ctx->program(src, ""));
  EXPECT_NE(ctx->program(src, ""), ctx->program(src, "-DX=1"));
  const char* cache = std::getenv("POCL_CACHE_DIR");
  ASSERT_NE(cache, nullptr);
  EXPECT_TRUE(std::filesystem::is_directory(cache));
}

// Simulates a machine without OpenCL: `auto` falls back to threads, `opencl` fails clearly.
TEST(OpenCl, AutoFallsBackToThreadsWithoutADevice) {
  ::setenv("OVO_NO_OPENCL", "1", 1);
  EXPECT_EQ(OpenClContext::shared(), nullptr);
  EXPECT_EQ(makeScoringBackend("auto")->name(), "threads");
  try {
    makeScoringBackend("opencl");
    ADD_FAILURE() << "no throw";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("ransac.backend=opencl"), std::string::npos) << msg;
    EXPECT_NE(msg.find("OVO_NO_OPENCL"), std::string::npos) << msg;
  }
  ::unsetenv("OVO_NO_OPENCL");
  if (haveOpenCl()) {
    EXPECT_EQ(makeScoringBackend("auto")->name(), "opencl");
  }
}

}  // namespace
}  // namespace ovo::gpu
