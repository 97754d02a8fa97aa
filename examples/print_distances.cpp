/// \file
/// Prints signed distances between a few shapes: a smoke run of the geometry core.
#include <cstdio>
#include <utility>
#include <vector>

#include "collision_monitor/core/query.h"

namespace cm = collision_monitor::core;

int main() {
  const cm::Transform3 origin = cm::Transform3::Identity();
  auto at = [](double x, double y, double z) {
    cm::Transform3 T;
    T.t = cm::Vec3(x, y, z);
    return T;
  };
  const std::vector<std::pair<const char*, cm::ConvexShape>> shapes = {
      {"sphere r=0.5", cm::ConvexShape::sphere(0.5)},
      {"box 1x1x1", cm::ConvexShape::box(cm::Vec3(1, 1, 1))},
      {"capsule l=1 r=0.2", cm::ConvexShape::capsule(1.0, 0.2)},
      {"cylinder h=1 r=0.3", cm::ConvexShape::cylinder(1.0, 0.3)},
      {"cone h=1 r=0.3", cm::ConvexShape::cone(1.0, 0.3)},
      {"ellipsoid 0.3,0.2,0.1", cm::ConvexShape::ellipsoid(cm::Vec3(0.3, 0.2, 0.1))},
  };
  const std::vector<cm::Transform3> poses = {at(2.0, 0, 0), at(0.9, 0.1, 0), at(0.3, 0.2, 0.1)};
  std::printf("%-22s %-22s %6s %12s  %-12s %-22s %s\n", "A (at origin)", "B", "B.x", "signed dist",
              "status", "normal", "gjk/epa iterations");
  for (const auto& a : shapes) {
    for (const auto& b : shapes) {
      for (const auto& pose : poses) {
        const cm::ContactResult r = cm::signedDistance(a.second, origin, b.second, pose);
        std::printf("%-22s %-22s %6.3f %12.6f  %-12s (%6.3f %6.3f %6.3f) %3d %3d\n", a.first,
                    b.first, pose.t.x(), r.distance, cm::toString(r.status), r.normal.x(),
                    r.normal.y(), r.normal.z(), r.gjk_iterations, r.epa_iterations);
      }
    }
  }
  return 0;
}
