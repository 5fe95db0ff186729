// Delaunay triangulation of image points (incremental Lawson flips in BRIO order, exact integer
// predicates) and libviso2's flow-consistency outlier filter built on it (DESIGN section 4).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "common/types.hpp"

namespace ovo::frontend {

/// Triangles (indices into `points`) of the Delaunay triangulation. Repeated points take part once
/// (the first occurrence). Fewer than three distinct points: no triangles. Where the triangulation
/// is not unique (four or more cocircular points) the choice is deterministic but arbitrary.
std::vector<std::array<int, 3>> delaunayTriangles(const std::vector<Vec2>& points);

/// Flow-consistency filter: triangulate the points px_cur; every Delaunay edge (i, j) with
/// ||flow_i - flow_j|| < flow_tol_px supports both ends (once, however many triangles share it).
/// Returns keep flags: support >= min_support.
std::vector<std::uint8_t> delaunaySupportFilter(const std::vector<Vec2>& px_cur,
                                                const std::vector<Vec2>& flow, double flow_tol_px,
                                                int min_support);
/// The same into *keep (reuses its buffer; the triangulation's buffers are reused per thread).
void delaunaySupportFilter(const std::vector<Vec2>& px_cur, const std::vector<Vec2>& flow,
                           double flow_tol_px, int min_support, std::vector<std::uint8_t>* keep);

}  // namespace ovo::frontend
