// A program without ROS using the installed geometry core: a qhull hull (a 0.5 m cube from its 8
// corners) and a 0.25 m sphere 1 m away are 0.5 m apart (GJK); 0.4 m away they overlap (libccd).
// Exits 0 when both answers are right.
#include <cmath>
#include <cstdio>
#include <vector>

#include <collision_monitor/core/backend.h>
#include <collision_monitor/core/query.h>

namespace cm = collision_monitor::core;

int main() {
  std::vector<cm::Vec3> corners;
  for (double x : {-0.25, 0.25}) {
    for (double y : {-0.25, 0.25}) {
      for (double z : {-0.25, 0.25})
        corners.emplace_back(x, y, z);
    }
  }
  const cm::ConvexShape cube = cm::ConvexShape::convexHull(corners);
  const cm::ConvexShape sphere = cm::ConvexShape::sphere(0.25);
  cm::Transform3 pose = cm::Transform3::Identity();
  pose.t = cm::Vec3(1.0, 0, 0);
  const cm::ContactResult r = cm::signedDistance(cube, cm::Transform3::Identity(), sphere, pose);
  std::printf("hull/sphere: %s, distance %.17g m\n", cm::toString(r.status), r.distance);

  pose.t = cm::Vec3(0.4, 0, 0);
  const auto ccd = cm::makeNarrowPhase(cm::BackendType::Libccd);
  const bool overlap = ccd->intersect(cube, cm::Transform3::Identity(), sphere, pose, nullptr);
  std::printf("%s at 0.4 m: %s\n", cm::toString(ccd->type()), overlap ? "intersect" : "apart");
  return r.status == cm::Status::Separated && std::abs(r.distance - 0.5) < 1e-12 && overlap ? 0 : 1;
}
