/// \file
/// Our types as FCL 0.7's, for every benchmark that runs FCL: a pose, and a hull as an
/// fcl::Convex (our vertices, our outward triangles as faces).
#pragma once

#include <fcl/geometry/shape/convex.h>

#include <array>
#include <memory>
#include <vector>

#include "collision_monitor/core/math.h"
#include "collision_monitor/core/shapes.h"

namespace cm_bench_fcl {

inline fcl::Transform3d toFcl(const collision_monitor::core::Transform3& p) {
  fcl::Transform3d t = fcl::Transform3d::Identity();
  t.linear() = p.R;
  t.translation() = p.t;
  return t;
}

/// `triangles`: core::hullTriangles(hull).
inline fcl::Convexd toFcl(const collision_monitor::core::Polytope<3>& hull,
                          const std::vector<std::array<int, 3>>& triangles) {
  auto verts = std::make_shared<std::vector<fcl::Vector3d>>();
  for (const auto& v : hull.vertices())
    verts->push_back(v);
  auto faces = std::make_shared<std::vector<int>>();
  for (const auto& t : triangles) {
    faces->push_back(3);
    faces->insert(faces->end(), t.begin(), t.end());
  }
  return fcl::Convexd(verts, static_cast<int>(triangles.size()), faces);
}

}  // namespace cm_bench_fcl
