// Delaunay triangulation known answers: empty circumcircles (also on integer pixels, where many
// points are cocircular or collinear), the triangle count of Euler's formula, a fully cocircular
// lattice, repeated points.
#include "frontend/delaunay.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>

namespace ovo::frontend {
namespace {

double cross(const Vec2& o, const Vec2& a, const Vec2& b) {
  return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
}

// Convex hull vertices, counter-clockwise (Andrew's monotone chain, collinear points excluded).
std::vector<Vec2> convexHull(std::vector<Vec2> p) {
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
  h.resize(k - 1);  // the last vertex repeats the first
  return h;
}

TEST(Delaunay, RandomPointsHaveEmptyCircumcirclesAndEulerCount) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 640.0), v(0.0, 480.0);
  std::vector<Vec2> pts(1500);
  for (Vec2& p : pts) {
    // Sequenced draws, the last component first (see draw3 in tests/test_support.hpp).
    const double y = v(rng), x = u(rng);
    p = Vec2(x, y);
  }
  const auto tris = delaunayTriangles(pts);
  // A triangulation of n points with h on the hull has 2n - 2 - h triangles; the enclosing
  // triangle may cost a few thin ones along the hull.
  const int expected =
      2 * static_cast<int>(pts.size()) - 2 - static_cast<int>(convexHull(pts).size());
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

// > 0 when d is strictly inside the circle through the counter-clockwise a, b, c (exact for small
// integer coordinates).
std::int64_t inCircleExact(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const auto ax = std::int64_t(a.x() - d.x()), ay = std::int64_t(a.y() - d.y());
  const auto bx = std::int64_t(b.x() - d.x()), by = std::int64_t(b.y() - d.y());
  const auto cx = std::int64_t(c.x() - d.x()), cy = std::int64_t(c.y() - d.y());
  return (ax * ax + ay * ay) * (bx * cy - cx * by) + (bx * bx + by * by) * (cx * ay - ax * cy) +
         (cx * cx + cy * cy) * (ax * by - bx * ay);
}

TEST(Delaunay, IntegerPixelsWithManyCocircularPointsGiveAnExactDelaunayTiling) {
  // 2500 draws on a 120 x 90 pixel grid: repeats, collinear runs and cocircular quadruples.
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> u(0, 119), v(0, 89);
  std::vector<Vec2> pts(2500);
  for (Vec2& p : pts) {
    // Sequenced draws, the last component first (see draw3 in tests/test_support.hpp).
    const double y = v(rng), x = u(rng);
    p = Vec2(x, y);
  }
  const auto tris = delaunayTriangles(pts);
  std::vector<Vec2> distinct = pts;
  std::sort(distinct.begin(), distinct.end(), [](const Vec2& a, const Vec2& b) {
    return a.x() != b.x() ? a.x() < b.x() : a.y() < b.y();
  });
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  // Every triangle counter-clockwise with an empty circumcircle, and together they tile the
  // convex hull: their areas add up to the hull's (twice the area, exact in integers).
  double area2 = 0.0;
  int violations = 0;
  for (const auto& t : tris) {
    const Vec2 &a = pts[t[0]], &b = pts[t[1]], &c = pts[t[2]];
    ASSERT_GT(cross(a, b, c), 0.0);
    area2 += cross(a, b, c);
    for (const Vec2& p : distinct) violations += inCircleExact(a, b, c, p) > 0;
  }
  EXPECT_EQ(violations, 0);
  const std::vector<Vec2> h = convexHull(distinct);
  double hull_area2 = 0.0;
  for (std::size_t i = 1; i + 1 < h.size(); ++i) hull_area2 += cross(h[0], h[i], h[i + 1]);
  EXPECT_EQ(area2, hull_area2);
  // Repeated points take part once, as their first occurrence.
  for (const auto& t : tris) {
    for (const int i : t) {
      for (int j = 0; j < i; ++j) ASSERT_FALSE(pts[j] == pts[i]) << i << " repeats " << j;
    }
  }
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
