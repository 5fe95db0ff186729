#include "common/so3.hpp"

#include <gtest/gtest.h>

#include "tests/test_support.hpp"

namespace ovo {
namespace {

TEST(So3, ExpLogRoundTripIncludingNearPi) {
  for (const Vec3& w :
       {Vec3(0.1, -0.2, 0.3), Vec3(1e-9, 2e-9, -1e-9), Vec3(0, 0, 3.1), Vec3(2.0, -1.0, 0.5)}) {
    const Vec3 back = so3::log(so3::exp(w));
    EXPECT_LT((back - w).norm(), 1e-9) << w.transpose();
  }
}

TEST(So3, ExpMatchesEigenAngleAxis) {
  const Vec3 w(0.3, -0.4, 1.2);
  const Mat3 R = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
  EXPECT_LT((so3::exp(w) - R).norm(), 1e-12);
}

TEST(So3, RightJacobianMatchesNumericAndInverse) {
  const Vec3 w(0.4, 0.1, -0.7);
  // Log(Exp(w)^T Exp(w + d)) ~ Jr(w) d
  auto f = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
    return so3::log(so3::exp(w).transpose() * so3::exp(w + Vec3(d)));
  };
  const Eigen::MatrixXd Jn = test::numericJacobian(f, Eigen::VectorXd::Zero(3));
  OVO_EXPECT_JACOBIAN_NEAR(so3::rightJacobian(w), Jn, 1e-7);
  EXPECT_LT((so3::rightJacobian(w) * so3::rightJacobianInverse(w) - Mat3::Identity()).norm(),
            1e-12);
}

}  // namespace
}  // namespace ovo
