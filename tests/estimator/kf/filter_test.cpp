// KfFilter on synthetic gyro (200 Hz) and VO-rotation (20 Hz) streams with a known constant gyro
// bias: bias convergence, fusion accuracy, turning-rate noise switching, gaps in either sensor.
#include "estimator/kf/filter.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/error.hpp"
#include "common/so3.hpp"
#include "tests/test_support.hpp"

namespace ovo::estimator {
namespace {

constexpr double kPi = 3.14159265358979323846;
const Vec3 kTrueBias(0.01, -0.02, 0.015);  // rad/s
constexpr double kGyroDensity = 1.7e-4;    // rad/s/sqrt(Hz)
constexpr double kVoSigma0 = 5e-4;         // rad
constexpr double kVoSigmaPerRad = 0.05;    // rad/rad

// Smooth 0 -> 1 -> 0 bump on [t0, t0 + len].
double bump(double t, double t0, double len) {
  if (t < t0 || t > t0 + len) return 0.0;
  return 0.5 * (1.0 - std::cos(2.0 * kPi * (t - t0) / len));
}

// Body rate: straight driving with a small wobble for 30 s, then three fast turns about z
// (peak 1 rad/s) at 32 s, 42 s and 52 s, alternating in sign.
Vec3 trueRate(double t) {
  Vec3 w(0.05 * std::sin(2.0 * kPi * 0.7 * t), 0.04 * std::sin(2.0 * kPi * 0.5 * t + 1.0),
         0.03 * std::sin(2.0 * kPi * 0.3 * t));
  w.z() += 1.0 * bump(t, 32.0, 4.0) - 1.0 * bump(t, 42.0, 4.0) + 1.0 * bump(t, 52.0, 4.0);
  return w;
}

struct Frame {
  Timestamp t_ns = 0;
  Mat3 R_W_B;          // truth
  Mat3 R_prev_cur_vo;  // measured VO rotation since the previous frame
};

struct Streams {
  std::vector<ImuSample> gyro;  // 200 Hz, biased and noisy
  std::vector<Frame> frames;    // 20 Hz
};

// Truth integrated at 4 kHz (midpoint rule); gyro at 200 Hz; VO noise follows the filter's
// schedule sigma0 + k |angle|.
Streams makeStreams(double duration_s, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Streams s;
  const int substeps = 20;
  const double dt_gyro = 1.0 / 200.0;
  const int gyro_per_frame = 10;
  const int n_gyro = static_cast<int>(std::round(duration_s / dt_gyro));
  Mat3 R = Mat3::Identity();
  Mat3 R_prev_frame = R;
  const double gyro_sigma = kGyroDensity / std::sqrt(dt_gyro);
  for (int k = 0; k <= n_gyro; ++k) {
    const double t = k * dt_gyro;
    if (k > 0) {
      const double h = dt_gyro / substeps;
      for (int j = 0; j < substeps; ++j)
        R = R * so3::exp(trueRate(t - dt_gyro + (j + 0.5) * h) * h);
    }
    ImuSample sample;
    sample.t_ns = fromSeconds(t);
    sample.gyro_radps = trueRate(t) + kTrueBias + gyro_sigma * ovo::test::draw3(normal, rng);
    s.gyro.push_back(sample);
    if (k % gyro_per_frame == 0) {
      const Mat3 R_true_rel = R_prev_frame.transpose() * R;
      const double sigma = kVoSigma0 + kVoSigmaPerRad * so3::angle(R_true_rel);
      const Vec3 n = sigma * ovo::test::draw3(normal, rng);
      s.frames.push_back({sample.t_ns, R, R_true_rel * so3::exp(n)});
      R_prev_frame = R;
    }
  }
  return s;
}

KfOptions testOptions() {
  KfOptions o;
  o.gyro_noise_density = kGyroDensity;
  o.gyro_bias_random_walk = 1e-6;  // the simulated bias is constant
  o.vo_sigma0_rad = kVoSigma0;
  o.vo_sigma_per_rad = kVoSigmaPerRad;
  o.vo_gate_chi2 = 25.0;  // these streams' VO noise is white and as modelled: 16 (the default,
                          // against real VO outliers) drops about one good update in 1000
  return o;
}

double rotationError(const Mat3& R_a, const Mat3& R_b) { return so3::angle(R_a.transpose() * R_b); }

// Runs the filter over the streams; gyro samples at a frame time come before the frame.
template <typename OnFrame>
void runFilter(KfFilter& kf, const Streams& s, bool use_gyro, bool use_vo, OnFrame on_frame,
               const Vec3& b_g_prior = Vec3::Zero()) {
  kf.initialise(0, Mat3::Identity(), b_g_prior);
  std::size_t g = 0;
  for (std::size_t f = 0; f < s.frames.size(); ++f) {
    const Frame& frame = s.frames[f];
    while (use_gyro && g < s.gyro.size() && s.gyro[g].t_ns <= frame.t_ns) kf.propagate(s.gyro[g++]);
    KfUpdateResult result;
    const Vec3 bias_before = kf.gyroBias();
    if (use_vo)
      result = kf.update(frame.t_ns, frame.R_prev_cur_vo);
    else
      kf.markFrame(frame.t_ns);
    on_frame(f, frame, result, bias_before);
  }
}

TEST(KfFilter, BiasConvergesWithinTenPercentAfterStraightSegment) {
  const Streams s = makeStreams(30.0, 7);
  KfFilter kf(testOptions());
  runFilter(kf, s, true, true,
            [](std::size_t, const Frame&, const KfUpdateResult&, const Vec3&) {});
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(kf.gyroBias()(i), kTrueBias(i), 0.1 * std::abs(kTrueBias(i))) << "axis " << i;
  // The covariance agrees: bias sigma below 10 % of the smallest bias component.
  EXPECT_LT(std::sqrt(kf.covariance().block<3, 3>(3, 3).diagonal().maxCoeff()), 1e-3);
}

// Rotation errors (rad) against the truth over one run: RMS over all frames and at the end.
struct RunErrors {
  double rms_fused = 0.0, rms_vo = 0.0, rms_gyro = 0.0;
  double final_fused = 0.0, final_vo = 0.0, final_gyro = 0.0;
  double bias_err = 0.0;  // rad/s
};

RunErrors runFusedVoGyro(const Streams& s) {
  KfFilter kf(testOptions());
  RunErrors e;
  Mat3 R_vo = Mat3::Identity();
  Mat3 R_gyro = Mat3::Identity();
  std::size_t g = 1;
  runFilter(kf, s, true, true,
            [&](std::size_t f, const Frame& frame, const KfUpdateResult&, const Vec3&) {
              if (f > 0) R_vo = R_vo * frame.R_prev_cur_vo;
              // Gyro only: raw rates (bias unknown) integrated with the midpoint rule.
              for (; g < s.gyro.size() && s.gyro[g].t_ns <= frame.t_ns; ++g) {
                const double dt = toSeconds(s.gyro[g].t_ns - s.gyro[g - 1].t_ns);
                R_gyro =
                    R_gyro * so3::exp(0.5 * (s.gyro[g].gyro_radps + s.gyro[g - 1].gyro_radps) * dt);
              }
              e.final_fused = rotationError(frame.R_W_B, kf.R_W_B());
              e.final_vo = rotationError(frame.R_W_B, R_vo);
              e.final_gyro = rotationError(frame.R_W_B, R_gyro);
              e.rms_fused += e.final_fused * e.final_fused;
              e.rms_vo += e.final_vo * e.final_vo;
              e.rms_gyro += e.final_gyro * e.final_gyro;
            });
  const double n = static_cast<double>(s.frames.size());
  e.rms_fused = std::sqrt(e.rms_fused / n);
  e.rms_vo = std::sqrt(e.rms_vo / n);
  e.rms_gyro = std::sqrt(e.rms_gyro / n);
  e.bias_err = (kf.gyroBias() - kTrueBias).norm();
  return e;
}

// The filter is optimal in expectation, not in every noise draw (with a constant bias learnt from
// the same VO, fused and VO differ little on the straight part): compare means over 8 runs.
TEST(KfFilter, FusedRotationBeatsGyroOnlyAndVoOnlyOver60s) {
  constexpr int kRuns = 8;
  RunErrors mean;
  for (int run = 0; run < kRuns; ++run) {
    const RunErrors e = runFusedVoGyro(makeStreams(60.0, 100 + run));
    EXPECT_LT(e.rms_fused, 0.2 * e.rms_gyro) << "run " << run;
    EXPECT_LT(e.bias_err, 0.15 * kTrueBias.norm()) << "run " << run;
    mean.rms_fused += e.rms_fused / kRuns;
    mean.rms_vo += e.rms_vo / kRuns;
    mean.rms_gyro += e.rms_gyro / kRuns;
    mean.final_fused += e.final_fused / kRuns;
    mean.final_vo += e.final_vo / kRuns;
    mean.final_gyro += e.final_gyro / kRuns;
    mean.bias_err += e.bias_err / kRuns;
  }
  const double deg = 180.0 / kPi;
  std::printf(
      "rotation error over 60 s, mean of %d runs [deg]: rms fused %.3f vo %.3f gyro %.3f; final "
      "fused %.3f vo %.3f gyro %.3f; bias error %.2e rad/s\n",
      kRuns, mean.rms_fused * deg, mean.rms_vo * deg, mean.rms_gyro * deg, mean.final_fused * deg,
      mean.final_vo * deg, mean.final_gyro * deg, mean.bias_err);
  EXPECT_LT(mean.rms_fused, 0.8 * mean.rms_vo);
  EXPECT_LT(mean.final_fused, 0.8 * mean.final_vo);
  EXPECT_LT(mean.rms_fused, 0.2 * mean.rms_gyro);
  EXPECT_LT(mean.final_fused, 0.2 * mean.final_gyro);
}

TEST(KfFilter, FastTurnFreezesBiasAndInflatesVoNoise) {
  const Streams s = makeStreams(40.0, 3);
  KfFilter kf(testOptions());
  int frozen = 0, straight_moved = 0, straight = 0;
  double max_sigma_straight = 0.0, min_sigma_frozen = 1e9, max_sigma_frozen = 0.0;
  runFilter(
      kf, s, true, true,
      [&](std::size_t f, const Frame& frame, const KfUpdateResult& r, const Vec3& bias_before) {
        if (f == 0) return;
        ASSERT_TRUE(r.applied) << "frame " << f;
        EXPECT_DOUBLE_EQ(r.sigma_vo_rad, kf.lastSigmaVo());
        const double t = toSeconds(frame.t_ns);
        if (r.bias_frozen) {
          ++frozen;
          EXPECT_EQ(kf.gyroBias(), bias_before) << "bias moved while frozen at t=" << t;
          EXPECT_GT(r.turn_rate_radps, kf.options().bias_freeze_rate_radps);
          min_sigma_frozen = std::min(min_sigma_frozen, r.sigma_vo_rad);
          max_sigma_frozen = std::max(max_sigma_frozen, r.sigma_vo_rad);
        }
        if (t < 30.0) {
          ++straight;
          EXPECT_FALSE(r.bias_frozen) << "t=" << t;
          if (kf.gyroBias() != bias_before) ++straight_moved;
          max_sigma_straight = std::max(max_sigma_straight, r.sigma_vo_rad);
        }
      });
  // The turn at 32-36 s exceeds 0.35 rad/s for about 2.5 s: ~50 frames at 20 Hz.
  EXPECT_GT(frozen, 40);
  EXPECT_EQ(straight_moved, straight);
  // Every frozen frame turns more than any straight one; at the peak, 1 rad/s -> 0.05 rad per
  // frame -> sigma = 4e-4 + 0.05 * 0.05 = 2.9e-3 rad, four times the straight-driving sigma.
  EXPECT_GT(min_sigma_frozen, max_sigma_straight);
  EXPECT_GT(max_sigma_frozen, 3.0 * max_sigma_straight);
}

TEST(KfFilter, NoiseScheduleGrowsWithMeasuredRotation) {
  KfFilter kf(testOptions());
  kf.initialise(0);
  kf.update(0, Mat3::Identity());
  const Timestamp dt = fromSeconds(0.05);
  kf.update(dt, so3::exp(Vec3(0, 0, 0.001)));
  EXPECT_NEAR(kf.lastSigmaVo(), kVoSigma0 + kVoSigmaPerRad * 0.001, 1e-12);
  const KfUpdateResult r = kf.update(2 * dt, so3::exp(Vec3(0, 0, 0.1)));
  EXPECT_NEAR(r.sigma_vo_rad, kVoSigma0 + kVoSigmaPerRad * 0.1, 1e-12);
  EXPECT_TRUE(r.bias_frozen);  // 0.1 rad in 0.05 s = 2 rad/s
  // A per-frame sigma0 replaces the configured one.
  EXPECT_NEAR(kf.update(3 * dt, Mat3::Identity(), 0.004).sigma_vo_rad, 0.004, 1e-12);
}

TEST(KfFilter, GyroOnlyFollowsBiasCorrectedIntegrationWithoutNaN) {
  const Streams s = makeStreams(10.0, 5);
  KfFilter kf(testOptions());
  const Vec3 bias_prior = kTrueBias;
  double last_rot_var = 0.0;
  Mat3 R_expected = Mat3::Identity();
  std::size_t g = 1;
  runFilter(
      kf, s, true, false,
      [&](std::size_t f, const Frame& frame, const KfUpdateResult& r, const Vec3&) {
        if (f == 0) return;
        EXPECT_FALSE(r.applied);
        for (; g < s.gyro.size() && s.gyro[g].t_ns <= frame.t_ns; ++g) {
          const double dt = toSeconds(s.gyro[g].t_ns - s.gyro[g - 1].t_ns);
          R_expected =
              R_expected *
              so3::exp((0.5 * (s.gyro[g].gyro_radps + s.gyro[g - 1].gyro_radps) - bias_prior) * dt);
        }
        ASSERT_TRUE(kf.R_W_B().allFinite());
        ASSERT_TRUE(kf.fullCovariance().allFinite());
        EXPECT_LT(rotationError(R_expected, kf.R_W_B()), 1e-9) << "frame " << f;
        const double rot_var = kf.covariance().block<3, 3>(0, 0).trace();
        EXPECT_GT(rot_var, last_rot_var);  // uncertainty only grows without VO
        last_rot_var = rot_var;
      },
      bias_prior);
  EXPECT_EQ(kf.gyroBias(), bias_prior);
  // Against the truth: only gyro white noise, 1.7e-4 * sqrt(10 s) per axis.
  EXPECT_LT(rotationError(s.frames.back().R_W_B, kf.R_W_B()), 3e-3);
}

TEST(KfFilter, VoOnlyRotationFollowsVoChain) {
  const Streams s = makeStreams(60.0, 9);
  KfFilter kf(testOptions());
  Mat3 R_vo = Mat3::Identity();
  runFilter(kf, s, false, true,
            [&](std::size_t f, const Frame& frame, const KfUpdateResult& r, const Vec3&) {
              if (f == 0) return;
              EXPECT_TRUE(r.applied) << "frame " << f << " chi2 " << r.chi2;
              R_vo = R_vo * frame.R_prev_cur_vo;
              ASSERT_TRUE(kf.fullCovariance().allFinite());
              // Per frame the filter keeps sigma_vo^2 / (sigma_vo^2 + sigma_gap^2 dt) ~ 2e-4 of the
              // VO step from its held prediction: a small lag behind the chain.
              EXPECT_LT(rotationError(R_vo, kf.R_W_B()), 1e-3) << "frame " << f;
            });
  EXPECT_EQ(kf.gyroBias(), Vec3::Zero());  // not observable without a gyro: prior kept
}

TEST(KfFilter, GapsInGyroAndVoKeepStateFinite) {
  const Streams s = makeStreams(30.0, 13);
  KfFilter kf(testOptions());
  kf.initialise(0);
  std::size_t g = 0;
  for (const Frame& frame : s.frames) {
    const double t = toSeconds(frame.t_ns);
    for (; g < s.gyro.size() && s.gyro[g].t_ns <= frame.t_ns; ++g)
      if (t < 10.0 || t > 12.0) kf.propagate(s.gyro[g]);  // 2 s gyro dropout
    if (t > 15.0 && t < 18.0)
      kf.markFrame(frame.t_ns);  // 3 s tracking loss
    else
      kf.update(frame.t_ns, frame.R_prev_cur_vo);
    ASSERT_TRUE(kf.R_W_B().allFinite()) << "t=" << t;
    ASSERT_TRUE(kf.gyroBias().allFinite()) << "t=" << t;
    ASSERT_TRUE(kf.fullCovariance().allFinite()) << "t=" << t;
  }
  // The VO rotation lost during the tracking loss is covered by the gyro: small error at the end.
  EXPECT_LT(rotationError(s.frames.back().R_W_B, kf.R_W_B()), 0.02);
  EXPECT_LT((kf.gyroBias() - kTrueBias).norm(), 0.2 * kTrueBias.norm());
}

TEST(KfFilter, OutlierVoRotationIsGated) {
  const Streams s = makeStreams(12.0, 17);
  KfFilter kf(testOptions());
  runFilter(kf, s, true, true,
            [](std::size_t, const Frame&, const KfUpdateResult&, const Vec3&) {});
  const Mat3 R_before = kf.R_W_B();
  const Timestamp t = kf.time() + fromSeconds(0.05);
  const KfUpdateResult r = kf.update(t, so3::exp(Vec3(0.0, 0.0, 10.0 * kPi / 180.0)));
  EXPECT_TRUE(r.gated);
  EXPECT_FALSE(r.applied);
  EXPECT_GT(r.chi2, kf.options().vo_gate_chi2);
  EXPECT_LT(rotationError(R_before, kf.R_W_B()), 0.01);  // only the held gyro rate moved it
}

TEST(KfFilter, ReadsOptionsAndRejectsOutOfRange) {
  Config c = Config::fromString("kf:\n  vo_sigma0_rad: 0.002\n  bias_freeze_rate_radps: 0.5\n");
  const KfOptions o = readKfOptions(c);
  EXPECT_DOUBLE_EQ(o.vo_sigma0_rad, 0.002);
  EXPECT_DOUBLE_EQ(o.bias_freeze_rate_radps, 0.5);
  EXPECT_DOUBLE_EQ(o.vo_sigma_per_rad, KfOptions{}.vo_sigma_per_rad);
  EXPECT_NO_THROW(c.checkAllUsed());
  EXPECT_THROW(readKfOptions(Config::fromString("kf:\n  vo_sigma0_rad: -1\n")), Error);
}

// Standing still: no VO rotation update at all (the chain keeps its reference), only zero-rate
// updates with the mean gyro of each 50 ms frame. After 1 s the bias is known to
// sigma_g / sqrt(1 s) = 1.7e-4 rad/s per axis; the filter's covariance says so too.
TEST(KfFilter, ZeroRateUpdatesAtStandstillFindTheBiasWithinGyroNoise) {
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  KfOptions o;
  o.gyro_noise_density = kGyroDensity;
  o.zero_rate_sigma_radps = 0.0;  // the gyro's white noise only: no idle vibration here
  KfFilter kf(o);
  kf.initialise(0);
  const double dt = 1.0 / 200.0;
  const double sample_sigma = kGyroDensity / std::sqrt(dt);
  Vec3 sum = Vec3::Zero();
  int n = 0;
  for (int i = 1; i <= 200; ++i) {
    ImuSample g;
    g.t_ns = fromSeconds(i * dt);
    g.gyro_radps = kTrueBias + sample_sigma * ovo::test::draw3(normal, rng);
    kf.propagate(g);
    sum += g.gyro_radps;
    if (++n == 10) {
      const KfUpdateResult r = kf.zeroRateUpdate(sum / n, n * dt);
      EXPECT_TRUE(r.applied);
      sum.setZero();
      n = 0;
    }
  }
  const Vec3 err = kf.gyroBias() - kTrueBias;
  const double sigma_1s = kGyroDensity;  // / sqrt(1 s)
  EXPECT_LT(err.cwiseAbs().maxCoeff(), 4.0 * sigma_1s) << err.transpose();
  const Vec3 bias_sd = kf.covariance().block<3, 3>(3, 3).diagonal().cwiseSqrt();
  EXPECT_NEAR(bias_sd.x(), sigma_1s, 0.2 * sigma_1s);
  // Without the updates the bias would still be at its prior (zero): 0.015-0.02 rad/s off.
  EXPECT_LT(err.norm(), 0.05 * kTrueBias.norm());
}

}  // namespace
}  // namespace ovo::estimator
