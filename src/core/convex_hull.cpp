/// \file
/// Convex hulls with qhull's reentrant C API (libqhull_r): one qhT per call, so concurrent calls
/// are safe. qhull never prints: its error/warning stream is an in-memory FILE whose text ends up
/// in the exception message when qhull fails.
///
/// Degenerate input is classified before qhull sees it (qhull's 3D hull fails on flat input):
///   - extent along the widest axis <= noise floor               -> one vertex,
///   - max distance to the line through the two extreme points <= kFlatRel * extent -> segment,
///   - max distance to the plane through three spread points  <= kFlatRel * extent -> polygon
///     (projected into the plane, 2D hull by Andrew's monotone chain, adjacency = polygon cycle).
/// The vertices kept are always input points (never projected ones). A 3D set that passes the
/// flatness test but on which qhull still fails (e.g. thickness just above kFlatRel) is retried
/// with joggling ("QJ") and then treated as flat. A solid set thinner than kRoundRel of its extent
/// goes to qhull mapped round (Rounding): qhull can loop for ever on long thin sets.
#include "collision_monitor/core/convex_hull.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

extern "C" {
#include <libqhull_r/qhull_ra.h>
}

namespace collision_monitor {
namespace core {
namespace {

/// Thickness (relative to the largest extent) below which a point set is treated as lower
/// dimensional. Dropping that thickness changes distances by at most kFlatRel * extent, the
/// accuracy the exact-oracle sweeps ask of the whole core.
constexpr double kFlatRel = 1e-10;

void validate(const std::vector<Vec3>& points, const char* who) {
  if (points.empty()) {
    throw std::invalid_argument(std::string(who) + ": empty point set (need at least one point)");
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) {
      throw std::invalid_argument(std::string(who) + ": point " + std::to_string(i) +
                                  " has a non-finite coordinate (NaN or Inf)");
    }
  }
}

/// Dimension analysis of a point set (indices into the input).
struct Frame {
  int dim = 0;             ///< 0 point, 1 segment, 2 polygon, 3 solid (affine dimension)
  int a = 0;               ///< first extreme point along the widest axis
  int b = 0;               ///< second extreme point (dim >= 1)
  Vec3 u = Vec3::UnitX();  ///< unit direction a -> b
  Vec3 v = Vec3::UnitY();  ///< unit, in plane, orthogonal to u (dim >= 2)
  Vec3 n = Vec3::UnitZ();  ///< unit plane normal u x v (dim >= 2)
  double extent = 0.0;     ///< |b - a|
  double floor = 0.0;      ///< rounding floor of the coordinates (absolute)
  double h1 = 0.0;         ///< largest distance from the line (a, u) (dim >= 2)
  double h2 = 0.0;         ///< largest distance from the plane (a, n) (dim == 3)
};

Frame analyse(const std::vector<Vec3>& pts) {
  Frame f;
  const int count = static_cast<int>(pts.size());
  // Widest axis of the bounding box and its two extreme points.
  Vec3 lo = pts[0], hi = pts[0];
  std::array<int, 3> imin{0, 0, 0}, imax{0, 0, 0};
  double max_abs = 0.0;
  for (int i = 0; i < count; ++i) {
    for (int k = 0; k < 3; ++k) {
      if (pts[i][k] < lo[k]) lo[k] = pts[i][k], imin[k] = i;
      if (pts[i][k] > hi[k]) hi[k] = pts[i][k], imax[k] = i;
    }
    max_abs = std::max(max_abs, pts[i].cwiseAbs().maxCoeff());
  }
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  f.a = imin[axis];
  f.b = imax[axis];
  f.extent = (pts[f.b] - pts[f.a]).norm();
  // Rounding floor: coordinates of magnitude max_abs are only known to a few ulps.
  const double floor = 16.0 * std::numeric_limits<double>::epsilon() * max_abs;
  f.floor = floor;
  if (!(f.extent > floor)) {
    f.dim = 0;
    return f;
  }
  f.u = (pts[f.b] - pts[f.a]) / f.extent;
  const double flat = kFlatRel * f.extent + floor;
  // Farthest point from the line a-b.
  double h1 = -1.0;
  int c = f.a;
  for (int i = 0; i < count; ++i) {
    const Vec3 w = pts[i] - pts[f.a];
    const double h = (w - w.dot(f.u) * f.u).norm();
    if (h > h1) h1 = h, c = i;
  }
  f.h1 = h1;
  if (!(h1 > flat)) {
    f.dim = 1;
    return f;
  }
  const Vec3 w = pts[c] - pts[f.a];
  f.v = (w - w.dot(f.u) * f.u).normalized();
  f.n = f.u.cross(f.v).normalized();
  double h2 = 0.0;
  for (int i = 0; i < count; ++i)
    h2 = std::max(h2, std::abs(f.n.dot(pts[i] - pts[f.a])));
  f.h2 = h2;
  f.dim = h2 > flat ? 3 : 2;
  return f;
}

/// Thinner than this (the largest distance from analyse()'s plane over the extent), a solid set
/// goes to qhull mapped round (Rounding). qhull 2020.2 can loop for ever merging and
/// re-partitioning the facets of a long thin set: the 16 distinct vertex differences of a flat
/// 1.1 x 4.7 m plate and a flat 2.1 x 1e6 m plate tilted by 8e-9 rad (a slanted prism 1e6 m x
/// 3.2 m x 4.7 m, 6.7e5 m out) did not finish in minutes with "Qs", "Qt", "Qt Qs", "C-0" or
/// "Q12", nor as 64 points with duplicates; mapped round, 0.07 ms
/// (fuzz/regressions/core/hull-slanted-1e6m-prism-qhull-hang).
constexpr double kRoundRel = 1e-3;

/// The affine map x -> M (x - origin) qhull sees a thin solid set through: analyse()'s axes u, v,
/// n, each divided by the set's spread along it (extent, h1, h2), so the set is about a unit cube
/// across. An invertible affine map keeps the hull's combinatorics (which points are vertices,
/// which pairs edges), so the vertices and edges are read off the run as they are; a facet's
/// outward normal m in the mapped space is M^T m back here (not unit). The identity (not mapped)
/// for sets at least kRoundRel * extent thick.
struct Rounding {
  bool mapped = false;
  Vec3 origin = Vec3::Zero();
  Mat3 M = Mat3::Identity();
  const std::vector<Vec3>* input;
  std::vector<Vec3> mapped_points;

  Rounding(const std::vector<Vec3>& pts, const Frame& f) : input(&pts) {
    if (f.dim < 3 || !(f.h2 < kRoundRel * f.extent)) return;
    mapped = true;
    origin = pts[f.a];
    M.row(0) = f.u.transpose() / f.extent;
    M.row(1) = f.v.transpose() / f.h1;
    M.row(2) = f.n.transpose() / f.h2;
    mapped_points.reserve(pts.size());
    for (const Vec3& p : pts)
      mapped_points.emplace_back(M * (p - origin));
  }
  /// The points as qhull gets them: the input itself, or mapped.
  const std::vector<Vec3>& points() const { return mapped ? mapped_points : *input; }
  /// The plane normal . x' + offset = 0 of the mapped space as m . x = c here: m = M^T normal,
  /// c = m . origin - offset; both divided by |m| (unit m). The identity when not mapped: (normal,
  /// -offset).
  std::pair<Vec3, double> planeBack(const Vec3& normal, double offset) const {
    if (!mapped) return {normal, -offset};
    const Vec3 m = M.transpose() * normal;
    const double len = m.norm();
    return {m / len, (m.dot(origin) - offset) / len};
  }
};

/// Indices of the extreme points along f.u (segment end points).
std::pair<int, int> segmentEnds(const std::vector<Vec3>& pts, const Frame& f) {
  int lo = 0, hi = 0;
  double tlo = std::numeric_limits<double>::infinity(), thi = -tlo;
  for (int i = 0; i < static_cast<int>(pts.size()); ++i) {
    const double t = f.u.dot(pts[i] - pts[f.a]);
    if (t < tlo) tlo = t, lo = i;
    if (t > thi) thi = t, hi = i;
  }
  return {lo, hi};
}

/// True when o -> p -> q turns left by more than rounding: sin(angle) > sin_tol.
bool leftTurn(const Vec2& o, const Vec2& p, const Vec2& q, double sin_tol) {
  const Vec2 op = p - o, oq = q - o;
  const double cross = op.x() * oq.y() - op.y() * oq.x();
  return cross > sin_tol * op.norm() * oq.norm();
}

/// 2D hull of the points projected into the plane (u, v) of `f` by Andrew's monotone chain
/// (Andrew 1979). Returns input indices counter-clockwise about f.n; points collinear within
/// rounding (of the input coordinates, projected) are dropped.
std::vector<int> planarHull(const std::vector<Vec3>& pts, const Frame& f) {
  const int count = static_cast<int>(pts.size());
  std::vector<Vec2> q(count);
  for (int i = 0; i < count; ++i) {
    const Vec3 w = pts[i] - pts[f.a];  // relative to a point of the set: no cancellation
    q[i] = Vec2(w.dot(f.u), w.dot(f.v));
  }
  std::vector<int> order(count);
  for (int i = 0; i < count; ++i)
    order[i] = i;
  std::sort(order.begin(), order.end(), [&](int i, int j) {
    return q[i].x() < q[j].x() || (q[i].x() == q[j].x() && q[i].y() < q[j].y());
  });
  const double sin_tol = 1e-12 + f.floor / f.extent;
  std::vector<int> hull(2 * count);
  int k = 0;
  for (int idx : order) {  // lower chain
    while (k >= 2 && !leftTurn(q[hull[k - 2]], q[hull[k - 1]], q[idx], sin_tol))
      --k;
    hull[k++] = idx;
  }
  for (int i = count - 2, t = k + 1; i >= 0; --i) {  // upper chain
    const int idx = order[i];
    while (k >= t && !leftTurn(q[hull[k - 2]], q[hull[k - 1]], q[idx], sin_tol))
      --k;
    hull[k++] = idx;
  }
  hull.resize(std::max(k - 1, 1));
  return hull;
}

/// RAII owner of one reentrant qhull run. Errors and warnings go to an in-memory stream.
class Qhull {
 public:
  Qhull() {
    err_ = open_memstream(&err_text_, &err_size_);
    if (err_ == nullptr) err_ = std::fopen("/dev/null", "w");  // never qhull's stderr default
    qh_zero(&qh_, err_);
  }
  ~Qhull() {
    if (ran_) {
      qh_freeqhull(&qh_, !qh_ALL);
      int curlong = 0, totlong = 0;
      qh_memfreeshort(&qh_, &curlong, &totlong);
    }
    if (err_ != nullptr) std::fclose(err_);
    std::free(err_text_);
  }
  Qhull(const Qhull&) = delete;
  Qhull& operator=(const Qhull&) = delete;

  /// Runs qhull on `pts` (3D) with `options` (appended to "qhull "). True on success.
  bool run(const std::vector<Vec3>& pts, const char* options) {
    coords_.resize(3 * pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) {
      for (int k = 0; k < 3; ++k)
        coords_[3 * i + k] = pts[i][k];
    }
    std::string cmd = std::string("qhull ") + options;
    ran_ = true;
    const int code = qh_new_qhull(&qh_, 3, static_cast<int>(pts.size()), coords_.data(), False,
                                  cmd.data(), nullptr, err_);
    return code == 0;
  }
  /// Text qhull wrote to its error stream so far.
  std::string errors() {
    if (err_ == nullptr) return "(no error stream)";
    std::fflush(err_);
    return err_text_ != nullptr ? std::string(err_text_, err_size_) : std::string();
  }
  qhT* get() { return &qh_; }

 private:
  qhT qh_;
  FILE* err_ = nullptr;
  char* err_text_ = nullptr;
  std::size_t err_size_ = 0;
  bool ran_ = false;
  std::vector<coordT> coords_;
};

/// Runs the 3D hull, retrying with joggle. Returns false (and `why`) if both fail.
bool runSolid(Qhull& qh, const std::vector<Vec3>& pts, const char* options, std::string* why) {
  if (qh.run(pts, options)) return true;
  if (why != nullptr) *why = qh.errors();
  return false;
}

std::shared_ptr<const Polytope<3>> makePolygon(const std::vector<Vec3>& pts, const Frame& f) {
  const std::vector<int> ring = planarHull(pts, f);
  const int m = static_cast<int>(ring.size());
  std::vector<Vec3> verts(m);
  for (int i = 0; i < m; ++i)
    verts[i] = pts[ring[i]];
  std::vector<int> offsets(m + 1), adj;
  adj.reserve(2 * m);
  for (int i = 0; i < m; ++i) {
    offsets[i] = static_cast<int>(adj.size());
    if (m == 1) continue;
    adj.push_back((i + m - 1) % m);
    if (m > 2) adj.push_back((i + 1) % m);
  }
  offsets[m] = static_cast<int>(adj.size());
  return std::make_shared<const Polytope<3>>(std::move(verts), std::move(offsets), std::move(adj));
}

std::shared_ptr<const Polytope<3>> makeLowDim(const std::vector<Vec3>& pts, const Frame& f) {
  if (f.dim == 0) {
    return std::make_shared<const Polytope<3>>(std::vector<Vec3>{pts[0]}, std::vector<int>{0, 0},
                                               std::vector<int>{});
  }
  if (f.dim == 1) {
    const auto ends = segmentEnds(pts, f);
    return std::make_shared<const Polytope<3>>(std::vector<Vec3>{pts[ends.first], pts[ends.second]},
                                               std::vector<int>{0, 1, 2}, std::vector<int>{1, 0});
  }
  return makePolygon(pts, f);
}

/// Hull vertices and edge graph of a successful 3D qhull run.
std::shared_ptr<const Polytope<3>> extractSolid(Qhull& q, const std::vector<Vec3>& pts) {
  qhT* qh = q.get();
  std::vector<int> remap(pts.size(), -1);
  std::vector<Vec3> verts;
  std::vector<std::pair<int, int>> edges;
  auto index = [&](vertexT* vx) {
    const int id = qh_pointid(qh, vx->point);
    if (remap[id] < 0) {
      remap[id] = static_cast<int>(verts.size());
      verts.push_back(pts[id]);
    }
    return remap[id];
  };
  auto addEdge = [&](int i, int j) {
    if (i != j) edges.emplace_back(std::min(i, j), std::max(i, j));
  };
  facetT* facet;
  FORALLfacets {
    // qhull keeps complete ridge sets only for non-simplicial (merged) facets; a simplicial
    // facet may hold some of its ridges or none (found by fuzz_core: a tetrahedron from input
    // with a duplicate point had three facets with one ridge each, and the edge walk lost a
    // vertex). So: ridges for merged facets, the three vertex pairs for simplicial ones.
    if (!facet->simplicial && facet->ridges != nullptr) {
      // Ridges are the real edges between distinct (merged, non-triangular) facets. Every
      // vertex is taken from the facet itself, so none depends on the ridges being complete.
      vertexT *vertex, **vertexp;
      FOREACHvertex_(facet->vertices) index(vertex);
      ridgeT *ridge, **ridgep;
      FOREACHridge_(facet->ridges) {
        vertexT* v0 = static_cast<vertexT*>(SETfirst_(ridge->vertices));
        vertexT* v1 = static_cast<vertexT*>(SETsecond_(ridge->vertices));
        if (v0 != nullptr && v1 != nullptr) addEdge(index(v0), index(v1));
      }
    } else {
      // Simplicial facet: its three vertices are pairwise hull edges.
      std::vector<int> fv;
      vertexT *vertex, **vertexp;
      FOREACHvertex_(facet->vertices) fv.push_back(index(vertex));
      for (std::size_t i = 0; i < fv.size(); ++i) {
        for (std::size_t j = i + 1; j < fv.size(); ++j)
          addEdge(fv[i], fv[j]);
      }
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  const int m = static_cast<int>(verts.size());
  std::vector<int> offsets(m + 1, 0), adj(2 * edges.size());
  for (const auto& e : edges)
    ++offsets[e.first + 1], ++offsets[e.second + 1];
  for (int i = 0; i < m; ++i)
    offsets[i + 1] += offsets[i];
  std::vector<int> fill(offsets.begin(), offsets.end() - 1);
  for (const auto& e : edges) {
    adj[fill[e.first]++] = e.second;
    adj[fill[e.second]++] = e.first;
  }
  return std::make_shared<const Polytope<3>>(std::move(verts), std::move(offsets), std::move(adj));
}

/// Outward, counter-clockwise triangles of a simplicial (triangulated) 3D qhull run on `pts`
/// seen through `r`.
void collectTriangles(Qhull& q, const std::vector<Vec3>& pts, const Rounding& r,
                      std::vector<std::array<int, 3>>* tris) {
  qhT* qh = q.get();
  facetT* facet;
  FORALLfacets {
    std::array<int, 3> t{};
    int k = 0;
    vertexT *vertex, **vertexp;
    FOREACHvertex_(facet->vertices) {
      if (k < 3) t[k] = qh_pointid(qh, vertex->point);
      ++k;
    }
    if (k != 3) continue;
    const Vec3 nrm =
        r.planeBack(Vec3(facet->normal[0], facet->normal[1], facet->normal[2]), facet->offset)
            .first;
    const Vec3 c = (pts[t[1]] - pts[t[0]]).cross(pts[t[2]] - pts[t[0]]);
    if (c.dot(nrm) < 0.0) std::swap(t[1], t[2]);  // counter-clockwise seen from outside
    tris->push_back(t);
  }
}

/// Coordinates outside [kTinyCoordinate, kHugeCoordinate] (largest magnitude) are scaled by a
/// power of two to about 1 before the hull is built: lengths are squared above (norm()) and
/// qhull's determinants are cubes, which underflow or overflow there (a cube 1.7e-273 m across
/// came out as a single point, its extent's square being 0:
/// fuzz/regressions/core/hull-1e-273m-cube-collapsed-to-a-point).
constexpr double kTinyCoordinate = 1e-50;
constexpr double kHugeCoordinate = 1e50;

/// The power of two 2^e that brings `points` to about unit size, or 1 (e = 0) when they are
/// within [kTinyCoordinate, kHugeCoordinate] (or all 0).
int unitScaleExponent(const std::vector<Vec3>& points) {
  double max_abs = 0.0;
  for (const Vec3& p : points)
    max_abs = std::max(max_abs, p.cwiseAbs().maxCoeff());
  if (!(max_abs > 0.0) || (max_abs >= kTinyCoordinate && max_abs <= kHugeCoordinate)) return 0;
  return -std::ilogb(max_abs);
}

/// `points` times 2^e (exact: a power of two; e from unitScaleExponent(), no overflow).
std::vector<Vec3> scaled(const std::vector<Vec3>& points, int e) {
  std::vector<Vec3> out(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (int k = 0; k < 3; ++k)
      out[i][k] = std::ldexp(points[i][k], e);
  }
  return out;
}

std::shared_ptr<const Polytope<3>> buildUnitHull(const std::vector<Vec3>& points) {
  const Frame f = analyse(points);
  if (f.dim < 3) return makeLowDim(points, f);
  const Rounding r(points, f);
  std::string why;
  {
    // Coplanar facets merged (qhull's default), so ridges are the real edges. "Qs": the initial
    // simplex from all points; with qhull's default pick, the 16 corners of a box swept along a
    // 1e6 m segment never left qhull's merging (qh_mergefacet, > 10 minutes; "Qs": 0.14 ms):
    // fuzz/regressions/core/hull-box-swept-1e6m-qhull-hang.
    Qhull q;
    if (runSolid(q, r.points(), "Qs", &why)) return extractSolid(q, points);
  }
  {
    Qhull q;  // nearly flat input: joggled input always gives a (simplicial) hull
    if (runSolid(q, r.points(), "QJ", &why)) return extractSolid(q, points);
  }
  // Both failed: the set is flat to qhull's precision; its in-plane hull is the best answer.
  Frame flat = f;
  flat.dim = 2;
  return makePolygon(points, flat);
}

}  // namespace

std::shared_ptr<const Polytope<3>> buildConvexHull(const std::vector<Vec3>& points) {
  validate(points, "buildConvexHull");
  const int e = unitScaleExponent(points);
  if (e == 0) return buildUnitHull(points);
  // The hull of the scaled points, its vertices scaled back: each is an input point times 2^e
  // times 2^-e, the input point again exactly (also a subnormal one: its bits fit either way).
  const auto unit = buildUnitHull(scaled(points, e));
  return std::make_shared<const Polytope<3>>(scaled(unit->vertices(), -e), unit->adjacencyOffsets(),
                                             unit->adjacency());
}

std::vector<std::array<int, 3>> hullTriangles(const Polytope<3>& poly) {
  // Indices only: computed on the vertices at about unit size (unitScaleExponent()).
  const int e = unitScaleExponent(poly.vertices());
  const std::vector<Vec3> unit = e != 0 ? scaled(poly.vertices(), e) : std::vector<Vec3>();
  const std::vector<Vec3>& pts = e != 0 ? unit : poly.vertices();
  std::vector<std::array<int, 3>> tris;
  if (pts.size() < 4) return tris;
  const Frame f = analyse(pts);
  if (f.dim < 3) return tris;
  const Rounding r(pts, f);
  // Triangulated output ("Qt"); joggled ("QJ", simplicial by construction) if qhull finds the
  // set too flat for its precision.
  Qhull q;
  if (!q.run(r.points(), "Qt")) {
    Qhull qj;
    if (qj.run(r.points(), "QJ")) collectTriangles(qj, pts, r, &tris);
    return tris;
  }
  collectTriangles(q, pts, r, &tris);
  return tris;
}

std::vector<HullPlane> hullPlanes(const std::vector<Vec3>& points) {
  validate(points, "hullPlanes");
  if (const int e = unitScaleExponent(points); e != 0) {
    // The planes of the points at about unit size (unitScaleExponent()), offsets scaled back.
    std::vector<HullPlane> planes = hullPlanes(scaled(points, e));
    for (HullPlane& h : planes)
      h.offset = std::ldexp(h.offset, -e);
    return planes;
  }
  const Frame f = analyse(points);
  std::vector<HullPlane> planes;
  if (f.dim == 3) {
    const Rounding r(points, f);
    Qhull q;
    if (q.run(r.points(), "")) {
      qhT* qh = q.get();
      facetT* facet;
      FORALLfacets {
        // qhull's hyperplane: normal . x + offset = 0, normal outward, interior negative.
        const auto [n, offset] =
            r.planeBack(Vec3(facet->normal[0], facet->normal[1], facet->normal[2]), facet->offset);
        planes.push_back(HullPlane{n, offset});
      }
      return planes;
    }
  }
  if (f.dim < 2) return planes;
  // Flat polygon: the two faces of the zero-thickness slab plus one plane per edge.
  const Vec3& o = points[f.a];
  planes.push_back(HullPlane{f.n, f.n.dot(o)});
  planes.push_back(HullPlane{-f.n, -f.n.dot(o)});
  const std::vector<int> ring = planarHull(points, f);
  const std::size_t m = ring.size();
  for (std::size_t i = 0; i < m; ++i) {
    const Vec3& p = points[ring[i]];
    const Vec3 e = points[ring[(i + 1) % m]] - p;
    const Vec3 out = e.cross(f.n).normalized();  // ring is counter-clockwise about n
    planes.push_back(HullPlane{out, out.dot(p)});
  }
  return planes;
}

}  // namespace core
}  // namespace collision_monitor
