#include "frontend/delaunay.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/imgproc.hpp>

namespace ovo::frontend {
namespace {

// Subdiv2D keeps its quad-edge list protected; this exposes the count needed to visit every edge.
class IndexedSubdiv : public cv::Subdiv2D {
 public:
  using cv::Subdiv2D::Subdiv2D;
  int numEdges() const { return static_cast<int>(qedges.size()) * 4; }
  bool edgeFree(int edge) const { return qedges[edge >> 2].isfree(); }
};

constexpr int kFirstRealVertex = 4;  // Subdiv2D: vertex 0 is a dummy, 1..3 the outer triangle

}  // namespace

std::vector<std::array<int, 3>> delaunayTriangles(const std::vector<Vec2>& points) {
  std::vector<std::array<int, 3>> triangles;
  if (points.size() < 3) return triangles;
  double u_min = std::numeric_limits<double>::max(), v_min = u_min;
  double u_max = -u_min, v_max = -u_min;
  for (const Vec2& p : points) {
    u_min = std::min(u_min, p.x());
    u_max = std::max(u_max, p.x());
    v_min = std::min(v_min, p.y());
    v_max = std::max(v_max, p.y());
  }
  // Work in coordinates relative to the bounding box to keep float precision.
  const cv::Rect rect(0, 0, static_cast<int>(u_max - u_min) + 3,
                      static_cast<int>(v_max - v_min) + 3);
  IndexedSubdiv subdiv(rect);
  std::vector<int> point_of_vertex;
  point_of_vertex.reserve(points.size() + kFirstRealVertex);
  // Insert in a serpentine order over 32 px strips: Subdiv2D locates each new point by walking
  // from the previous one, so spatially close consecutive points keep the walks short.
  constexpr double kStripPx = 32.0;
  std::vector<std::pair<std::int64_t, int>> keyed(points.size());
  for (int i = 0; i < static_cast<int>(points.size()); ++i) {
    const auto strip = static_cast<std::int64_t>((points[i].y() - v_min) / kStripPx);
    const auto u = static_cast<std::int64_t>(std::lround((points[i].x() - u_min) * 16.0));
    keyed[i] = {(strip << 32) + ((strip & 1) ? (std::int64_t{1} << 31) - u : u), i};
  }
  std::sort(keyed.begin(), keyed.end());
  for (const auto& [key, i] : keyed) {
    const cv::Point2f p(static_cast<float>(points[i].x() - u_min + 1.0),
                        static_cast<float>(points[i].y() - v_min + 1.0));
    const int vertex = subdiv.insert(p);
    if (vertex >= static_cast<int>(point_of_vertex.size())) point_of_vertex.resize(vertex + 1, -1);
    if (point_of_vertex[vertex] < 0 || i < point_of_vertex[vertex]) point_of_vertex[vertex] = i;
  }
  // A face left of a primal directed edge e is a triangle when lnext^3(e) = e; each triangle is
  // reported from the edge whose origin has the smallest vertex id.
  const int num_edges = subdiv.numEdges();
  for (int e = 0; e < num_edges; e += 2) {  // rotations 0 and 2: primal edges, both directions
    if (subdiv.edgeFree(e)) continue;
    const int e1 = subdiv.getEdge(e, cv::Subdiv2D::NEXT_AROUND_LEFT);
    const int e2 = subdiv.getEdge(e1, cv::Subdiv2D::NEXT_AROUND_LEFT);
    if (subdiv.getEdge(e2, cv::Subdiv2D::NEXT_AROUND_LEFT) != e) continue;
    const int a = subdiv.edgeOrg(e), b = subdiv.edgeOrg(e1), c = subdiv.edgeOrg(e2);
    if (a < kFirstRealVertex || b < kFirstRealVertex || c < kFirstRealVertex) continue;
    if (a > b || a > c) continue;
    triangles.push_back({point_of_vertex[a], point_of_vertex[b], point_of_vertex[c]});
  }
  return triangles;
}

std::vector<std::uint8_t> delaunaySupportFilter(const std::vector<Vec2>& px_cur,
                                                const std::vector<Vec2>& flow, double flow_tol_px,
                                                int min_support) {
  const int n = static_cast<int>(px_cur.size());
  std::vector<int> support(n, 0);
  const double tol2 = flow_tol_px * flow_tol_px;
  std::vector<std::pair<int, int>> edges;
  for (const auto& t : delaunayTriangles(px_cur)) {
    for (int k = 0; k < 3; ++k) {
      const int i = t[k], j = t[(k + 1) % 3];
      edges.emplace_back(std::min(i, j), std::max(i, j));
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  for (const auto& [i, j] : edges) {
    if ((flow[i] - flow[j]).squaredNorm() < tol2) {
      ++support[i];
      ++support[j];
    }
  }
  std::vector<std::uint8_t> keep(n);
  for (int i = 0; i < n; ++i) keep[i] = support[i] >= min_support ? 1 : 0;
  return keep;
}

}  // namespace ovo::frontend
