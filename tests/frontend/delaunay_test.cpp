// Delaunay triangulation known answers: empty circumcircles, the triangle count of Euler's formula,
// a fully cocircular lattice, repeated points.
#include "frontend/delaunay.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace ovo::frontend {
namespace {

double cross(const Vec2& o, const Vec2& a, const Vec2& b) {
  return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
}

// Number of convex hull vertices (Andrew's monotone chain, collinear points excluded).
int hullSize(std::vector<Vec2> p) {
  std::sort(p.begin(), p.end(), [](const Vec2& a, const Vec2& b) {
    return a.x() != b.x() ? a.x() < b.x() : a.y() < b.y();
  });
  std::vector<Vec2> h(2 * p.size());
  int k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (int i = static_cast<int>(p.size()) - 2, t = k + 1; i >= 0; --i) {
    while (k >= t && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  return k - 1;
}

TEST(Delaunay, RandomPointsHaveEmptyCircumcirclesAndEulerCount) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 640.0), v(0.0, 480.0);
  std::vector<Vec2> pts(1500);
  for (Vec2& p : pts) p = Vec2(u(rng), v(rng));
  const auto tris = delaunayTriangles(pts);
  // A triangulation of n points with h on the hull has 2n - 2 - h triangles; the enclosing
  // triangle may cost a few thin ones along the hull.
  const int expected = 2 * static_cast<int>(pts.size()) - 2 - hullSize(pts);
  EXPECT_LE(static_cast<int>(tris.size()), expected);
  EXPECT_GE(static_cast<int>(tris.size()), expected - 5);
  int violations = 0;
  for (const auto& t : tris) {
    const Vec2 &a = pts[t[0]], &b = pts[t[1]], &c = pts[t[2]];
    EXPECT_GT(std::abs(cross(a, b, c)), 0.0);
    const double d = 2.0 * cross(a, b, c);
    const Vec2 centre((a.squaredNorm() * (b.y() - c.y()) + b.squaredNorm() * (c.y() - a.y()) +
                       c.squaredNorm() * (a.y() - b.y())) /
                          d,
                      (a.squaredNorm() * (c.x() - b.x()) + b.squaredNorm() * (a.x() - c.x()) +
                       c.squaredNorm() * (b.x() - a.x())) /
                          d);
    const double r2 = (a - centre).squaredNorm();
    for (const Vec2& p : pts) {
      if ((p - centre).squaredNorm() < r2 * (1.0 - 1e-9)) ++violations;
    }
  }
  EXPECT_EQ(violations, 0);
}

TEST(Delaunay, CocircularLatticeGivesTwoTrianglesPerCell) {
  std::vector<Vec2> pts;
  for (int r = 0; r < 12; ++r)
    for (int c = 0; c < 12; ++c) pts.emplace_back(7.0 * c + 100.0, 7.0 * r + 50.0);
  const auto tris = delaunayTriangles(pts);
  EXPECT_EQ(tris.size(), 2u * 11 * 11);
  for (const auto& t : tris) {
    const double area2 = std::abs(cross(pts[t[0]], pts[t[1]], pts[t[2]]));
    EXPECT_NEAR(area2, 49.0, 1e-9);  // half a cell each
  }
}

TEST(Delaunay, RepeatedPointsTakePartOnceAsTheFirstOccurrence) {
  const std::vector<Vec2> pts = {{0, 0}, {10, 0}, {10, 0}, {0, 10}, {10, 10}, {0, 10}};
  const auto tris = delaunayTriangles(pts);
  ASSERT_EQ(tris.size(), 2u);
  for (const auto& t : tris) {
    for (const int i : t) EXPECT_TRUE(i == 0 || i == 1 || i == 3 || i == 4) << i;
  }
}

}  // namespace
}  // namespace ovo::frontend
