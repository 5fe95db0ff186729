#include "frontend/delaunay.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace ovo::frontend {
namespace {

__extension__ typedef __int128 Int128;

// Points on a 1/256 px integer grid, so that the orientation and in-circle predicates are exact
// (int64 and int128): the triangulation cannot break on the many collinear and cocircular feature
// positions of a pixel grid.
struct IPoint {
  std::int64_t x, y;
};

// > 0 when a, b, c turn counter-clockwise (in the algebraic x-y sense).
inline std::int64_t orient(const IPoint& a, const IPoint& b, const IPoint& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// True when d lies strictly inside the circumcircle of the counter-clockwise triangle a, b, c.
// Evaluated in double with Shewchuk's static error bound ("Adaptive Precision Floating-Point
// Arithmetic and Fast Robust Geometric Predicates", 1997; the inputs are exact integers), and in
// int128 when the sign is not certain.
inline bool inCircle(const IPoint& a, const IPoint& b, const IPoint& c, const IPoint& d) {
  const std::int64_t adx = a.x - d.x, ady = a.y - d.y;
  const std::int64_t bdx = b.x - d.x, bdy = b.y - d.y;
  const std::int64_t cdx = c.x - d.x, cdy = c.y - d.y;
  {
    const double ax = double(adx), ay = double(ady), bx = double(bdx), by = double(bdy);
    const double cx = double(cdx), cy = double(cdy);
    const double bxcy = bx * cy, cxby = cx * by, cxay = cx * ay, axcy = ax * cy;
    const double axby = ax * by, bxay = bx * ay;
    const double alift = ax * ax + ay * ay, blift = bx * bx + by * by, clift = cx * cx + cy * cy;
    const double det = alift * (bxcy - cxby) + blift * (cxay - axcy) + clift * (axby - bxay);
    const double permanent = (std::abs(bxcy) + std::abs(cxby)) * alift +
                             (std::abs(cxay) + std::abs(axcy)) * blift +
                             (std::abs(axby) + std::abs(bxay)) * clift;
    constexpr double kEps = std::numeric_limits<double>::epsilon() / 2.0;
    const double bound = (10.0 + 96.0 * kEps) * kEps * permanent;
    if (det > bound) return true;
    if (-det > bound) return false;
  }
  const Int128 alift = Int128(adx) * adx + Int128(ady) * ady;
  const Int128 blift = Int128(bdx) * bdx + Int128(bdy) * bdy;
  const Int128 clift = Int128(cdx) * cdx + Int128(cdy) * cdy;
  const Int128 det = alift * (Int128(bdx) * cdy - Int128(cdx) * bdy) +
                     blift * (Int128(cdx) * ady - Int128(adx) * cdy) +
                     clift * (Int128(adx) * bdy - Int128(bdx) * ady);
  return det > 0;
}

// Triangle with counter-clockwise vertices; nbr[k] is the triangle across the edge opposite
// vert[k] (-1: none).
struct Tri {
  int vert[3];
  int nbr[3];
  bool alive;
};

// Incremental Bowyer-Watson triangulation inside a large enclosing triangle (vertices 0..2),
// points inserted in a spatially coherent order and located by a visibility walk from the
// previous insertion (Lawson's walk terminates on a Delaunay triangulation).
class Triangulation {
 public:
  static constexpr int kNumSuper = 3;

  // Empties the triangulation (keeping its buffers) and starts from the enclosing triangle.
  void reset(std::size_t capacity, const IPoint& s0, const IPoint& s1, const IPoint& s2) {
    pts_.clear();
    tris_.clear();
    pts_.reserve(capacity + kNumSuper);
    tris_.reserve(2 * capacity + 8);
    pts_.push_back(s0);
    pts_.push_back(s1);
    pts_.push_back(s2);
    tris_.push_back({{0, 1, 2}, {-1, -1, -1}, true});
    last_ = 0;
  }

  // Inserts p; returns its vertex id, or the id of an existing vertex at the same position.
  int insert(const IPoint& p) {
    const int t0 = locate(p);
    for (const int v : tris_[t0].vert) {
      if (pts_[v].x == p.x && pts_[v].y == p.y) return v;
    }
    const int pv = static_cast<int>(pts_.size());
    pts_.push_back(p);
    // Cavity: triangles whose circumcircle strictly contains p, connected to t0.
    bad_.clear();
    stack_.clear();
    stack_.push_back(t0);
    tris_[t0].alive = false;
    while (!stack_.empty()) {
      const int t = stack_.back();
      stack_.pop_back();
      bad_.push_back(t);
      for (const int n : tris_[t].nbr) {
        if (n < 0 || !tris_[n].alive) continue;
        const Tri& tn = tris_[n];
        if (inCircle(pts_[tn.vert[0]], pts_[tn.vert[1]], pts_[tn.vert[2]], p)) {
          tris_[n].alive = false;
          stack_.push_back(n);
        }
      }
    }
    // Boundary edges (a, b), counter-clockwise as seen from inside the cavity, with the triangle
    // outside them; each becomes a new triangle (a, b, p).
    boundary_.clear();
    for (const int t : bad_) {
      for (int k = 0; k < 3; ++k) {
        const int n = tris_[t].nbr[k];
        if (n >= 0 && !tris_[n].alive) continue;
        boundary_.push_back({tris_[t].vert[(k + 1) % 3], tris_[t].vert[(k + 2) % 3], n, -1});
      }
    }
    // A cavity of m triangles has m + 2 boundary edges: reuse the m slots, append two.
    std::size_t reuse = 0;
    for (Edge& e : boundary_) {
      int t;
      if (reuse < bad_.size()) {
        t = bad_[reuse++];
      } else {
        t = static_cast<int>(tris_.size());
        tris_.push_back({});
      }
      e.tri = t;
      tris_[t] = {{e.a, e.b, pv}, {-1, -1, e.outside}, true};
      if (e.outside >= 0) {
        Tri& o = tris_[e.outside];
        for (int k = 0; k < 3; ++k) {
          if (o.vert[k] != e.a && o.vert[k] != e.b) o.nbr[k] = t;
        }
      }
    }
    // New triangles (a, b, p) and (b, c, p) share the edge (b, p); the cavity boundary is a simple
    // polygon, so each vertex starts exactly one boundary edge.
    if (tri_from_vertex_.size() < pts_.size()) tri_from_vertex_.resize(2 * pts_.size());
    for (const Edge& e : boundary_) tri_from_vertex_[e.a] = e.tri;
    for (const Edge& e : boundary_) {
      const int next = tri_from_vertex_[e.b];
      tris_[e.tri].nbr[0] = next;  // across (b, p), opposite a
      tris_[next].nbr[1] = e.tri;  // across (p, b) of (b, c, p), opposite its b
    }
    last_ = boundary_.front().tri;
    return pv;
  }

  const std::vector<Tri>& triangles() const { return tris_; }

 private:
  struct Edge {
    int a, b, outside, tri;
  };

  int locate(const IPoint& p) {
    int t = last_;
    if (!tris_[t].alive) t = firstAlive();
    const std::size_t max_steps = tris_.size() + 8;
    for (std::size_t step = 0; step < max_steps; ++step) {
      const Tri& tri = tris_[t];
      int next = -1;
      for (int k = 0; k < 3; ++k) {
        if (orient(pts_[tri.vert[(k + 1) % 3]], pts_[tri.vert[(k + 2) % 3]], p) < 0) {
          next = tri.nbr[k];
          break;
        }
      }
      if (next < 0) return t;
      t = next;
    }
    // Unreachable on a valid triangulation; a linear scan keeps the result correct regardless.
    for (int k = 0; k < static_cast<int>(tris_.size()); ++k) {
      const Tri& tri = tris_[k];
      if (tri.alive && orient(pts_[tri.vert[0]], pts_[tri.vert[1]], p) >= 0 &&
          orient(pts_[tri.vert[1]], pts_[tri.vert[2]], p) >= 0 &&
          orient(pts_[tri.vert[2]], pts_[tri.vert[0]], p) >= 0) {
        return k;
      }
    }
    return t;
  }

  int firstAlive() const {
    for (int k = 0; k < static_cast<int>(tris_.size()); ++k) {
      if (tris_[k].alive) return k;
    }
    return 0;
  }

  std::vector<IPoint> pts_;
  std::vector<Tri> tris_;
  std::vector<int> bad_, stack_, tri_from_vertex_;
  std::vector<Edge> boundary_;
  int last_ = 0;
};

// Buffers of one triangulation and its support count, reused from call to call (the frontend calls
// the filter twice per frame; fresh allocations of this size cost page faults every time).
struct Workspace {
  Triangulation tri;
  std::vector<std::pair<std::int64_t, int>> keyed;
  std::vector<IPoint> ipts;
  std::vector<int> vertex_point;  // input index of vertex v (lowest among repeats; -1: enclosing)
  std::vector<Vec2> vertex_flow;
  std::vector<int> vertex_support;
  std::vector<std::uint8_t> real;
};
thread_local Workspace t_workspace;

// Triangulates `points` into ws->tri and ws->vertex_point.
void triangulate(const std::vector<Vec2>& points, Workspace* ws) {
  double u_min = std::numeric_limits<double>::max(), v_min = u_min;
  double u_max = -u_min, v_max = -u_min;
  for (const Vec2& p : points) {
    u_min = std::min(u_min, p.x());
    u_max = std::max(u_max, p.x());
    v_min = std::min(v_min, p.y());
    v_max = std::max(v_max, p.y());
  }
  const double extent = std::max({u_max - u_min, v_max - v_min, 1.0});
  // 1/256 px, coarser for extents over 4096 px so that the enclosing triangle stays below 2^27.
  const double scale = std::min(256.0, double(1 << 20) / extent);
  const auto range = static_cast<std::int64_t>(std::ceil(extent * scale)) + 1;
  const std::int64_t k = 16 * range + 16;
  ws->tri.reset(points.size(), {-k, -k}, {3 * k, -k}, {-k, 3 * k});
  // Insert along a serpentine over 32 px strips: consecutive points are neighbours, so each walk
  // is a few steps.
  constexpr double kStripPx = 32.0;
  ws->keyed.resize(points.size());
  ws->ipts.resize(points.size());
  for (int i = 0; i < static_cast<int>(points.size()); ++i) {
    ws->ipts[i] = {std::llround((points[i].x() - u_min) * scale),
                   std::llround((points[i].y() - v_min) * scale)};
    const auto strip = static_cast<std::int64_t>((points[i].y() - v_min) / kStripPx);
    const std::int64_t u = ws->ipts[i].x;
    ws->keyed[i] = {(strip << 32) + ((strip & 1) ? (std::int64_t{1} << 31) - u : u), i};
  }
  std::sort(ws->keyed.begin(), ws->keyed.end());
  ws->vertex_point.assign(points.size() + Triangulation::kNumSuper, -1);
  for (const auto& [key, i] : ws->keyed) {
    int& owner = ws->vertex_point[ws->tri.insert(ws->ipts[i])];
    if (owner < 0 || i < owner) owner = i;
  }
}

bool isReal(const Tri& t) {
  return t.alive && t.vert[0] >= Triangulation::kNumSuper &&
         t.vert[1] >= Triangulation::kNumSuper && t.vert[2] >= Triangulation::kNumSuper;
}

}  // namespace

std::vector<std::array<int, 3>> delaunayTriangles(const std::vector<Vec2>& points) {
  std::vector<std::array<int, 3>> triangles;
  if (points.size() < 3) return triangles;
  Workspace& ws = t_workspace;
  triangulate(points, &ws);
  for (const Tri& t : ws.tri.triangles()) {
    if (!isReal(t)) continue;
    triangles.push_back(
        {ws.vertex_point[t.vert[0]], ws.vertex_point[t.vert[1]], ws.vertex_point[t.vert[2]]});
  }
  return triangles;
}

std::vector<std::uint8_t> delaunaySupportFilter(const std::vector<Vec2>& px_cur,
                                                const std::vector<Vec2>& flow, double flow_tol_px,
                                                int min_support) {
  std::vector<std::uint8_t> keep;
  delaunaySupportFilter(px_cur, flow, flow_tol_px, min_support, &keep);
  return keep;
}

void delaunaySupportFilter(const std::vector<Vec2>& px_cur, const std::vector<Vec2>& flow,
                           double flow_tol_px, int min_support, std::vector<std::uint8_t>* keep) {
  const int n = static_cast<int>(px_cur.size());
  keep->assign(n, min_support <= 0 ? 1 : 0);
  if (n < 3) return;
  Workspace& ws = t_workspace;
  const double tol2 = flow_tol_px * flow_tol_px;
  triangulate(px_cur, &ws);
  const std::vector<Tri>& tris = ws.tri.triangles();
  // Flows and supports by vertex (insertion order, spatially coherent like the triangles).
  const int num_vertices = static_cast<int>(ws.vertex_point.size());
  ws.vertex_flow.assign(num_vertices, Vec2::Zero());
  ws.vertex_support.assign(num_vertices, 0);
  for (int v = Triangulation::kNumSuper; v < num_vertices; ++v) {
    if (ws.vertex_point[v] >= 0) ws.vertex_flow[v] = flow[ws.vertex_point[v]];
  }
  ws.real.resize(tris.size());
  for (std::size_t t = 0; t < tris.size(); ++t) ws.real[t] = isReal(tris[t]);
  // Each edge of a real triangle once: from the lower-numbered of its two real triangles.
  for (int t = 0; t < static_cast<int>(tris.size()); ++t) {
    if (!ws.real[t]) continue;
    const Tri& tr = tris[t];
    for (int k = 0; k < 3; ++k) {
      const int other = tr.nbr[k];
      if (other >= 0 && other < t && ws.real[other]) continue;
      const int a = tr.vert[k == 2 ? 0 : k + 1], b = tr.vert[k == 0 ? 2 : k - 1];
      const int pass = (ws.vertex_flow[a] - ws.vertex_flow[b]).squaredNorm() < tol2;
      ws.vertex_support[a] += pass;
      ws.vertex_support[b] += pass;
    }
  }
  for (int v = Triangulation::kNumSuper; v < num_vertices; ++v) {
    const int i = ws.vertex_point[v];
    if (i >= 0) (*keep)[i] = ws.vertex_support[v] >= min_support ? 1 : 0;
  }
}

}  // namespace ovo::frontend
