// A downstream user of collision_monitor: its messages, services and geometry core from the
// installed headers and libraries. Exits 0 when a capsule and a box are 0.35 m apart, as they are.
#include <cmath>
#include <cstdio>

#include <collision_monitor/Body.h>
#include <collision_monitor/CheckCollision.h>
#include <collision_monitor/CollisionState.h>
#include <collision_monitor/GetDistance.h>
#include <collision_monitor/core/query.h>

namespace cm = collision_monitor::core;

int main() {
  collision_monitor::Body body;
  body.id = "capsule";
  body.operation = collision_monitor::Body::ADD;
  collision_monitor::Shape capsule;
  capsule.type = collision_monitor::Shape::CAPSULE;
  capsule.dimensions = {0.4, 0.05};
  body.parts.push_back(capsule);
  collision_monitor::GetDistance distance_srv;
  distance_srv.request.body_a = body.id;

  const cm::ConvexShape a =
      cm::ConvexShape::capsule(body.parts[0].dimensions[0], body.parts[0].dimensions[1]);
  const cm::ConvexShape b = cm::ConvexShape::box({0.2, 0.2, 0.2});
  cm::Transform3 pose_b = cm::Transform3::Identity();
  pose_b.t = cm::Vec3(0.5, 0, 0);
  cm::PairCache cache;
  const cm::ContactResult r = cm::signedDistance(a, cm::Transform3::Identity(), b, pose_b, &cache);
  std::printf("capsule/box: %s, distance %.17g m\n", cm::toString(r.status), r.distance);
  return r.status == cm::Status::Separated && std::abs(r.distance - 0.35) < 1e-12 ? 0 : 1;
}
