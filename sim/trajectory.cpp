#include "sim/trajectory.hpp"

#include <algorithm>
#include <cmath>

#include "sim/height_field.hpp"
#include "sim/random.hpp"
#include "sim/world.hpp"

namespace ovo::sim {
namespace {

using Vec6 = UniformCubicBSpline::Vec6;
constexpr double kDeg = M_PI / 180.0;

// Step smoothed by a raised-cosine kernel of unit width centred at 0: C1, and the convolution keeps
// the integral of a piecewise-constant schedule (a commanded turn keeps its total angle).
double smoothStep(double x) {
  if (x <= -0.5) return 0.0;
  if (x >= 0.5) return 1.0;
  const double s = x + 0.5;
  return s - std::sin(2.0 * M_PI * s) / (2.0 * M_PI);
}

double wrapAngle(double a) { return std::remainder(a, 2.0 * M_PI); }

Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

Vec3 vee(const Mat3& m) {
  return 0.5 * Vec3(m(2, 1) - m(1, 2), m(0, 2) - m(2, 0), m(1, 0) - m(0, 1));
}

// One constant command of the unicycle: forward speed, yaw rate, and the row line to follow.
struct Command {
  double duration_s;
  double v_mps;
  double omega_radps;
  int line = -1;  // index into Plan::lines, -1: open loop
};

struct Line {
  double b;    // lateral position in T
  double psi;  // heading along the line
};

struct Plan {
  std::vector<Command> commands;
  std::vector<Line> lines;
  double a0 = 0.0, b0 = 0.0, psi0 = 0.0;
};

// Smoothed command schedule: v(t), omega(t) and the weight of each line's feedback.
class Schedule {
 public:
  Schedule(const Plan& plan, double ramp_s) : plan_(plan), ramp_(ramp_s) {
    double t = 0.0;
    for (const auto& c : plan.commands) {
      begin_.push_back(t);
      t += c.duration_s;
    }
    end_ = t;
  }
  double end() const { return end_; }
  void at(double t, double* v, double* omega, std::vector<double>* line_weight) const {
    *v = 0.0;
    *omega = 0.0;
    std::fill(line_weight->begin(), line_weight->end(), 0.0);
    for (std::size_t k = 0; k < plan_.commands.size(); ++k) {
      const Command& c = plan_.commands[k];
      const double w =
          smoothStep((t - begin_[k]) / ramp_) - smoothStep((t - begin_[k] - c.duration_s) / ramp_);
      if (w == 0.0) continue;
      *v += w * c.v_mps;
      *omega += w * c.omega_radps;
      if (c.line >= 0) (*line_weight)[c.line] += w;
    }
  }

 private:
  const Plan& plan_;
  double ramp_;
  std::vector<double> begin_;
  double end_ = 0.0;
};

// Terrain-frame coordinates (a, b) of the ground point below world (x, y).
Vec2 toTerrain(const VineyardWorld& world, double x, double y) {
  const Vec3 p(x, y, world.planeHeight(x, y));
  return Vec2(p.dot(world.R_W_T().col(0)), p.dot(world.R_W_T().col(1)));
}

Plan makePlan(const TrajectoryOptions& o, const VineyardWorld& world, Rng& rng) {
  const WorldOptions& w = world.options();
  const double j = o.jitter;
  const auto speed = [&](double v) { return v * (1.0 + 0.03 * j * rng.normal()); };
  Plan plan;
  plan.commands.push_back({o.start_hold_s, 0.0, 0.0});
  const double L = w.row_length_m, sp = w.row_spacing_m;
  int lateral = o.turn_left ? 1 : -1;  // direction of the inter-row index over the passes

  // Drive `dist` along line `line` at `v`, with stops every stop_every_m.
  const auto drive = [&](double dist, double v, int line) {
    double left = dist;
    while (left > 1e-6) {
      const double chunk = o.stop_every_m > 0.0 ? std::min(left, o.stop_every_m) : left;
      plan.commands.push_back({chunk / v, v, 0.0, line});
      left -= chunk;
      if (left > 1e-6 && o.stop_every_m > 0.0)
        plan.commands.push_back({o.stop_duration_s, 0.0, 0.0});
    }
  };
  const auto lineOf = [&](int interrow, double psi) {
    const Vec2 ab = toTerrain(world, 0.0, world.interrowY(interrow));
    plan.lines.push_back({ab.y(), psi});
    return static_cast<int>(plan.lines.size()) - 1;
  };

  const double b_offset = 0.05 * j * rng.normal();
  const double psi_offset = 1.0 * kDeg * j * rng.normal();
  if (o.kind == "spin") {
    const double x0 = o.start_x_m >= 0.0 ? o.start_x_m : 0.5 * L - o.lead_in_m;
    const Vec2 ab = toTerrain(world, x0, world.interrowY(o.first_interrow));
    plan.a0 = ab.x();
    plan.b0 = ab.y() + b_offset;
    plan.psi0 = psi_offset;
    const int line = lineOf(o.first_interrow, 0.0);
    const double v = speed(o.speed_mps);
    if (o.lead_in_m > 0.0) drive(o.lead_in_m, v, line);
    plan.commands.push_back({1.0, 0.0, 0.0});
    const double rate = o.spin_rate_dps * kDeg;
    plan.commands.push_back(
        {std::abs(o.spin_deg) * kDeg / rate, 0.0, o.spin_deg >= 0 ? rate : -rate});
    plan.commands.push_back({1.0, 0.0, 0.0});
    plan.lines.push_back({plan.lines[line].b, o.spin_deg * kDeg});
    if (o.lead_out_m > 0.0) drive(o.lead_out_m, v, static_cast<int>(plan.lines.size()) - 1);
  } else {
    // kind rows: passes along inter-rows, joined by headland U-turns.
    const double x_end = L + o.headland_entry_m;
    const double x_start = x_end - o.first_pass_m;
    const Vec2 ab = toTerrain(world, x_start, world.interrowY(o.first_interrow));
    plan.a0 = ab.x();
    plan.b0 = ab.y() + b_offset;
    plan.psi0 = psi_offset;
    int interrow = o.first_interrow;
    for (int p = 0; p < o.passes; ++p) {
      const double psi = p % 2 == 0 ? 0.0 : M_PI;
      const int line = lineOf(interrow, psi);
      double dist = L + 2.0 * o.headland_entry_m;
      if (p == 0) dist = o.first_pass_m;
      if (p == o.passes - 1 && p > 0) dist = o.last_pass_m;
      drive(dist, speed(o.speed_mps), line);
      if (p + 1 == o.passes) break;
      // U-turn: quarter arc, straight across, quarter arc (radius 0: pivot turns).
      const double sign = lateral * (p % 2 == 0 ? 1.0 : -1.0);
      const double r = std::min(o.uturn_radius_m, 0.5 * sp);
      const double rate = o.uturn_yaw_rate_dps * kDeg;
      const double quarter = 0.5 * M_PI / rate;
      const double straight = sp - 2.0 * r;
      plan.commands.push_back({quarter, rate * r, sign * rate});
      if (straight > 1e-3) {
        const double v = speed(o.uturn_speed_mps);
        plan.commands.push_back({straight / v, v, 0.0});
      }
      plan.commands.push_back({quarter, rate * r, sign * rate});
      interrow += lateral;
    }
  }
  plan.commands.push_back({o.end_hold_s, 0.0, 0.0});
  return plan;
}

}  // namespace

UniformCubicBSpline::UniformCubicBSpline(double dt_s, std::vector<Vec6> control_points)
    : dt_(dt_s), points_(std::move(control_points)) {}

double UniformCubicBSpline::endTime() const {
  return points_.size() < 4 ? 0.0 : static_cast<double>(points_.size() - 3) * dt_;
}

void UniformCubicBSpline::evaluate(double t, Vec6* value, Vec6* d1, Vec6* d2) const {
  if (points_.size() < 4) {
    value->setZero();
    if (d1) d1->setZero();
    if (d2) d2->setZero();
    return;
  }
  const int segments = static_cast<int>(points_.size()) - 3;
  t = std::clamp(t, 0.0, endTime());
  int i = static_cast<int>(std::floor(t / dt_));
  i = std::clamp(i, 0, segments - 1);
  const double u = t / dt_ - i;
  const double u2 = u * u, u3 = u2 * u, m = 1.0 - u;
  const Vec6& p0 = points_[i];
  const Vec6& p1 = points_[i + 1];
  const Vec6& p2 = points_[i + 2];
  const Vec6& p3 = points_[i + 3];
  *value = (m * m * m * p0 + (3 * u3 - 6 * u2 + 4) * p1 + (-3 * u3 + 3 * u2 + 3 * u + 1) * p2 +
            u3 * p3) /
           6.0;
  if (d1)
    *d1 =
        (-m * m * p0 + (3 * u2 - 4 * u) * p1 + (-3 * u2 + 2 * u + 1) * p2 + u2 * p3) / (2.0 * dt_);
  if (d2) *d2 = (m * p0 + (3 * u - 2) * p1 + (1 - 3 * u) * p2 + u * p3) / (dt_ * dt_);
}

BodyTrajectory::BodyTrajectory(const Mat3& R_W_T, double body_height_m, UniformCubicBSpline spline)
    : R_W_T_(R_W_T), body_height_m_(body_height_m), spline_(std::move(spline)) {}

BodyTrajectory::BodyTrajectory(const Mat3& R_W_T, double body_height_m, UniformCubicBSpline spline,
                               std::shared_ptr<const HeightField> field, const Vec2& plane_gradient)
    : R_W_T_(R_W_T),
      body_height_m_(body_height_m),
      spline_(std::move(spline)),
      field_(std::move(field)),
      plane_gradient_(plane_gradient) {}

void BodyTrajectory::groundContact(double t_s, Vec3* point_W, Vec3* normal_W) const {
  Vec6 x;
  spline_.evaluate(t_s, &x);
  *point_W = R_W_T_ * Vec3(x[0], x[1], 0.0);
  *normal_W = R_W_T_.col(2);
  if (!field_) return;
  Vec2 g;
  point_W->z() += field_->height(point_W->x(), point_W->y(), &g);
  *normal_W = Vec3(-plane_gradient_.x() - g.x(), -plane_gradient_.y() - g.y(), 1.0).normalized();
}

BodyState BodyTrajectory::roughState(double t_s) const {
  Vec6 x, dx, ddx;
  spline_.evaluate(t_s, &x, &dx, &ddx);
  if (t_s < 0.0 || t_s > duration()) {  // held still outside the spline's range
    dx.setZero();
    ddx.setZero();
  }
  const double psi = x[3], theta = x[4], phi = x[5];
  const double dpsi = dx[3], dtheta = dx[4], dphi = dx[5];
  const Mat3 R_base =
      R_W_T_ * (Eigen::AngleAxisd(psi, Vec3::UnitZ()) * Eigen::AngleAxisd(theta, Vec3::UnitY()) *
                Eigen::AngleAxisd(phi, Vec3::UnitX()))
                   .toRotationMatrix();
  const double sp = std::sin(phi), cp = std::cos(phi), st = std::sin(theta), ct = std::cos(theta);
  const Vec3 omega_base(dphi - dpsi * st, dtheta * cp + dpsi * sp * ct,
                        -dtheta * sp + dpsi * cp * ct);
  // The plane point below the body and its derivatives; q = its world x, y.
  const Vec3 P = R_W_T_ * Vec3(x[0], x[1], 0.0);
  const Vec3 Pd = R_W_T_ * Vec3(dx[0], dx[1], 0.0);
  const Vec3 Pdd = R_W_T_ * Vec3(ddx[0], ddx[1], 0.0);
  const Vec2 qd = Pd.head<2>(), qdd = Pdd.head<2>();
  const HeightSample hs = field_->sample(P.x(), P.y(), qd);
  // The ground point g = P + h e_z.
  const Vec3 ez = Vec3::UnitZ();
  const Vec3 g = P + ez * hs.h;
  const Vec3 gd = Pd + ez * hs.grad.dot(qd);
  const Vec3 gdd = Pdd + ez * (qd.dot(hs.hess * qd) + hs.grad.dot(qdd));
  // The ground normal n = u / |u|, u = (-dz/dx, -dz/dy, 1), and its first two derivatives.
  const Vec3 u(-plane_gradient_.x() - hs.grad.x(), -plane_gradient_.y() - hs.grad.y(), 1.0);
  const Vec2 Hqd = hs.hess * qd;
  const Vec3 ud(-Hqd.x(), -Hqd.y(), 0.0);
  const Vec2 w = hs.third_uu + hs.hess * qdd;
  const Vec3 udd(-w.x(), -w.y(), 0.0);
  const double r = u.norm();
  const Vec3 n = u / r;
  const double rd = n.dot(ud);
  const Vec3 nd = (ud - n * rd) / r;
  const Vec3 ndd = (udd - nd * rd - n * (nd.dot(ud) + n.dot(udd))) / r - nd * rd / r;
  // Body origin: body_height + bump along the local normal.
  const double s = body_height_m_ + x[2], sd = dx[2], sdd = ddx[2];
  BodyState out;
  out.T_W_B.translation() = g + n * s;
  out.v_W = gd + nd * s + n * sd;
  out.a_W = gdd + ndd * s + 2.0 * nd * sd + n * sdd;
  // Tilt: the smallest rotation taking the plane's normal n0 onto n (Rodrigues with v = n0 x n,
  // c = n0 . n: R = I + [v] + [v]^2 / (1 + c)), and its angular velocity from dR/dt R^T.
  const Vec3 n0 = R_W_T_.col(2);
  const Mat3 K = skew(n0.cross(n)), Kd = skew(n0.cross(nd));
  const double c = n0.dot(n), cd = n0.dot(nd);
  const Mat3 R_tilt = Mat3::Identity() + K + K * K / (1.0 + c);
  const Mat3 R_tilt_d = Kd + (Kd * K + K * Kd) / (1.0 + c) - K * K * cd / ((1.0 + c) * (1.0 + c));
  const Vec3 omega_tilt_W = vee(R_tilt_d * R_tilt.transpose());
  out.T_W_B.linear() = R_tilt * R_base;
  out.omega_B = R_base.transpose() * (R_tilt.transpose() * omega_tilt_W) + omega_base;
  return out;
}

BodyState BodyTrajectory::state(double t_s) const {
  if (field_) return roughState(t_s);
  Vec6 x, dx, ddx;
  spline_.evaluate(t_s, &x, &dx, &ddx);
  if (t_s < 0.0 || t_s > duration()) {  // held still outside the spline's range
    dx.setZero();
    ddx.setZero();
  }
  const double psi = x[3], theta = x[4], phi = x[5];
  const double dpsi = dx[3], dtheta = dx[4], dphi = dx[5];
  BodyState s;
  s.T_W_B.linear() =
      R_W_T_ * (Eigen::AngleAxisd(psi, Vec3::UnitZ()) * Eigen::AngleAxisd(theta, Vec3::UnitY()) *
                Eigen::AngleAxisd(phi, Vec3::UnitX()))
                   .toRotationMatrix();
  s.T_W_B.translation() = R_W_T_ * Vec3(x[0], x[1], body_height_m_ + x[2]);
  s.v_W = R_W_T_ * Vec3(dx[0], dx[1], dx[2]);
  s.a_W = R_W_T_ * Vec3(ddx[0], ddx[1], ddx[2]);
  // Body rates of Z-Y-X Euler angles (R_W_T is constant).
  const double sp = std::sin(phi), cp = std::cos(phi), st = std::sin(theta), ct = std::cos(theta);
  s.omega_B = Vec3(dphi - dpsi * st, dtheta * cp + dpsi * sp * ct, -dtheta * sp + dpsi * cp * ct);
  return s;
}

BodyTrajectory planTrajectory(const TrajectoryOptions& o, const VineyardWorld& world,
                              std::uint64_t seed, double min_duration_s) {
  Rng rng(subSeed(seed, 3));
  Plan plan = makePlan(o, world, rng);
  {
    double total = 0.0;
    for (const auto& c : plan.commands) total += c.duration_s;
    if (total < min_duration_s) plan.commands.push_back({min_duration_s - total + 0.5, 0.0, 0.0});
  }
  const Schedule schedule(plan, o.ramp_s);
  const double knot = o.vibration_knot_s;
  const int segments = static_cast<int>(std::ceil(schedule.end() / knot)) + 1;
  const int points = segments + 3;

  // Integrate the row-following unicycle (RK4, 1 ms) and sample it at the knots: control point k
  // sits at time (k - 1) * knot.
  std::vector<double> weights(plan.lines.size());
  const auto deriv = [&](double t, const Eigen::Vector3d& s) {
    double v = 0.0, omega = 0.0;
    schedule.at(t, &v, &omega, &weights);
    for (std::size_t l = 0; l < plan.lines.size(); ++l) {
      if (weights[l] == 0.0) continue;
      const Line& line = plan.lines[l];
      const double e_psi = wrapAngle(s[2] - line.psi);
      const double e_lat = (s[1] - line.b) * std::cos(line.psi);  // left of the line, positive
      omega += weights[l] * (-1.2 * e_psi - 0.8 * std::abs(v) * e_lat);
    }
    return Eigen::Vector3d(v * std::cos(s[2]), v * std::sin(s[2]), omega);
  };
  const int substeps = std::max(1, static_cast<int>(std::round(knot / 0.001)));
  const double h = knot / substeps;
  Eigen::Vector3d s(plan.a0, plan.b0, plan.psi0);
  std::vector<Vec6> control(points, Vec6::Zero());
  Rng vib(subSeed(seed, 4));
  double t = 0.0;
  for (int k = 0; k < points; ++k) {
    const double t_k = (k - 1) * knot;
    while (t < t_k - 1e-12) {
      const Eigen::Vector3d k1 = deriv(t, s);
      const Eigen::Vector3d k2 = deriv(t + 0.5 * h, s + 0.5 * h * k1);
      const Eigen::Vector3d k3 = deriv(t + 0.5 * h, s + 0.5 * h * k2);
      const Eigen::Vector3d k4 = deriv(t + h, s + h * k3);
      s += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
      t += h;
    }
    double v = 0.0, omega = 0.0;
    schedule.at(std::max(t_k, 0.0), &v, &omega, &weights);
    // Ride vibration grows with speed and turning; none while standing.
    const double level =
        std::clamp(std::abs(v) / std::max(o.speed_mps, 0.1) + std::abs(omega) / 0.5, 0.0, 1.0);
    const double n_z = vib.normal(), n_pitch = vib.normal(), n_roll = vib.normal();
    Vec6& c = control[k];
    c << s[0], s[1], o.bump_sigma_m * level * n_z, s[2],
        o.vibration_sigma_deg * kDeg * level * n_pitch,
        o.vibration_sigma_deg * kDeg * level * n_roll;
  }
  // The spline's domain starts at t = 0 with segment 0 (control points 0..3).
  if (world.heightField())
    return BodyTrajectory(world.R_W_T(), o.body_height_m,
                          UniformCubicBSpline(knot, std::move(control)), world.heightField(),
                          world.planeGradient());
  return BodyTrajectory(world.R_W_T(), o.body_height_m,
                        UniformCubicBSpline(knot, std::move(control)));
}

}  // namespace ovo::sim
