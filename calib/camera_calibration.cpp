#include "calib/camera_calibration.hpp"

#include <ceres/autodiff_cost_function.h>
#include <ceres/loss_function.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/rotation.h>
#include <ceres/solver.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>

#include "calib/projection.hpp"
#include "common/error.hpp"
#include "common/stats.hpp"

#include <tbb/parallel_for.h>

namespace ovo::calib {
namespace {

// ---- parameter blocks ------------------------------------------------------------------------

struct PoseState {
  double aa[3];                  // angle-axis of R_C_B
  double t[3];                   // t_C_B
  double shape[2] = {0.0, 0.0};  // board shear and y stretch (BoardShape, see the options)
};

PoseState toState(const BoardPose& pose) {
  PoseState s;
  Eigen::AngleAxisd aa(pose.R_C_B);
  const Vec3 v = aa.angle() * aa.axis();
  for (int k = 0; k < 3; ++k) {
    s.aa[k] = v(k);
    s.t[k] = pose.t_C_B(k);
  }
  return s;
}

BoardPose fromState(const PoseState& s) {
  BoardPose pose;
  const Vec3 v(s.aa[0], s.aa[1], s.aa[2]);
  const double angle = v.norm();
  pose.R_C_B =
      angle > 0.0 ? Eigen::AngleAxisd(angle, v / angle).toRotationMatrix() : Mat3::Identity();
  pose.t_C_B = Vec3(s.t[0], s.t[1], s.t[2]);
  return pose;
}

// p_C = R_C_B S p_B + t_C_B, S = [1 shear; 0 1 + stretch] on the board plane (identity for a
// rigid board).
template <typename T>
void boardToCamera(const T* aa, const T* t, const T* shape, const Vec3& p_B, T* p_C) {
  const T p[3] = {T(p_B.x()) + shape[0] * p_B.y(), (T(1.0) + shape[1]) * p_B.y(), T(p_B.z())};
  ceres::AngleAxisRotatePoint(aa, p, p_C);
  for (int k = 0; k < 3; ++k) p_C[k] += t[k];
}

// The intrinsics of whichever model is being refined.
struct ModelState {
  CameraModelKind kind = CameraModelKind::kOcam;
  // OCam: normalised ss coefficients (projection.hpp), centre (row, col), affine (c, d, e).
  int degree = 4;
  double b[kOcamMaxCoeffs] = {0, 0, 0, 0, 0, 0, 0, 0};
  double ss_scale = 1.0;
  double centre[2] = {0, 0};
  double affine[3] = {1, 0, 0};
  double rho_max_px = 1.0;
  // Kannala-Brandt / pinhole: (fx, fy, cx, cy) and the distortion.
  double k[4] = {0, 0, 0, 0};
  double d[4] = {0, 0, 0, 0};
  // The board's shear and y stretch when one shape is shared by all views (BoardShape::kShared).
  double board_shape[2] = {0, 0};

  std::vector<double> ss() const {
    std::vector<double> a(degree + 1);
    for (int i = 0; i <= degree; ++i) a[i] = b[i] * std::pow(ss_scale, 1 - i);
    return a;
  }
  void setSs(const std::vector<double>& a) {
    ss_scale = std::abs(a.front());
    std::fill(std::begin(b), std::end(b), 0.0);
    for (int i = 0; i < static_cast<int>(a.size()) && i < kOcamMaxCoeffs; ++i)
      b[i] = a[i] * std::pow(ss_scale, i - 1);
    b[1] = 0.0;
  }
};

template <typename T>
bool projectWith(const ModelState& m, const T* b, const T* centre, const T* affine, const T* k,
                 const T* d, const T* p_C, T* uv) {
  switch (m.kind) {
    case CameraModelKind::kOcam:
      return projectOcam(b, m.ss_scale, centre, affine, p_C, m.rho_max_px, uv);
    case CameraModelKind::kKannalaBrandt:
      return projectKannalaBrandt(k, d, p_C, uv);
    case CameraModelKind::kPinhole:
      return projectPinholeRadtan(k, d, p_C, uv);
  }
  return false;
}

// Double-precision prediction of one corner.
bool predict(const ModelState& m, const PoseState& pose, const Vec3& p_B, Vec2* uv) {
  double p_C[3], out[2];
  boardToCamera(pose.aa, pose.t, pose.shape, p_B, p_C);
  if (!projectWith(m, m.b, m.centre, m.affine, m.k, m.d, p_C, out)) return false;
  *uv = Vec2(out[0], out[1]);
  return uv->allFinite();
}

// ---- residuals -------------------------------------------------------------------------------

struct OcamResidual {
  Vec2 observed;
  Vec3 p_B;
  double ss_scale, rho_max_px;
  template <typename T>
  bool operator()(const T* b, const T* centre, const T* affine, const T* aa, const T* t,
                  const T* shape, T* residual) const {
    T p_C[3], uv[2];
    boardToCamera(aa, t, shape, p_B, p_C);
    if (!projectOcam(b, ss_scale, centre, affine, p_C, rho_max_px, uv)) return false;
    residual[0] = uv[0] - observed.x();
    residual[1] = uv[1] - observed.y();
    return true;
  }
};

struct LensResidual {
  Vec2 observed;
  Vec3 p_B;
  CameraModelKind kind;
  template <typename T>
  bool operator()(const T* k, const T* d, const T* aa, const T* t, const T* shape,
                  T* residual) const {
    T p_C[3], uv[2];
    boardToCamera(aa, t, shape, p_B, p_C);
    const bool ok = kind == CameraModelKind::kKannalaBrandt ? projectKannalaBrandt(k, d, p_C, uv)
                                                            : projectPinholeRadtan(k, d, p_C, uv);
    if (!ok) return false;
    residual[0] = uv[0] - observed.x();
    residual[1] = uv[1] - observed.y();
    return true;
  }
};

// The affine [c d; e 1] of the OCam model holds a rotation about the optical axis that the board
// poses absorb exactly (with a scale that the polynomial absorbs): a gauge freedom. It is fixed
// by keeping the matrix symmetric, d = e (the polar decomposition's stretch; the rotation goes
// into the camera frame). Ambient (c, d, e), tangent (dc, dd) with e moving with d.
class SymmetricAffineManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 3; }
  int TangentSize() const override { return 2; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override {
    x_plus_delta[0] = x[0] + delta[0];
    x_plus_delta[1] = x[1] + delta[1];
    x_plus_delta[2] = x[2] + delta[1];
    return true;
  }
  bool PlusJacobian(const double*, double* jacobian) const override {
    const double J[6] = {1, 0, 0, 1, 0, 1};  // row-major 3x2
    std::copy(J, J + 6, jacobian);
    return true;
  }
  bool Minus(const double* y, const double* x, double* y_minus_x) const override {
    y_minus_x[0] = y[0] - x[0];
    y_minus_x[1] = 0.5 * ((y[1] - x[1]) + (y[2] - x[2]));
    return true;
  }
  bool MinusJacobian(const double*, double* jacobian) const override {
    const double J[6] = {1, 0, 0, 0, 0.5, 0.5};  // row-major 2x3
    std::copy(J, J + 6, jacobian);
    return true;
  }
};

// ---- one refinement --------------------------------------------------------------------------

struct Problem {
  const std::vector<BoardObservation>* boards;
  std::vector<PoseState>* poses;
  std::vector<std::vector<char>> usable;  // corners that take part
};

void solve(ModelState& m, Problem& pb, const CalibrationOptions& options, bool intrinsics_fixed) {
  ceres::Problem problem;
  const auto shapeBlock = [&](PoseState& pose) {
    return options.board_shape == BoardShape::kPerBoard ? pose.shape : m.board_shape;
  };
  const auto& boards = *pb.boards;
  for (std::size_t j = 0; j < boards.size(); ++j) {
    PoseState& pose = (*pb.poses)[j];
    for (std::size_t i = 0; i < boards[j].size(); ++i) {
      if (!pb.usable[j][i]) continue;
      ceres::LossFunction* loss =
          options.huber_px > 0.0 ? new ceres::HuberLoss(options.huber_px) : nullptr;
      if (m.kind == CameraModelKind::kOcam) {
        auto* cost =
            new ceres::AutoDiffCostFunction<OcamResidual, 2, kOcamMaxCoeffs, 2, 3, 3, 3, 2>(
                new OcamResidual{boards[j].corners_px[i], boards[j].points_B[i], m.ss_scale,
                                 m.rho_max_px});
        problem.AddResidualBlock(cost, loss, m.b, m.centre, m.affine, pose.aa, pose.t,
                                 shapeBlock(pose));
      } else {
        auto* cost = new ceres::AutoDiffCostFunction<LensResidual, 2, 4, 4, 3, 3, 2>(
            new LensResidual{boards[j].corners_px[i], boards[j].points_B[i], m.kind});
        problem.AddResidualBlock(cost, loss, m.k, m.d, pose.aa, pose.t, shapeBlock(pose));
      }
    }
  }
  if (options.board_shape == BoardShape::kRigid || intrinsics_fixed)
    for (PoseState& pose : *pb.poses)
      if (problem.HasParameterBlock(shapeBlock(pose)))
        problem.SetParameterBlockConstant(shapeBlock(pose));
  if (m.kind == CameraModelKind::kOcam) {
    if (problem.HasParameterBlock(m.b)) {
      std::vector<int> fixed{1};  // a1 = 0
      for (int i = m.degree + 1; i < kOcamMaxCoeffs; ++i) fixed.push_back(i);
      problem.SetManifold(m.b, new ceres::SubsetManifold(kOcamMaxCoeffs, fixed));
      problem.SetManifold(m.affine, new SymmetricAffineManifold);
      if (intrinsics_fixed) {
        problem.SetParameterBlockConstant(m.b);
        problem.SetParameterBlockConstant(m.centre);
        problem.SetParameterBlockConstant(m.affine);
      }
    }
  } else if (problem.HasParameterBlock(m.k) && intrinsics_fixed) {
    problem.SetParameterBlockConstant(m.k);
    problem.SetParameterBlockConstant(m.d);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.max_num_iterations = options.max_iterations;
  so.num_threads = std::max(1, options.threads);
  so.function_tolerance = 1e-12;
  so.gradient_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (options.board_shape != BoardShape::kPerBoard)
    for (PoseState& pose : *pb.poses) std::copy(m.board_shape, m.board_shape + 2, pose.shape);
}

struct Residuals {
  std::vector<std::vector<Vec2>> per_corner;  // NaN where unusable
  std::vector<double> rms, mean;
};

Residuals residualsOf(const ModelState& m, const Problem& pb) {
  Residuals r;
  const auto& boards = *pb.boards;
  for (std::size_t j = 0; j < boards.size(); ++j) {
    std::vector<Vec2> res;
    double sum2 = 0.0, sum = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < boards[j].size(); ++i) {
      Vec2 uv;
      if (!pb.usable[j][i] || !predict(m, (*pb.poses)[j], boards[j].points_B[i], &uv)) {
        res.push_back(Vec2::Constant(std::numeric_limits<double>::quiet_NaN()));
        continue;
      }
      res.push_back(uv - boards[j].corners_px[i]);
      sum2 += res.back().squaredNorm();
      sum += res.back().norm();
      ++n;
    }
    r.per_corner.push_back(std::move(res));
    r.rms.push_back(n ? std::sqrt(sum2 / n) : std::numeric_limits<double>::infinity());
    r.mean.push_back(n ? sum / n : std::numeric_limits<double>::infinity());
  }
  return r;
}

std::string rejectedList(const std::vector<RejectedImage>& rejected) {
  std::string out;
  for (const auto& r : rejected) out += fmt::format("\n  {}: {}", r.image, r.reason);
  return out;
}

// Refines, rejects boards that do not fit and refines again until none is rejected.
void refineWithRejection(ModelState& m, std::vector<BoardObservation>& boards,
                         std::vector<PoseState>& poses, std::vector<std::vector<char>>& usable,
                         const CalibrationOptions& options, std::vector<RejectedImage>* rejected) {
  for (int round = 0; round < 10; ++round) {
    Problem pb{&boards, &poses, usable};
    solve(m, pb, options, false);
    const Residuals res = residualsOf(m, pb);
    const double med = upperMedian(res.rms);
    const double limit = std::max(options.reject_rms_px, options.reject_factor * med);
    std::vector<std::size_t> keep;
    for (std::size_t j = 0; j < boards.size(); ++j) {
      if (res.rms[j] <= limit) {
        keep.push_back(j);
        continue;
      }
      rejected->push_back(
          {boards[j].image,
           std::isfinite(res.rms[j])
               ? fmt::format(
                     "reprojection RMS {:.2f} px after calibration, above {:.2f} px ({}x the "
                     "median {:.2f} px, at least {:.2f} px): corners misdetected or out of order",
                     res.rms[j], limit, options.reject_factor, med, options.reject_rms_px)
               : std::string("the calibrated model cannot project its corners")});
    }
    if (keep.size() == boards.size()) return;
    if (static_cast<int>(keep.size()) < options.min_boards)
      fail("calibration: only {} usable boards remain, at least {} are needed; rejected:{}",
           keep.size(), options.min_boards, rejectedList(*rejected));
    std::vector<BoardObservation> b2;
    std::vector<PoseState> p2;
    std::vector<std::vector<char>> u2;
    for (std::size_t j : keep) {
      b2.push_back(std::move(boards[j]));
      p2.push_back(poses[j]);
      u2.push_back(std::move(usable[j]));
    }
    boards = std::move(b2);
    poses = std::move(p2);
    usable = std::move(u2);
  }
}

// The radial curve of the refined OCam model (pixels from the centre, along the column axis)
// at off-axis angles up to phi_max.
std::vector<std::pair<double, double>> ocamRadialCurve(const ModelState& ocam, double phi_max) {
  std::vector<std::pair<double, double>> curve;
  const double centre[2] = {0.0, 0.0}, affine[3] = {1.0, 0.0, 0.0};
  for (int i = 1; i <= 200; ++i) {
    const double phi = phi_max * i / 200.0;
    const double p[3] = {std::sin(phi), 0.0, std::cos(phi)};
    double uv[2];
    if (projectOcam(ocam.b, ocam.ss_scale, centre, affine, p, ocam.rho_max_px, uv))
      curve.emplace_back(phi, uv[0]);
  }
  return curve;
}

// Kannala-Brandt or pinhole intrinsics fitted to the OCam model: rho = f g(theta) (1 + k1 g^2 +
// ...) linear in f and f k_i, with g = theta (KB) or tan(theta) (pinhole).
ModelState lensFromOcam(const ModelState& ocam, CameraModelKind kind, double phi_max) {
  ModelState m;
  m.kind = kind;
  const bool kb = kind == CameraModelKind::kKannalaBrandt;
  const double limit = kb ? phi_max : std::min(phi_max, 70.0 * M_PI / 180.0);
  const auto curve = ocamRadialCurve(ocam, limit);
  const int terms = kb ? 5 : 3;
  Eigen::MatrixXd A(curve.size(), terms);
  Eigen::VectorXd y(curve.size());
  for (std::size_t i = 0; i < curve.size(); ++i) {
    const double g = kb ? curve[i].first : std::tan(curve[i].first);
    double power = g;
    for (int k = 0; k < terms; ++k, power *= g * g) A(i, k) = power;
    y(i) = curve[i].second;
  }
  Eigen::VectorXd x = Eigen::VectorXd::Zero(terms);
  if (curve.size() >= static_cast<std::size_t>(terms)) x = A.colPivHouseholderQr().solve(y);
  double f = x(0);
  if (!(f > 0.0 && std::isfinite(f))) {
    f = ocam.ss_scale;
    x.setZero();
    x(0) = f;
  }
  std::copy(ocam.board_shape, ocam.board_shape + 2, m.board_shape);
  m.k[0] = f;
  m.k[1] = f * ocam.affine[0];  // the toolbox's c stretches rows
  m.k[2] = ocam.centre[1];
  m.k[3] = ocam.centre[0];
  for (int k = 1; k < terms; ++k) m.d[k - 1] = x(k) / f;
  return m;
}

double offAxis(const PoseState& pose, const Vec3& p_B) {
  double p_C[3];
  boardToCamera(pose.aa, pose.t, pose.shape, p_B, p_C);
  return std::atan2(std::hypot(p_C[0], p_C[1]), p_C[2]);
}

camera::Camera cameraOf(const ModelState& m, int width, int height) {
  switch (m.kind) {
    case CameraModelKind::kOcam: {
      camera::OcamParams p;
      p.ss = m.ss();
      p.center_row = m.centre[0];
      p.center_col = m.centre[1];
      p.c = m.affine[0];
      p.d = m.affine[1];
      p.e = m.affine[2];
      p.width = width;
      p.height = height;
      // invpol fitted afterwards: the model fits it when none is given; keep it as the file's own.
      const camera::OcamCamera fitted(p);
      p.invpol = fitted.projectionInvpol();
      return camera::OcamCamera(p);
    }
    case CameraModelKind::kKannalaBrandt:
      return camera::KannalaBrandtCamera({.fx = m.k[0],
                                          .fy = m.k[1],
                                          .cx = m.k[2],
                                          .cy = m.k[3],
                                          .k1 = m.d[0],
                                          .k2 = m.d[1],
                                          .k3 = m.d[2],
                                          .k4 = m.d[3],
                                          .width = width,
                                          .height = height});
    case CameraModelKind::kPinhole:
      return camera::PinholeRadtanCamera({.fx = m.k[0],
                                          .fy = m.k[1],
                                          .cx = m.k[2],
                                          .cy = m.k[3],
                                          .k1 = m.d[0],
                                          .k2 = m.d[1],
                                          .p1 = m.d[2],
                                          .p2 = m.d[3],
                                          .k3 = 0.0,
                                          .width = width,
                                          .height = height});
  }
  fail("calibration: unknown camera model");
}

void checkSizes(const std::vector<BoardObservation>& boards) {
  for (const auto& b : boards) {
    if (b.width <= 0 || b.height <= 0)
      fail("{}: the image size is unknown ({}x{})", b.image, b.width, b.height);
    if (b.width != boards.front().width || b.height != boards.front().height)
      fail(
          "calibration: images of different sizes: {} is {}x{} but {} is {}x{}; calibrate one "
          "camera (one image size) at a time",
          b.image, b.width, b.height, boards.front().image, boards.front().width,
          boards.front().height);
    if (b.corners_px.size() != b.points_B.size() || b.size() < 6)
      fail("{}: a board needs at least 6 corners with board coordinates, got {}", b.image,
           b.size());
  }
}

}  // namespace

CameraModelKind parseCameraModel(const std::string& name, const std::string& option) {
  if (name == "ocam") return CameraModelKind::kOcam;
  if (name == "kb") return CameraModelKind::kKannalaBrandt;
  if (name == "pinhole") return CameraModelKind::kPinhole;
  fail("{}: expected ocam, kb or pinhole, got '{}'", option, name);
}

BoardShape parseBoardShape(const std::string& name, const std::string& option) {
  if (name == "rigid") return BoardShape::kRigid;
  if (name == "shared") return BoardShape::kShared;
  if (name == "per-board") return BoardShape::kPerBoard;
  fail("{}: expected rigid, shared or per-board, got '{}'", option, name);
}

std::string boardShapeName(BoardShape shape) {
  switch (shape) {
    case BoardShape::kRigid:
      return "rigid";
    case BoardShape::kShared:
      return "shared";
    case BoardShape::kPerBoard:
      return "per-board";
  }
  return "?";
}

std::string modelKindName(CameraModelKind kind) {
  switch (kind) {
    case CameraModelKind::kOcam:
      return "ocam";
    case CameraModelKind::kKannalaBrandt:
      return "kb";
    case CameraModelKind::kPinhole:
      return "pinhole";
  }
  return "?";
}

namespace {

// calibrateCamera, also giving the refined model's state (for fits with it fixed).
CalibrationResult calibrate(const std::vector<BoardObservation>& input,
                            const CalibrationOptions& options, ModelState* model_out) {
  if (static_cast<int>(input.size()) < options.min_boards)
    fail(
        "calibration: {} board{} found, at least {} are needed (boards seen from different "
        "directions, covering the image)",
        input.size(), input.size() == 1 ? "" : "s", options.min_boards);
  checkSizes(input);
  if (options.ocam_degree < 2 || options.ocam_degree >= kOcamMaxCoeffs)
    fail("calibration: the OCam polynomial degree must be 2 to {}, got {}", kOcamMaxCoeffs - 1,
         options.ocam_degree);
  const int width = input.front().width, height = input.front().height;

  CalibrationResult result;
  result.model = options.model;
  result.width = width;
  result.height = height;

  // Linear initialisation; boards it cannot place at all are rejected before the refinement.
  OcamInitOptions init_options;
  init_options.degree = options.ocam_degree;
  std::string why;
  auto init = ocamLinearInit(input, init_options, &why);
  if (!init) fail("calibration: {}", why);
  result.init_rms_px = init->rms_px;

  std::vector<BoardObservation> boards = input;
  std::vector<PoseState> poses;
  for (const auto& p : init->poses) poses.push_back(toState(p));
  std::vector<std::vector<char>> usable;
  for (const auto& b : boards) usable.emplace_back(b.size(), 1);

  ModelState ocam;
  ocam.kind = CameraModelKind::kOcam;
  ocam.degree = options.ocam_degree;
  ocam.setSs(init->ss);
  ocam.centre[0] = init->center_row;
  ocam.centre[1] = init->center_col;
  ocam.rho_max_px = 2.0 * std::hypot(width, height);

  // Corners the initial model cannot project take no part (a wild initial pose).
  for (std::size_t j = 0; j < boards.size(); ++j)
    for (std::size_t i = 0; i < boards[j].size(); ++i) {
      Vec2 uv;
      usable[j][i] = predict(ocam, poses[j], boards[j].points_B[i], &uv) ? 1 : 0;
    }
  refineWithRejection(ocam, boards, poses, usable, options, &result.rejected);

  ModelState model = ocam;
  if (options.model != CameraModelKind::kOcam) {
    double phi_max = 0.0;
    for (std::size_t j = 0; j < boards.size(); ++j)
      for (const Vec3& p : boards[j].points_B) phi_max = std::max(phi_max, offAxis(poses[j], p));
    model = lensFromOcam(ocam, options.model, phi_max);
    if (options.model == CameraModelKind::kPinhole) {
      // Corners too far off-axis for a pinhole are left out; boards with few left are rejected.
      std::vector<std::size_t> keep;
      int dropped = 0;
      for (std::size_t j = 0; j < boards.size(); ++j) {
        int n = 0;
        for (std::size_t i = 0; i < boards[j].size(); ++i) {
          Vec2 uv;
          usable[j][i] = offAxis(poses[j], boards[j].points_B[i]) < 80.0 * M_PI / 180.0 &&
                         predict(model, poses[j], boards[j].points_B[i], &uv);
          n += usable[j][i];
        }
        dropped += static_cast<int>(boards[j].size()) - n;
        if (2 * n >= static_cast<int>(boards[j].size())) {
          keep.push_back(j);
        } else {
          result.rejected.push_back(
              {boards[j].image,
               fmt::format("{} of its {} corners lie beyond the pinhole model's field of view "
                           "(80 deg off-axis)",
                           boards[j].size() - n, boards[j].size())});
        }
      }
      if (dropped > 0)
        result.notes.push_back(fmt::format(
            "{} corners beyond 80 deg off-axis left out of the pinhole model", dropped));
      if (static_cast<int>(keep.size()) < options.min_boards)
        fail(
            "calibration: only {} boards fit a pinhole model, at least {} are needed; "
            "rejected:{}",
            keep.size(), options.min_boards, rejectedList(result.rejected));
      std::vector<BoardObservation> b2;
      std::vector<PoseState> p2;
      std::vector<std::vector<char>> u2;
      for (std::size_t j : keep) {
        b2.push_back(boards[j]);
        p2.push_back(poses[j]);
        u2.push_back(usable[j]);
      }
      boards = std::move(b2);
      poses = std::move(p2);
      usable = std::move(u2);
    }
    refineWithRejection(model, boards, poses, usable, options, &result.rejected);
  }

  const Problem pb{&boards, &poses, usable};
  const Residuals res = residualsOf(model, pb);
  double sum2 = 0.0, sum = 0.0;
  int n = 0;
  for (const auto& board : res.per_corner)
    for (const Vec2& r : board)
      if (r.allFinite()) {
        sum2 += r.squaredNorm();
        sum += r.norm();
        ++n;
      }
  result.rms_px = n ? std::sqrt(sum2 / n) : 0.0;
  result.mean_error_px = n ? sum / n : 0.0;
  result.mean_of_image_means_px = std::accumulate(res.mean.begin(), res.mean.end(), 0.0) /
                                  std::max<std::size_t>(1, res.mean.size());
  result.corners_used = n;
  result.board_shear = model.board_shape[0];
  result.board_stretch = model.board_shape[1];
  result.per_image_rms_px = res.rms;
  result.per_image_mean_px = res.mean;
  result.residuals_px = res.per_corner;
  for (const auto& p : poses) result.poses.push_back(fromState(p));
  result.boards = std::move(boards);
  result.camera = cameraOf(model, width, height);
  if (model_out) *model_out = model;
  return result;
}

// A board's pose under a fixed camera, in closed form: the corners' bearings b_i are parallel to
// H (X_i, Y_i, 1) with H = [r1 r2 t] up to scale (the board plane's homography onto bearings);
// H from b_i x H x_i = 0 by SVD, then the nearest rotation. nullopt when the corners do not
// unproject or the board is not in front.
std::optional<PoseState> poseFromBearings(const camera::Camera& cam, const BoardObservation& b,
                                          const double* shape) {
  Eigen::MatrixXd A(2 * b.size(), 9);
  int rows = 0;
  std::vector<Vec3> bearings;
  std::vector<Vec3> points;
  for (std::size_t i = 0; i < b.size(); ++i) {
    const auto f = camera::unproject(cam, b.corners_px[i]);
    if (!f) continue;
    const Vec3 d = f->normalized();
    const Vec3& P = b.points_B[i];
    const Vec3 x(P.x() + shape[0] * P.y(), (1.0 + shape[1]) * P.y(), 1.0);
    // Two rows of d x (H x) = 0: H's rows h1, h2, h3 with d = (dx, dy, dz).
    A.row(rows).setZero();
    A.row(rows).segment<3>(3) = -d.z() * x.transpose();
    A.row(rows).segment<3>(6) = d.y() * x.transpose();
    A.row(rows + 1).setZero();
    A.row(rows + 1).segment<3>(0) = d.z() * x.transpose();
    A.row(rows + 1).segment<3>(6) = -d.x() * x.transpose();
    rows += 2;
    bearings.push_back(d);
    points.push_back(x);
  }
  if (rows < 12) return std::nullopt;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A.topRows(rows), Eigen::ComputeFullV);
  const Eigen::VectorXd h = svd.matrixV().col(8);
  Mat3 H;
  H << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  // The board in front: the bearings point at the points.
  double front = 0.0;
  for (std::size_t i = 0; i < bearings.size(); ++i) front += bearings[i].dot(H * points[i]);
  if (front < 0.0) H = -H;
  const double scale = 2.0 / (H.col(0).norm() + H.col(1).norm());
  if (!std::isfinite(scale)) return std::nullopt;
  Mat3 R;
  R.col(0) = scale * H.col(0);
  R.col(1) = scale * H.col(1);
  R.col(2) = R.col(0).cross(R.col(1));
  Eigen::JacobiSVD<Mat3> r_svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  R = r_svd.matrixU() * r_svd.matrixV().transpose();
  if (R.determinant() < 0.0) return std::nullopt;
  BoardPose pose;
  pose.R_C_B = R;
  pose.t_C_B = scale * H.col(2);
  PoseState state = toState(pose);
  std::copy(shape, shape + 2, state.shape);
  return state;
}

}  // namespace

CalibrationResult calibrateCamera(const std::vector<BoardObservation>& input,
                                  const CalibrationOptions& options) {
  return calibrate(input, options, nullptr);
}

HeldOutError crossValidate(const std::vector<BoardObservation>& boards,
                           const CalibrationOptions& options, int folds) {
  checkSizes(boards);
  const int n = static_cast<int>(boards.size());
  folds = std::clamp(folds, 2, std::max(2, n));
  HeldOutError out;
  out.folds = folds;
  out.per_image_rms_px.assign(boards.size(), std::numeric_limits<double>::quiet_NaN());
  std::vector<double> sum2(boards.size(), 0.0);
  std::vector<int> count(boards.size(), 0);
  CalibrationOptions fold_options = options;
  fold_options.threads = 1;  // the folds run in parallel
  tbb::parallel_for(0, folds, [&](int f) {
    std::vector<BoardObservation> train, test;
    std::vector<std::size_t> test_index;
    for (int j = 0; j < n; ++j) {
      if (j % folds == f) {
        test.push_back(boards[j]);
        test_index.push_back(j);
      } else {
        train.push_back(boards[j]);
      }
    }
    if (static_cast<int>(train.size()) < options.min_boards) return;
    ModelState model;
    CalibrationResult fit;
    try {
      fit = calibrate(train, fold_options, &model);
    } catch (const Error&) {
      return;  // this fold's boards stay NaN (failed)
    }
    // The held-out boards' poses with the intrinsics and the shared board shape fixed; a free
    // shape per board (kPerBoard) is not a property of the camera and is held at zero.
    const double zero_shape[2] = {0.0, 0.0};
    const double* shape =
        options.board_shape == BoardShape::kShared ? model.board_shape : zero_shape;
    CalibrationOptions pose_options = fold_options;
    pose_options.huber_px = 0.0;
    pose_options.board_shape =
        options.board_shape == BoardShape::kPerBoard ? BoardShape::kRigid : options.board_shape;
    for (std::size_t k = 0; k < test.size(); ++k) {
      const auto pose = poseFromBearings(*fit.camera, test[k], shape);
      if (!pose) continue;
      std::vector<BoardObservation> one{test[k]};
      std::vector<PoseState> poses{*pose};
      std::vector<std::vector<char>> usable{std::vector<char>(test[k].size(), 1)};
      Problem pb{&one, &poses, usable};
      ModelState fixed = model;
      solve(fixed, pb, pose_options, true);
      const Residuals res = residualsOf(fixed, pb);
      double s2 = 0.0;
      int c = 0;
      for (const Vec2& r : res.per_corner[0])
        if (r.allFinite()) {
          s2 += r.squaredNorm();
          ++c;
        }
      if (c == 0) continue;
      const std::size_t j = test_index[k];
      sum2[j] = s2;
      count[j] = c;
      out.per_image_rms_px[j] = std::sqrt(s2 / c);
    }
  });
  double total2 = 0.0;
  for (std::size_t j = 0; j < boards.size(); ++j) {
    if (count[j] == 0) {
      ++out.failed;
      continue;
    }
    total2 += sum2[j];
    out.corners += count[j];
  }
  out.rms_px = out.corners > 0 ? std::sqrt(total2 / out.corners)
                               : std::numeric_limits<double>::quiet_NaN();
  return out;
}

FixedModelFit fitPosesWithFixedOcam(const std::vector<BoardObservation>& boards,
                                    const camera::OcamParams& params) {
  checkSizes(boards);
  OcamInitOptions init_options;
  init_options.degree = std::max(2, static_cast<int>(params.ss.size()) - 1);
  auto init = ocamLinearInit(boards, init_options);
  if (!init) fail("pose fit: the linear initialisation failed");
  std::vector<BoardObservation> b = boards;
  std::vector<PoseState> poses;
  for (const auto& p : init->poses) poses.push_back(toState(p));
  std::vector<std::vector<char>> usable;
  for (const auto& board : b) usable.emplace_back(board.size(), 1);
  ModelState m;
  m.kind = CameraModelKind::kOcam;
  m.degree = static_cast<int>(params.ss.size()) - 1;
  m.rho_max_px = 2.0 * std::hypot(params.width, params.height);
  CalibrationOptions options;
  options.huber_px = 0.0;
  // Poses first under the initial model (closer to the start), then under the fixed one.
  m.setSs(init->ss);
  m.centre[0] = init->center_row;
  m.centre[1] = init->center_col;
  Problem pb{&b, &poses, usable};
  solve(m, pb, options, true);
  m.setSs(params.ss);
  m.centre[0] = params.center_row;
  m.centre[1] = params.center_col;
  m.affine[0] = params.c;
  m.affine[1] = params.d;
  m.affine[2] = params.e;
  solve(m, pb, options, true);
  const Residuals res = residualsOf(m, pb);
  FixedModelFit fit;
  fit.per_image_rms_px = res.rms;
  fit.per_image_mean_px = res.mean;
  double sum2 = 0.0;
  int n = 0;
  for (const auto& board : res.per_corner)
    for (const Vec2& r : board)
      if (r.allFinite()) {
        sum2 += r.squaredNorm();
        ++n;
      }
  fit.rms_px = n ? std::sqrt(sum2 / n) : 0.0;
  fit.mean_of_image_means_px = std::accumulate(res.mean.begin(), res.mean.end(), 0.0) /
                               std::max<std::size_t>(1, res.mean.size());
  return fit;
}

}  // namespace ovo::calib
