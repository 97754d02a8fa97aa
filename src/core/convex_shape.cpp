/// \file
/// ConvexShape: validated factories and the full-shape support mapping (core + radius).
#include "collision_monitor/core/convex_shape.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <sstream>
#include <type_traits>
#include <utility>
#include <variant>

#include "collision_monitor/core/convex_hull.h"

namespace collision_monitor {
namespace core {

namespace {

/// ConvexShape::coreId() of the next shape constructed (from 1: 0 is a cold PairCache's).
std::uint64_t nextCoreId() {
  static std::atomic<std::uint64_t> next{1};
  return next.fetch_add(1, std::memory_order_relaxed);
}

[[noreturn]] void fail(const std::string& shape, const std::string& what, double value,
                       const std::string& requirement) {
  std::ostringstream msg;
  msg.precision(17);
  msg << "ConvexShape::" << shape << ": " << what << " = " << value << " must be " << requirement;
  throw std::invalid_argument(msg.str());
}

/// Sizes: finite and >= 0 (0 is a valid degenerate shape).
void checkSize(const std::string& shape, const std::string& what, double value) {
  if (!std::isfinite(value) || value < 0.0) fail(shape, what, value, "finite and >= 0");
}

/// Coordinates: finite.
void checkPoint(const std::string& shape, const std::string& what, const Vec3& p) {
  static const char* const kAxis[3] = {".x", ".y", ".z"};
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(p[i])) fail(shape, what + kAxis[i], p[i], "finite");
}

/// Support of a core in its own frame (the one place the variant is switched on per call; GJK
/// visits the variant once per query instead, see query.cpp).
Vec3 coreSupportOf(const ConvexShape::Core& core, const Vec3& d) {
  return std::visit(
      [&d](const auto& c) -> Vec3 {
        using T = std::decay_t<decltype(c)>;
        if constexpr (std::is_same_v<T, std::shared_ptr<const Polytope<3>>>) {
          return c->support(d);
        } else {
          return c.support(d);
        }
      },
      core);
}

/// p plus the radius `r` along d (the full shape's support from its core's): unchanged for d = 0.
Vec3 withRadius(Vec3 p, const Vec3& d, double r) {
  const double n = d.norm();
  if (n > 0.0 && r > 0.0) p += (r / n) * d;
  return p;
}

/// ConvexShape::offset() of a finite point set: the centre of its bounding box along the axes
/// where that lies further out than four half-extents, when the centre lies further out than four
/// half-diagonals; else zero. On those axes every coordinate is within 1/4 of the centre's, so
/// subtracting the centre is exact (Sterbenz). Halves first: lo + hi may overflow.
Vec3 coordinatesOffset(const std::vector<Vec3>& pts) {
  Aabb box;
  for (const Vec3& p : pts)
    box.extend(p);
  const Vec3 mid = 0.5 * box.min + 0.5 * box.max;
  const Vec3 half = 0.5 * box.max - 0.5 * box.min;
  Vec3 offset = Vec3::Zero();
  if (!(mid.stableNorm() > 4.0 * half.stableNorm())) return offset;
  for (int k = 0; k < 3; ++k)
    if (std::abs(mid[k]) > 4.0 * half[k]) offset[k] = mid[k];
  return offset;
}

std::vector<Vec3> shifted(std::vector<Vec3> pts, const Vec3& offset) {
  for (Vec3& p : pts)
    p -= offset;
  return pts;
}

/// Radius of a ball about `centre` that contains the core. stableNorm(): a plain norm of a
/// 1e-277 m box is 0 (its square underflows), and the radius sets the query's scale (query.cpp:
/// tiny pairs run scaled; fuzz/regressions/core/flat-box-1.4e-277-holds-point).
double coreRadius(const ConvexShape::Core& core, const Vec3& centre) {
  return std::visit(
      [&centre](const auto& c) -> double {
        using T = std::decay_t<decltype(c)>;
        if constexpr (std::is_same_v<T, PointShape<3>>) {
          return (c.p - centre).stableNorm();
        } else if constexpr (std::is_same_v<T, SegmentShape<3>>) {
          return std::max((c.a - centre).stableNorm(), (c.b - centre).stableNorm());
        } else if constexpr (std::is_same_v<T, BoxShape<3>>) {
          return c.half.stableNorm() + centre.stableNorm();
        } else if constexpr (std::is_same_v<T, CylinderShape> || std::is_same_v<T, ConeShape>) {
          return std::hypot(c.half_height, c.radius) + centre.stableNorm();
        } else if constexpr (std::is_same_v<T, EllipsoidShape<3>>) {
          return c.semi.maxCoeff() + centre.stableNorm();
        } else {
          double m = 0.0;
          for (const Vec3& v : c->vertices())
            m = std::max(m, (v - centre).stableNorm());
          return m;
        }
      },
      core);
}

}  // namespace

ConvexShape::ConvexShape(Core core, double radius, std::string kind, const Vec3& offset)
    : core_(std::move(core)),
      offset_(offset),
      has_offset_(!offset.isZero(0.0)),
      radius_(radius),
      core_id_(nextCoreId()),
      kind_(std::move(kind)) {
  local_radius_ = coreRadius(core_, Vec3::Zero()) + radius_;
  // About the frame origin: the core's points are offset() away from where the core has them.
  bounding_radius_ = has_offset_ ? coreRadius(core_, -offset_) + radius_ : local_radius_;
}

ConvexShape ConvexShape::sphere(double radius) {
  checkSize("sphere", "radius", radius);
  return ConvexShape(PointShape<3>{}, radius, "sphere");
}

ConvexShape ConvexShape::box(const Vec3& sides) {
  static const char* const kSide[3] = {"sides.x", "sides.y", "sides.z"};
  for (int i = 0; i < 3; ++i)
    checkSize("box", kSide[i], sides[i]);
  BoxShape<3> b;
  b.half = 0.5 * sides;
  return ConvexShape(b, 0.0, "box");
}

ConvexShape ConvexShape::capsule(double length, double radius) {
  checkSize("capsule", "length", length);
  checkSize("capsule", "radius", radius);
  SegmentShape<3> s;
  s.a = Vec3(0.0, 0.0, -0.5 * length);
  s.b = Vec3(0.0, 0.0, 0.5 * length);
  return ConvexShape(s, radius, "capsule");
}

ConvexShape ConvexShape::cylinder(double height, double radius) {
  checkSize("cylinder", "height", height);
  checkSize("cylinder", "radius", radius);
  return ConvexShape(CylinderShape{0.5 * height, radius}, 0.0, "cylinder");
}

ConvexShape ConvexShape::cone(double height, double radius) {
  checkSize("cone", "height", height);
  checkSize("cone", "radius", radius);
  return ConvexShape(ConeShape{0.5 * height, radius}, 0.0, "cone");
}

ConvexShape ConvexShape::ellipsoid(const Vec3& semi_axes) {
  static const char* const kAxis[3] = {"semi_axes.x", "semi_axes.y", "semi_axes.z"};
  for (int i = 0; i < 3; ++i)
    checkSize("ellipsoid", kAxis[i], semi_axes[i]);
  EllipsoidShape<3> e;
  e.semi = semi_axes;
  return ConvexShape(e, 0.0, "ellipsoid");
}

ConvexShape ConvexShape::point(const Vec3& p) {
  checkPoint("point", "p", p);
  const Vec3 offset = coordinatesOffset({p});
  PointShape<3> s;
  s.p = p - offset;
  return ConvexShape(s, 0.0, "point", offset);
}

ConvexShape ConvexShape::segment(const Vec3& a, const Vec3& b) {
  checkPoint("segment", "a", a);
  checkPoint("segment", "b", b);
  const Vec3 offset = coordinatesOffset({a, b});
  SegmentShape<3> s;
  s.a = a - offset;
  s.b = b - offset;
  return ConvexShape(s, 0.0, "segment", offset);
}

ConvexShape ConvexShape::convexHull(const std::vector<Vec3>& points) {
  if (points.empty()) throw std::invalid_argument("ConvexShape::convexHull: no points");
  for (std::size_t i = 0; i < points.size(); ++i)
    checkPoint("convexHull", "points[" + std::to_string(i) + "]", points[i]);
  // Hulled about the offset: the same points (exact), and qhull sees them about their centre.
  const Vec3 offset = coordinatesOffset(points);
  return polytopeAt(buildConvexHull(offset.isZero(0.0) ? points : shifted(points, offset)), offset);
}

namespace {

/// A polytope's adjacency (Polytope's constructor): none, or offsets from 0 to the neighbour
/// count, non-decreasing, one per vertex and one more, neighbours in range and not the vertex
/// itself; and, where support hill-climbs (usesLinearScan() false), an edge graph it can climb:
/// from vertex 0 along each of 96 directions (cube-map cell centres, 4 x 4 per face) it ends at a
/// vertex as far along as the farthest (1e-12 of the size). Hill-climbing needs the hull's edge
/// graph: with less (empty lists) it stops short and every query is silently wrong.
void checkAdjacency(const Polytope<3>& p) {
  const auto bad = [](const std::string& why) {
    throw std::invalid_argument("ConvexShape::polytope: adjacency " + why);
  };
  const std::vector<int>& off = p.adjacencyOffsets();
  const std::vector<int>& adj = p.adjacency();
  const int n = p.size();
  if (off.empty()) {
    if (!adj.empty()) bad("has neighbours but no offsets");
    return;
  }
  if (static_cast<int>(off.size()) != n + 1)
    bad("offsets: " + std::to_string(off.size()) + " for " + std::to_string(n) +
        " vertices (must be one per vertex and one more)");
  if (off[0] != 0 || off[n] != static_cast<int>(adj.size()))
    bad("offsets must run from 0 to the neighbour count (" + std::to_string(adj.size()) + ")");
  for (int i = 0; i < n; ++i) {
    if (off[i + 1] < off[i]) bad("offsets decrease at vertex " + std::to_string(i));
  }
  for (int i = 0; i < n; ++i) {
    for (int k = off[i]; k < off[i + 1]; ++k) {
      if (adj[k] < 0 || adj[k] >= n || adj[k] == i)
        bad("of vertex " + std::to_string(i) + ": neighbour " + std::to_string(adj[k]) +
            " is not another vertex (0 to " + std::to_string(n - 1) + ")");
    }
  }
  if (p.usesLinearScan()) return;
  const std::vector<Vec3>& v = p.vertices();
  double size = 0.0;
  for (const Vec3& x : v)
    size = std::max(size, x.cwiseAbs().maxCoeff());
  constexpr int kGrid = 4;
  for (int face = 0; face < 6; ++face) {
    for (int a = 0; a < kGrid; ++a) {
      for (int b = 0; b < kGrid; ++b) {
        Vec3 d;
        d[face / 2] = face % 2 == 0 ? 1.0 : -1.0;
        d[(face / 2 + 1) % 3] = (2.0 * a + 1.0) / kGrid - 1.0;
        d[(face / 2 + 2) % 3] = (2.0 * b + 1.0) / kGrid - 1.0;
        int cur = 0;  // steepest ascent, as Polytope::supportIndex() climbs
        for (bool moved = true; moved;) {
          moved = false;
          int next = cur;
          for (int k = off[cur]; k < off[cur + 1]; ++k) {
            if (v[adj[k]].dot(d) > v[next].dot(d)) next = adj[k];
          }
          if (next != cur) {
            cur = next;
            moved = true;
          }
        }
        const int best = p.scanIndex(d);
        if (v[cur].dot(d) < v[best].dot(d) - 1e-12 * size * d.norm())
          bad("is not the hull's edge graph: climbing along (" + std::to_string(d.x()) + ", " +
              std::to_string(d.y()) + ", " + std::to_string(d.z()) + ") from vertex 0 stops at " +
              std::to_string(cur) + ", short of vertex " + std::to_string(best));
      }
    }
  }
}

}  // namespace

ConvexShape ConvexShape::polytope(std::shared_ptr<const Polytope<3>> poly) {
  if (!poly) throw std::invalid_argument("ConvexShape::polytope: null polytope");
  if (poly->size() == 0) throw std::invalid_argument("ConvexShape::polytope: no vertices");
  for (int i = 0; i < poly->size(); ++i)
    checkPoint("polytope", "vertices[" + std::to_string(i) + "]", poly->vertices()[i]);
  checkAdjacency(*poly);
  const Vec3 offset = coordinatesOffset(poly->vertices());
  if (offset.isZero(0.0)) return polytopeAt(std::move(poly), offset);
  return polytopeAt(
      std::make_shared<const Polytope<3>>(shifted(poly->vertices(), offset),
                                          poly->adjacencyOffsets(), poly->adjacency()),
      offset);
}

ConvexShape ConvexShape::polytopeAt(std::shared_ptr<const Polytope<3>> poly, const Vec3& offset) {
  const int n = poly->size();
  return ConvexShape(std::move(poly), 0.0, "polytope(" + std::to_string(n) + ")", offset);
}

ConvexShape ConvexShape::padded(double padding) const {
  checkSize("padded", "padding", padding);
  ConvexShape out = *this;
  out.radius_ += padding;
  out.bounding_radius_ += padding;
  out.local_radius_ += padding;
  // 1e308 m of padding on a 1e308 m shape: an infinite size, with which every query fails.
  if (!std::isfinite(out.bounding_radius_))
    fail("padded", "padding", padding, "small enough that the padded shape's size is finite");
  return out;
}

Vec3 ConvexShape::coreSupport(const Vec3& d) const {
  return coreSupportOf(core_, d) + offset_;
}

Vec3 ConvexShape::support(const Vec3& d) const {
  return withRadius(coreSupport(d), d, radius_);
}

Vec3 ConvexShape::localSupport(const Vec3& d, bool core_only) const {
  const Vec3 p = coreSupportOf(core_, d);
  return core_only ? p : withRadius(p, d, radius_);
}

Aabb ConvexShape::aabb(const Transform3& pose) const {
  // Extent along world axis e_i: e_i . (R s(R^T e_i) + t), s the full shape's support.
  Aabb box;
  for (int i = 0; i < 3; ++i) {
    const Vec3 dir = pose.R.row(i).transpose();  // R^T e_i
    box.max[i] = pose.R.row(i).dot(support(dir)) + pose.t[i];
    box.min[i] = pose.R.row(i).dot(support(-dir)) + pose.t[i];
  }
  return box;
}

std::string ConvexShape::describe() const {
  return kind_;
}

}  // namespace core
}  // namespace collision_monitor
