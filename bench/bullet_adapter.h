/// \file
/// Bullet 3.24 (double precision: the *-float64 libraries, BT_USE_DOUBLE_PRECISION) as a
/// competitor: btGjkPairDetector with btVoronoiSimplexSolver, and btGjkEpaPenetrationDepthSolver
/// when a penetration depth is asked for.
///
/// Geometry is made identical to ours by setting every collision margin to 0: btConvexHullShape
/// gets our hull vertices (margin 0, so not inflated by Bullet's default 4 cm), btBoxShape /
/// btCylinderShapeZ keep their full extents (their setMargin() compensates), btConeShapeZ is not
/// inflated; btSphereShape and btCapsuleShapeZ carry their radius as margin (exact, as our radius).
///
/// Queries:
///   distance: btGjkPairDetector::getClosestPoints without a penetration solver (pure GJK, the
///             same work as our distance(): no depth when overlapping, then no result);
///   penetration: the same with btGjkEpaPenetrationDepthSolver (signed distance);
///   warm distance: Bullet's own warm start, the cached separating axis kept per pair.
/// btConvexHullShape's support is a linear scan over all vertices (no hill-climbing).
#pragma once

#include <BulletCollision/CollisionShapes/btBoxShape.h>
#include <BulletCollision/CollisionShapes/btCapsuleShape.h>
#include <BulletCollision/CollisionShapes/btConeShape.h>
#include <BulletCollision/CollisionShapes/btConvexHullShape.h>
#include <BulletCollision/CollisionShapes/btCylinderShape.h>
#include <BulletCollision/CollisionShapes/btSphereShape.h>
#include <BulletCollision/NarrowPhaseCollision/btGjkEpaPenetrationDepthSolver.h>
#include <BulletCollision/NarrowPhaseCollision/btGjkPairDetector.h>
#include <BulletCollision/NarrowPhaseCollision/btPointCollector.h>
#include <BulletCollision/NarrowPhaseCollision/btVoronoiSimplexSolver.h>

#include <memory>
#include <stdexcept>
#include <vector>

#include "bench_loop.h"
#include "pools.h"

#ifndef BT_USE_DOUBLE_PRECISION
#error "The Bullet competitor needs BT_USE_DOUBLE_PRECISION and the *-float64 libraries"
#endif

namespace cm_bench {

/// Result of one Bullet query. `has_result` false: GJK found no separation (overlap) and no
/// penetration solver was attached.
struct BulletResult {
  bool has_result = false;
  double distance = 0.0;  ///< m, < 0 penetrating (only with the penetration solver)
  bool overlapping() const { return !has_result || distance <= 0.0; }
};

class BulletBench {
 public:
  explicit BulletBench(const Pool& pool) : pool_(&pool) {
    for (const ShapeSpec& s : pool.shapes)
      shapes_.push_back(makeShape(s));
    for (int p = 0; p < pool.size(); ++p) {
      pose_a_.push_back(toBullet(pool.poseA(p)));
      for (int k = 0; k < Pool::kSteps; ++k)
        pose_b_.push_back(toBullet(pool.poseB(p, k)));
    }
  }

  /// One query. `epa`: attach the GJK-EPA penetration solver. `axis`: Bullet's warm start
  /// (in/out), or nullptr for a cold query (btGjkPairDetector's default initial axis).
  BulletResult query(int pair, int step, bool epa, btVector3* axis = nullptr) const {
    const btConvexShape* a = shapes_[pool_->shape_a[pair]].get();
    const btConvexShape* b = shapes_[pool_->shape_b[pair]].get();
    btGjkPairDetector detector(a, b, &simplex_, epa ? &epa_ : nullptr);
    if (axis) detector.setCachedSeparatingAxis(*axis);
    btGjkPairDetector::ClosestPointInput input;
    input.m_transformA = pose_a_[pair];
    input.m_transformB = pose_b_[static_cast<size_t>(pair) * Pool::kSteps + step];
    btPointCollector out;
    detector.getClosestPoints(input, out, nullptr);
    if (axis) *axis = detector.getCachedSeparatingAxis();
    return BulletResult{out.m_hasResult, out.m_distance};
  }

  void benchDistance(benchmark::State& state) const {
    runPool(state, *pool_,
            [this](int pair, int step) { return query(pair, step, false).distance; });
  }
  /// Boolean intersect: Bullet has no separate boolean GJK; the distance query's verdict.
  void benchIntersect(benchmark::State& state) const {
    runPool(state, *pool_,
            [this](int pair, int step) { return query(pair, step, false).overlapping(); });
  }
  void benchDistanceWarm(benchmark::State& state) const {
    std::vector<btVector3> axes(pool_->size(), btVector3(0, 1, 0));
    // One untimed pass so every pair starts from its previous step's axis.
    Cursor c(pool_->size());
    for (int i = 0; i < pool_->size(); ++i, c.next())
      query(c.pair, c.step(), false, &axes[c.pair]);
    runPool(state, *pool_, [this, &axes](int pair, int step) {
      return query(pair, step, false, &axes[pair]).distance;
    });
  }
  void benchPenetration(benchmark::State& state, const std::vector<PairStep>& list) const {
    runList(state, list, [this](int pair, int step) { return query(pair, step, true).distance; });
  }

 private:
  static std::unique_ptr<btConvexShape> makeShape(const ShapeSpec& s) {
    std::unique_ptr<btConvexShape> shape;
    switch (s.kind) {
      case Kind::Hull: {
        auto hull = std::make_unique<btConvexHullShape>();
        for (const Vec3& v : s.hull->vertices())
          hull->addPoint(btVector3(v.x(), v.y(), v.z()), false);
        hull->recalcLocalAabb();
        shape = std::move(hull);
        shape->setMargin(0.0);
        break;
      }
      case Kind::Box:
        shape = std::make_unique<btBoxShape>(
            btVector3(s.box_sides.x(), s.box_sides.y(), s.box_sides.z()) * 0.5);
        shape->setMargin(0.0);
        break;
      case Kind::Sphere:
        shape = std::make_unique<btSphereShape>(s.radius);
        break;
      case Kind::Capsule:
        shape = std::make_unique<btCapsuleShapeZ>(s.radius, s.length);
        break;
      case Kind::Cylinder:
        shape = std::make_unique<btCylinderShapeZ>(btVector3(s.radius, s.radius, 0.5 * s.length));
        shape->setMargin(0.0);
        break;
      case Kind::Cone:
        shape = std::make_unique<btConeShapeZ>(s.radius, s.length);
        shape->setMargin(0.0);
        break;
    }
    return shape;
  }
  static btTransform toBullet(const Transform3& p) {
    const btMatrix3x3 R(p.R(0, 0), p.R(0, 1), p.R(0, 2), p.R(1, 0), p.R(1, 1), p.R(1, 2), p.R(2, 0),
                        p.R(2, 1), p.R(2, 2));
    return btTransform(R, btVector3(p.t.x(), p.t.y(), p.t.z()));
  }

  const Pool* pool_;
  std::vector<std::unique_ptr<btConvexShape>> shapes_;  // by pool shape index
  std::vector<btTransform> pose_a_;
  std::vector<btTransform> pose_b_;
  // Reused across queries (as a collision dispatcher would); btGjkPairDetector resets them.
  mutable btVoronoiSimplexSolver simplex_;
  mutable btGjkEpaPenetrationDepthSolver epa_;
};

}  // namespace cm_bench
