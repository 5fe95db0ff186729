#include "frontend/delaunay.hpp"

#include <algorithm>
#include <bit>
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
  std::int32_t x, y;
};

// > 0 when a, b, c turn counter-clockwise (in the algebraic x-y sense).
inline std::int64_t orient(const IPoint& a, const IPoint& b, const IPoint& c) {
  return std::int64_t{b.x - a.x} * (c.y - a.y) - std::int64_t{b.y - a.y} * (c.x - a.x);
}

// True when d lies strictly inside the circumcircle of the counter-clockwise triangle a, b, c.
// Evaluated in double with Shewchuk's static error bound ("Adaptive Precision Floating-Point
// Arithmetic and Fast Robust Geometric Predicates", 1997; the inputs are exact integers), and in
// int128 when the sign is not certain.
inline bool inCircle(const IPoint& a, const IPoint& b, const IPoint& c, const IPoint& d) {
  const std::int64_t adx = std::int64_t{a.x} - d.x, ady = std::int64_t{a.y} - d.y;
  const std::int64_t bdx = std::int64_t{b.x} - d.x, bdy = std::int64_t{b.y} - d.y;
  const std::int64_t cdx = std::int64_t{c.x} - d.x, cdy = std::int64_t{c.y} - d.y;
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

inline int nextEdge(int e) { return e % 3 == 2 ? e - 2 : e + 1; }
inline int prevEdge(int e) { return e % 3 == 0 ? e + 2 : e - 1; }

// Incremental Delaunay triangulation by Lawson flips (Lawson 1977; Guibas & Stolfi 1985) inside a
// large enclosing triangle (vertices 0..2), on flat half-edge arrays: half-edge 3t + k of triangle
// t runs from corner k to corner k + 1 (counter-clockwise), twin_ is the opposite half-edge (-1 on
// the enclosing triangle). Points are inserted in a spatially coherent order and located by a
// visibility walk from the previous insertion (it terminates on a Delaunay triangulation).
class Triangulation {
 public:
  static constexpr int kNumSuper = 3;

  // Empties the triangulation (keeping its buffers) and starts from the enclosing triangle.
  void reset(std::size_t capacity, const IPoint& s0, const IPoint& s1, const IPoint& s2) {
    pts_.clear();
    pts_.reserve(capacity + kNumSuper);
    pts_.push_back(s0);
    pts_.push_back(s1);
    pts_.push_back(s2);
    const std::size_t max_edges = 3 * (2 * capacity + 1);
    if (vert_.size() < max_edges) {
      vert_.resize(max_edges);
      twin_.resize(max_edges);
    }
    vert_[0] = 0;
    vert_[1] = 1;
    vert_[2] = 2;
    twin_[0] = twin_[1] = twin_[2] = -1;
    num_tris_ = 1;
    last_ = 0;
  }

  // Inserts p; returns its vertex id, or the id of an existing vertex at the same position.
  int insert(const IPoint& p) {
    int on_edge = -1;
    const int t = locate(p, &on_edge);
    for (int k = 0; k < 3; ++k) {
      const IPoint& v = pts_[vert_[3 * t + k]];
      if (v.x == p.x && v.y == p.y) return vert_[3 * t + k];
    }
    const int pv = static_cast<int>(pts_.size());
    pts_.push_back(p);
    if (on_edge < 0) {
      splitTriangle(t, pv);
    } else {
      splitEdge(on_edge, pv);
    }
    last_ = t;
    return pv;
  }

  int numTriangles() const { return num_tris_; }
  // Vertex at corner k of triangle t; twin of half-edge e (-1: none).
  int vertex(int t, int k) const { return vert_[3 * t + k]; }
  int twin(int e) const { return twin_[e]; }

 private:
  void link(int e, int f) {
    twin_[e] = f;
    if (f >= 0) twin_[f] = e;
  }

  // New triangle (a, b, c); returns its id.
  int setTriangle(int t, int a, int b, int c) {
    vert_[3 * t] = a;
    vert_[3 * t + 1] = b;
    vert_[3 * t + 2] = c;
    return t;
  }

  // The closed fan of K triangles tris[i] = (ring[i], ring[i + 1], p) around p: edge 0 of each
  // faces outer[i] (the twin across the ring edge), edges 1 and 2 join neighbouring triangles,
  // and every ring edge is then legalised in order.
  template <int K>
  void fillFan(int p, const int (&tris)[K], const int (&ring)[K], const int (&outer)[K]) {
    for (int i = 0; i < K; ++i) setTriangle(tris[i], ring[i], ring[(i + 1) % K], p);
    for (int i = 0; i < K; ++i) {
      link(3 * tris[i], outer[i]);
      link(3 * tris[i] + 1, 3 * tris[(i + 1) % K] + 2);
    }
    for (int i = 0; i < K; ++i) legalize(3 * tris[i], p);
  }

  // p strictly inside triangle t = (a, b, c): (a, b, p), (b, c, p), (c, a, p).
  void splitTriangle(int t, int p) {
    const int a = vert_[3 * t], b = vert_[3 * t + 1], c = vert_[3 * t + 2];
    const int tw_ab = twin_[3 * t], tw_bc = twin_[3 * t + 1], tw_ca = twin_[3 * t + 2];
    const int t1 = num_tris_, t2 = num_tris_ + 1;
    num_tris_ += 2;
    fillFan(p, {t, t1, t2}, {a, b, c}, {tw_ab, tw_bc, tw_ca});
  }

  // p on the interior of half-edge e = (a, b) of triangle (a, b, c), whose twin's triangle is
  // (b, a, d): (b, c, p), (c, a, p), (a, d, p), (d, b, p).
  void splitEdge(int e, int p) {
    const int t = e / 3, o = twin_[e], ot = o / 3;
    const int a = vert_[e], b = vert_[nextEdge(e)], c = vert_[prevEdge(e)];
    const int d = vert_[prevEdge(o)];
    const int tw_bc = twin_[nextEdge(e)], tw_ca = twin_[prevEdge(e)];
    const int tw_ad = twin_[nextEdge(o)], tw_db = twin_[prevEdge(o)];
    const int t3 = num_tris_, t4 = num_tris_ + 1;
    num_tris_ += 2;
    fillFan(p, {t, ot, t3, t4}, {b, c, a, d}, {tw_bc, tw_ca, tw_ad, tw_db});
  }

  // Restores the Delaunay property around the new vertex p: e is the edge (a, b) opposite p of
  // triangle (a, b, p); if the vertex d across it lies inside the circle through a, b, p, the edge
  // flips to (p, d) and the two edges beyond are checked in turn.
  void legalize(int e0, int p) {
    stack_.clear();
    stack_.push_back(e0);
    while (!stack_.empty()) {
      const int e = stack_.back();
      stack_.pop_back();
      const int o = twin_[e];
      if (o < 0) continue;
      const int t = e / 3, ot = o / 3;
      const int a = vert_[e], b = vert_[3 * t + 1];
      const int d = vert_[prevEdge(o)];
      if (!inCircle(pts_[a], pts_[b], pts_[p], pts_[d])) continue;
      const int tw_ad = twin_[nextEdge(o)], tw_db = twin_[prevEdge(o)];
      const int tw_bp = twin_[3 * t + 1];
      // (a, b, p) + (b, a, d) -> (a, d, p) in t, (d, b, p) in ot.
      setTriangle(t, a, d, p);
      setTriangle(ot, d, b, p);
      link(3 * t, tw_ad);
      link(3 * ot, tw_db);
      link(3 * ot + 1, tw_bp);
      link(3 * t + 1, 3 * ot + 2);
      stack_.push_back(3 * ot);
      stack_.push_back(3 * t);
    }
  }

  // Triangle containing p (closed); *on_edge: the half-edge whose interior holds p, or -1.
  int locate(const IPoint& p, int* on_edge) {
    int t = last_;
    const int max_steps = num_tris_ + 8;
    for (int step = 0; step < max_steps; ++step) {
      const IPoint& a = pts_[vert_[3 * t]];
      const IPoint& b = pts_[vert_[3 * t + 1]];
      const IPoint& c = pts_[vert_[3 * t + 2]];
      const std::int64_t o0 = orient(a, b, p);
      if (o0 < 0) {
        t = twin_[3 * t] / 3;
        continue;
      }
      const std::int64_t o1 = orient(b, c, p);
      if (o1 < 0) {
        t = twin_[3 * t + 1] / 3;
        continue;
      }
      const std::int64_t o2 = orient(c, a, p);
      if (o2 < 0) {
        t = twin_[3 * t + 2] / 3;
        continue;
      }
      *on_edge = onEdge(t, o0, o1, o2);
      return t;
    }
    // Unreachable on a valid triangulation; a linear scan keeps the result correct regardless.
    for (int k = 0; k < num_tris_; ++k) {
      const IPoint& a = pts_[vert_[3 * k]];
      const IPoint& b = pts_[vert_[3 * k + 1]];
      const IPoint& c = pts_[vert_[3 * k + 2]];
      const std::int64_t o0 = orient(a, b, p), o1 = orient(b, c, p), o2 = orient(c, a, p);
      if (o0 >= 0 && o1 >= 0 && o2 >= 0) {
        *on_edge = onEdge(k, o0, o1, o2);
        return k;
      }
    }
    *on_edge = -1;
    return t;
  }

  // The half-edge of t with orientation 0 when exactly one is (two: p is a vertex).
  static int onEdge(int t, std::int64_t o0, std::int64_t o1, std::int64_t o2) {
    const int zeros = (o0 == 0) + (o1 == 0) + (o2 == 0);
    if (zeros != 1) return -1;
    return 3 * t + (o0 == 0 ? 0 : o1 == 0 ? 1 : 2);
  }

  std::vector<IPoint> pts_;
  std::vector<int> vert_, twin_, stack_;
  int num_tris_ = 0;
  int last_ = 0;
};

// Buffers of one triangulation and its support count, reused from call to call (the frontend calls
// the filter twice per frame; fresh allocations of this size cost page faults every time).
struct Workspace {
  Triangulation tri;
  std::vector<std::uint64_t> keyed, sort_buffer;  // insertion order key | input index
  std::vector<IPoint> ipts;
  std::vector<int> vertex_point;  // input index of vertex v (lowest among repeats; -1: enclosing)
  std::vector<Vec2> vertex_flow;
  std::vector<int> vertex_support;
  std::vector<std::uint8_t> real;
};
thread_local Workspace t_workspace;

// Sorts keys by their upper 32 bits, stably (LSD radix sort, 11 + 11 + 10 bits): the lower 32
// bits, ascending input indices, break ties as std::sort would.
void radixSortByHighBits(std::vector<std::uint64_t>* keys, std::vector<std::uint64_t>* buffer) {
  buffer->resize(keys->size());
  std::uint64_t* from = keys->data();
  std::uint64_t* to = buffer->data();
  const std::size_t n = keys->size();
  for (const int shift : {32, 43, 54}) {
    std::array<std::uint32_t, 2049> start{};
    for (std::size_t k = 0; k < n; ++k) ++start[((from[k] >> shift) & 2047) + 1];
    for (std::size_t b = 1; b < start.size(); ++b) start[b] += start[b - 1];
    for (std::size_t k = 0; k < n; ++k) to[start[(from[k] >> shift) & 2047]++] = from[k];
    std::swap(from, to);
  }
  // Three passes: the sorted keys are in *buffer.
  keys->swap(*buffer);
}

// BRIO round of input point i (0..6; 6 for half the points), from a hash of i: deterministic.
int insertionRound(int i) {
  std::uint64_t z = static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ull;  // splitmix64 finaliser
  z = (z ^ (z >> 31)) * 0xBF58476D1CE4E5B9ull;
  z ^= z >> 29;
  return 6 - std::min(6, std::countr_zero(z | (std::uint64_t{1} << 63)));
}

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
  // 1/256 px, coarser for extents over 4096 px so that the enclosing triangle stays below 2^26
  // (int32 coordinates and differences).
  const double scale = std::min(256.0, double(1 << 20) / extent);
  const auto range = static_cast<std::int64_t>(std::ceil(extent * scale)) + 1;
  const auto k = static_cast<std::int32_t>(16 * range + 16);
  ws->tri.reset(points.size(), {-k, -k}, {3 * k, -k}, {-k, 3 * k});
  // Insertion order: biased randomised rounds (Amenta, Choi & Rote, "Incremental constructions
  // con BRIO", 2003): a point joins the last round with probability 1/2, the one before with 1/4,
  // ..., so that most points land inside an already triangulated area (about three flips each);
  // within a round a serpentine over strips keeps consecutive points neighbours (short walks).
  // Key: round (3 bits), strip (7 bits), position along the strip (21 bits), input index.
  const double strip_px = std::max(32.0, extent / 100.0);
  ws->keyed.resize(points.size());
  ws->ipts.resize(points.size());
  for (int i = 0; i < static_cast<int>(points.size()); ++i) {
    // Round half up (the offsets are not negative).
    const IPoint q{static_cast<std::int32_t>((points[i].x() - u_min) * scale + 0.5),
                   static_cast<std::int32_t>((points[i].y() - v_min) * scale + 0.5)};
    ws->ipts[i] = q;
    const auto strip = static_cast<std::uint64_t>((points[i].y() - v_min) / strip_px);
    const std::uint64_t along = (strip & 1) ? (std::uint64_t{1} << 21) - 1 - q.x : q.x;
    ws->keyed[i] = (static_cast<std::uint64_t>(insertionRound(i)) << 60) | (strip << 53) |
                   (along << 32) | static_cast<std::uint32_t>(i);
  }
  radixSortByHighBits(&ws->keyed, &ws->sort_buffer);
  ws->vertex_point.assign(points.size() + Triangulation::kNumSuper, -1);
  for (const std::uint64_t key : ws->keyed) {
    const auto i = static_cast<int>(key & 0xffffffffu);
    int& owner = ws->vertex_point[ws->tri.insert(ws->ipts[i])];
    if (owner < 0 || i < owner) owner = i;
  }
}

bool isReal(const Triangulation& tri, int t) {
  return tri.vertex(t, 0) >= Triangulation::kNumSuper &&
         tri.vertex(t, 1) >= Triangulation::kNumSuper &&
         tri.vertex(t, 2) >= Triangulation::kNumSuper;
}

}  // namespace

std::vector<std::array<int, 3>> delaunayTriangles(const std::vector<Vec2>& points) {
  std::vector<std::array<int, 3>> triangles;
  if (points.size() < 3) return triangles;
  Workspace& ws = t_workspace;
  triangulate(points, &ws);
  const Triangulation& tri = ws.tri;
  for (int t = 0; t < tri.numTriangles(); ++t) {
    if (!isReal(tri, t)) continue;
    triangles.push_back({ws.vertex_point[tri.vertex(t, 0)], ws.vertex_point[tri.vertex(t, 1)],
                         ws.vertex_point[tri.vertex(t, 2)]});
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
  const Triangulation& tri = ws.tri;
  const int num_tris = tri.numTriangles();
  // Flows and supports by vertex (insertion order, spatially coherent like the triangles).
  const int num_vertices = static_cast<int>(ws.vertex_point.size());
  ws.vertex_flow.assign(num_vertices, Vec2::Zero());
  ws.vertex_support.assign(num_vertices, 0);
  for (int v = Triangulation::kNumSuper; v < num_vertices; ++v) {
    if (ws.vertex_point[v] >= 0) ws.vertex_flow[v] = flow[ws.vertex_point[v]];
  }
  ws.real.resize(num_tris);
  for (int t = 0; t < num_tris; ++t) ws.real[t] = isReal(tri, t);
  // Each edge of a real triangle once: from the lower-numbered of its two real triangles.
  for (int t = 0; t < num_tris; ++t) {
    if (!ws.real[t]) continue;
    for (int k = 0; k < 3; ++k) {
      const int o = tri.twin(3 * t + k);
      if (o >= 0 && o / 3 < t && ws.real[o / 3]) continue;
      const int a = tri.vertex(t, k), b = tri.vertex(t, k == 2 ? 0 : k + 1);
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
