/// \file
/// FCL 0.7 as a competitor: fcl::detail::GJKSolver_libccd<double> (its libccd-based narrow
/// phase) on fcl::Convex (our hull vertices, our hull triangles as faces) and FCL primitives.
///
/// Solver settings are FCL's defaults (distance_tolerance 1e-6, 1000 distance iterations, MPR for
/// boolean collision with tolerance 1e-6 and 500 iterations). What FCL actually runs per pair:
///   shapeDistance:  libccd GJK distance (FCL's ccdGJKDist2), except sphere/box and
///                   capsule/capsule, which FCL answers in closed form;
///   shapeIntersect: ccdMPRIntersect, except box/box (SAT, boxBoxIntersect) and sphere/box
///                   (closed form);
///   shapeSignedDistance: GJK + FCL's EPA.
/// fcl::Convex with more than 32 vertices walks its vertex-neighbour graph from vertex 0 for every
/// support call; 32 or fewer: a linear scan.
#pragma once

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cone.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/detail/gjk_solver_libccd.h>

#include <memory>
#include <stdexcept>
#include <utility>
#include <vector>

#include "bench_loop.h"
#include "fcl_common.h"
#include "pools.h"

namespace cm_bench {

/// The FCL side of one pool, behind a virtual interface; the timed loops live in the typed
/// implementation, so the loop body is fully inlined (no virtual call per query).
class FclBench {
 public:
  virtual ~FclBench() = default;
  /// shapeIntersect verdict.
  virtual bool intersect(int pair, int step) const = 0;
  /// shapeDistance: (separated, distance in m; FCL reports -1 when not separated).
  virtual std::pair<bool, double> distance(int pair, int step) const = 0;
  /// shapeSignedDistance, m (< 0 when penetrating). May throw on degenerate input.
  virtual double signedDistance(int pair, int step) const = 0;
  virtual void benchIntersect(benchmark::State& state) const = 0;
  virtual void benchDistance(benchmark::State& state) const = 0;
  virtual void benchPenetration(benchmark::State& state,
                                const std::vector<PairStep>& list) const = 0;
};

namespace fcl_detail {

template <class S>
S make(const ShapeSpec& s);
template <>
inline fcl::Convexd make<fcl::Convexd>(const ShapeSpec& s) {
  return cm_bench_fcl::toFcl(*s.hull, s.triangles);
}
template <>
inline fcl::Boxd make<fcl::Boxd>(const ShapeSpec& s) {
  return fcl::Boxd(s.box_sides.x(), s.box_sides.y(), s.box_sides.z());
}
template <>
inline fcl::Sphered make<fcl::Sphered>(const ShapeSpec& s) {
  return fcl::Sphered(s.radius);
}
template <>
inline fcl::Capsuled make<fcl::Capsuled>(const ShapeSpec& s) {
  return fcl::Capsuled(s.radius, s.length);
}
template <>
inline fcl::Cylinderd make<fcl::Cylinderd>(const ShapeSpec& s) {
  return fcl::Cylinderd(s.radius, s.length);
}
template <>
inline fcl::Coned make<fcl::Coned>(const ShapeSpec& s) {
  return fcl::Coned(s.radius, s.length);
}

using cm_bench_fcl::toFcl;

template <class S1, class S2>
class FclBenchT final : public FclBench {
 public:
  explicit FclBenchT(const Pool& pool) {
    // Shapes are built once per pool shape (shared by pairs, as the pool's shapes are).
    std::vector<std::unique_ptr<S1>> a_by_index(pool.shapes.size());
    std::vector<std::unique_ptr<S2>> b_by_index(pool.shapes.size());
    for (int p = 0; p < pool.size(); ++p) {
      auto& a = a_by_index[pool.shape_a[p]];
      if (!a) a = std::make_unique<S1>(make<S1>(pool.a(p)));
      auto& b = b_by_index[pool.shape_b[p]];
      if (!b) b = std::make_unique<S2>(make<S2>(pool.b(p)));
      a_.push_back(a.get());
      b_.push_back(b.get());
      pose_a_.push_back(toFcl(pool.poseA(p)));
      for (int k = 0; k < Pool::kSteps; ++k)
        pose_b_.push_back(toFcl(pool.poseB(p, k)));
    }
    for (auto& a : a_by_index)
      if (a) owned_a_.push_back(std::move(a));
    for (auto& b : b_by_index)
      if (b) owned_b_.push_back(std::move(b));
    pool_ = &pool;
  }

  bool intersect(int pair, int step) const override {
    return solver_.shapeIntersect(*a_[pair], pose_a_[pair], *b_[pair], poseB(pair, step), nullptr);
  }
  std::pair<bool, double> distance(int pair, int step) const override {
    double d = -1.0;
    fcl::Vector3d p1, p2;
    const bool sep =
        solver_.shapeDistance(*a_[pair], pose_a_[pair], *b_[pair], poseB(pair, step), &d, &p1, &p2);
    return {sep, d};
  }
  double signedDistance(int pair, int step) const override {
    double d = 0.0;
    fcl::Vector3d p1, p2;
    solver_.shapeSignedDistance(*a_[pair], pose_a_[pair], *b_[pair], poseB(pair, step), &d, &p1,
                                &p2);
    return d;
  }
  void benchIntersect(benchmark::State& state) const override {
    runPool(state, *pool_, [this](int pair, int step) { return intersect(pair, step); });
  }
  void benchDistance(benchmark::State& state) const override {
    runPool(state, *pool_, [this](int pair, int step) {
      // Witness points asked for, as ours always computes them (and FCL's capsule/capsule
      // closed form requires them).
      double d = -1.0;
      fcl::Vector3d p1, p2;
      solver_.shapeDistance(*a_[pair], pose_a_[pair], *b_[pair], poseB(pair, step), &d, &p1, &p2);
      return d;
    });
  }
  void benchPenetration(benchmark::State& state, const std::vector<PairStep>& list) const override {
    runList(state, list, [this](int pair, int step) {
      double d = 0.0;
      fcl::Vector3d p1, p2;
      solver_.shapeSignedDistance(*a_[pair], pose_a_[pair], *b_[pair], poseB(pair, step), &d, &p1,
                                  &p2);
      return d;
    });
  }

 private:
  const fcl::Transform3d& poseB(int pair, int step) const {
    return pose_b_[static_cast<size_t>(pair) * Pool::kSteps + step];
  }
  const Pool* pool_ = nullptr;
  fcl::detail::GJKSolver_libccdd solver_;
  std::vector<std::unique_ptr<S1>> owned_a_;
  std::vector<std::unique_ptr<S2>> owned_b_;
  std::vector<const S1*> a_;
  std::vector<const S2*> b_;
  std::vector<fcl::Transform3d> pose_a_;
  std::vector<fcl::Transform3d> pose_b_;
};

}  // namespace fcl_detail

/// The FCL side of `pool` (which must outlive it).
inline std::unique_ptr<FclBench> makeFclBench(const Pool& pool) {
  using namespace fcl_detail;
  if (pool.kind_a == Kind::Hull && pool.kind_b == Kind::Hull)
    return std::make_unique<FclBenchT<fcl::Convexd, fcl::Convexd>>(pool);
  if (pool.kind_a == Kind::Box && pool.kind_b == Kind::Box)
    return std::make_unique<FclBenchT<fcl::Boxd, fcl::Boxd>>(pool);
  if (pool.kind_a == Kind::Capsule && pool.kind_b == Kind::Capsule)
    return std::make_unique<FclBenchT<fcl::Capsuled, fcl::Capsuled>>(pool);
  if (pool.kind_a == Kind::Sphere && pool.kind_b == Kind::Box)
    return std::make_unique<FclBenchT<fcl::Sphered, fcl::Boxd>>(pool);
  if (pool.kind_a == Kind::Cylinder && pool.kind_b == Kind::Cone)
    return std::make_unique<FclBenchT<fcl::Cylinderd, fcl::Coned>>(pool);
  throw std::invalid_argument(std::string("makeFclBench: no FCL pair for ") +
                              toString(pool.kind_a) + "/" + toString(pool.kind_b));
}

}  // namespace cm_bench
