/// \file
/// libccd 2.1 on our shapes: the `void*` object is a placed ShapeSpec, the support callback
/// rotates the direction into the shape frame, asks the shape, and maps the point back to world.
///
/// This is the adapter a careful libccd user would write: polytopes hill-climb with a hint that
/// lives for one query (starting at vertex 0, as libccd has no warm start), primitives use their
/// closed-form support. Return code polarity differs between libccd functions:
/// ccdGJKIntersect / ccdMPRIntersect return 1 on contact; ccdGJKPenetration / ccdMPRPenetration
/// return 0 on contact and -1 when separated.
#pragma once

#include <ccd/ccd.h>

#include "pools.h"

namespace cm_bench {

/// One placed shape as libccd sees it.
struct CcdBody {
  const ShapeSpec* spec = nullptr;
  const Transform3* pose = nullptr;
  mutable int hint = 0;  ///< polytope hill-climbing start, per query
};

inline void ccdSupport(const void* obj, const ccd_vec3_t* dir, ccd_vec3_t* out) {
  const auto* body = static_cast<const CcdBody*>(obj);
  const Vec3 d(dir->v[0], dir->v[1], dir->v[2]);
  const Vec3 d_local = body->pose->R.transpose() * d;
  Vec3 p;
  if (body->spec->kind == Kind::Hull) {
    // The scalar lane reduction: the faster one for libccd (detail::scanBlocks); same index.
    p = body->spec->hull->support<false>(d_local, body->hint);
  } else {
    p = body->spec->ours->support(d_local);
  }
  const Vec3 w = body->pose->R * p + body->pose->t;
  out->v[0] = w.x();
  out->v[1] = w.y();
  out->v[2] = w.z();
}

inline void ccdCenter(const void* obj, ccd_vec3_t* out) {
  const auto* body = static_cast<const CcdBody*>(obj);
  const Vec3 w = body->pose->R * body->spec->centroid + body->pose->t;
  out->v[0] = w.x();
  out->v[1] = w.y();
  out->v[2] = w.z();
}

/// libccd settings used everywhere: its defaults (CCD_INIT: tolerances 1e-4 for MPR and EPA,
/// 1e-6 for distance) with an iteration bound of 500 (FCL's bound for collision) instead of
/// ULONG_MAX.
inline ccd_t makeCcd() {
  ccd_t ccd;
  CCD_INIT(&ccd);
  ccd.support1 = ccdSupport;
  ccd.support2 = ccdSupport;
  ccd.center1 = ccdCenter;
  ccd.center2 = ccdCenter;
  ccd.max_iterations = 500;
  return ccd;
}

inline bool ccdGjkIntersect(const ccd_t& ccd, const ShapeSpec& a, const Transform3& pa,
                            const ShapeSpec& b, const Transform3& pb) {
  const CcdBody ba{&a, &pa, 0};
  const CcdBody bb{&b, &pb, 0};
  return ccdGJKIntersect(&ba, &bb, &ccd) != 0;
}

inline bool ccdMprIntersect(const ccd_t& ccd, const ShapeSpec& a, const Transform3& pa,
                            const ShapeSpec& b, const Transform3& pb) {
  const CcdBody ba{&a, &pa, 0};
  const CcdBody bb{&b, &pb, 0};
  return ccdMPRIntersect(&ba, &bb, &ccd) != 0;
}

/// Penetration depth (m, >= 0) by libccd GJK+EPA, or -1 when separated.
inline double ccdGjkDepth(const ccd_t& ccd, const ShapeSpec& a, const Transform3& pa,
                          const ShapeSpec& b, const Transform3& pb) {
  const CcdBody ba{&a, &pa, 0};
  const CcdBody bb{&b, &pb, 0};
  ccd_real_t depth = 0;
  ccd_vec3_t dir, pos;
  return ccdGJKPenetration(&ba, &bb, &ccd, &depth, &dir, &pos) == 0 ? depth : -1.0;
}

/// Penetration depth (m, >= 0, MPR's estimate: not exact) by libccd MPR, or -1 when separated.
inline double ccdMprDepth(const ccd_t& ccd, const ShapeSpec& a, const Transform3& pa,
                          const ShapeSpec& b, const Transform3& pb) {
  const CcdBody ba{&a, &pa, 0};
  const CcdBody bb{&b, &pb, 0};
  ccd_real_t depth = 0;
  ccd_vec3_t dir, pos;
  return ccdMPRPenetration(&ba, &bb, &ccd, &depth, &dir, &pos) == 0 ? depth : -1.0;
}

}  // namespace cm_bench
