/// \file
/// Mesh parts: where a mesh URI may point, and loading it as a convex hull.
///
/// A MESH resource is resolved to a canonical path (realpath: symlinks and `..` resolved) before
/// anything is read, and refused unless that path is a regular file inside
///  - a directory of `mesh_roots` (file:// and package:// URIs), or
///  - the package's own directory (package:// URIs only).
/// So `file:///etc/passwd`, `package://pkg/../../etc/passwd` and a symlink inside a mesh root
/// that points outside it are all refused. The mesh is then read from the canonical path (not the
/// URI), so what is loaded is what was checked.
#pragma once

#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <tuple>
#include <vector>

#include "collision_monitor/core/convex_shape.h"
#include "collision_monitor/ros/expected.h"

namespace collision_monitor {
namespace ros_layer {

/// Package name -> its directory; empty when unknown. The node uses ros::package::getPath.
using PackageResolver = std::function<std::string(const std::string& package)>;

/// ros::package::getPath.
std::string rosPackagePath(const std::string& package);

/// The canonical path of a mesh URI, or why it may not be read (unsupported scheme, unknown
/// package, no such file, outside mesh_roots, not a regular file, unreadable).
Expected<std::string> resolveMeshUri(const std::string& uri,
                                     const std::vector<std::string>& mesh_roots,
                                     const PackageResolver& resolve_package);

/// Loads the mesh file at `path` (STL/DAE/OBJ via geometric_shapes/assimp), scaled, and returns
/// its convex hull; refused when the mesh has more than `max_vertices` (distinct) vertices,
/// checked right after loading and before hulling, or when it has no vertices.
Expected<core::ConvexShape> loadMeshHull(const std::string& path, const core::Vec3& scale,
                                         std::size_t max_vertices);

/// resolveMeshUri + loadMeshHull with a cache of hulls by (canonical path, scale): the PR2 uses the
/// same wheel mesh eight times. Thread-safe.
class MeshCache {
 public:
  MeshCache(std::vector<std::string> mesh_roots, std::size_t max_vertices,
            PackageResolver resolve_package = rosPackagePath);
  Expected<core::ConvexShape> load(const std::string& uri, const core::Vec3& scale);
  const std::vector<std::string>& meshRoots() const { return mesh_roots_; }
  /// Hulls kept (path, scale). Past kMaxEntries the cache starts again empty: a stream of bodies
  /// with ever new scales cannot grow it without bound (bodies keep their own hulls).
  std::size_t size() const;
  static constexpr std::size_t kMaxEntries = 256;

 private:
  std::vector<std::string> mesh_roots_;
  std::size_t max_vertices_;
  PackageResolver resolve_package_;
  mutable std::mutex mutex_;
  std::map<std::tuple<std::string, double, double, double>, core::ConvexShape> cache_;
};

}  // namespace ros_layer
}  // namespace collision_monitor
