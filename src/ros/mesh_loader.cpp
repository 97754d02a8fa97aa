#include "collision_monitor/ros/mesh_loader.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>

#include <geometric_shapes/mesh_operations.h>
#include <geometric_shapes/shapes.h>
#include <ros/package.h>

#include "collision_monitor/core/shapes.h"
#include "collision_monitor/ros/conversions.h"

namespace collision_monitor {
namespace ros_layer {

namespace {

bool startsWith(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

/// realpath(3) as a string; empty with `why` set on failure.
std::string canonical(const std::string& path, std::string* why) {
  char buf[PATH_MAX];
  if (::realpath(path.c_str(), buf) == nullptr) {
    if (why) *why = std::strerror(errno);
    return {};
  }
  return buf;
}

/// Paths are quoted longer than other input (they are checked against PATH_MAX first).
constexpr std::size_t kPathQuote = 512;

/// True when canonical `path` lies inside canonical directory `dir`.
bool inside(const std::string& path, const std::string& dir) {
  if (dir.empty()) return false;
  if (dir == "/") return true;
  // The directory itself counts as inside: it is then refused as "not a regular file".
  return startsWith(path, dir) && (path.size() == dir.size() || path[dir.size()] == '/');
}

}  // namespace

std::string rosPackagePath(const std::string& package) {
  return ros::package::getPath(package);
}

Expected<std::string> resolveMeshUri(const std::string& uri,
                                     const std::vector<std::string>& mesh_roots,
                                     const PackageResolver& resolve_package) {
  std::string path;
  std::string package_dir;
  if (startsWith(uri, "package://")) {
    const std::string rest = uri.substr(std::strlen("package://"));
    const auto slash = rest.find('/');
    if (slash == std::string::npos || slash == 0 || slash + 1 == rest.size()) {
      return Error{"malformed package URI (want package://<package>/<path>)"};
    }
    const std::string package = rest.substr(0, slash);
    const std::string dir = resolve_package ? resolve_package(package) : std::string();
    if (dir.empty())
      return Error{"unknown package " + quoteInput(package) + " (not on ROS_PACKAGE_PATH)"};
    std::string why;
    package_dir = canonical(dir, &why);
    if (package_dir.empty()) return Error{"package directory " + dir + ": " + why};
    path = dir + "/" + rest.substr(slash + 1);
  } else if (startsWith(uri, "file://")) {
    path = uri.substr(std::strlen("file://"));
    if (startsWith(path, "localhost/")) path = path.substr(std::strlen("localhost"));
    if (path.empty() || path[0] != '/') return Error{"file:// URI needs an absolute path"};
  } else {
    return Error{"unsupported URI scheme (use package:// or file://)"};
  }

  std::string why;
  const std::string real = canonical(path, &why);
  if (real.empty()) return Error{"cannot resolve " + quoteInput(path, kPathQuote) + ": " + why};

  bool allowed = inside(real, package_dir);
  for (const std::string& root : mesh_roots) {
    if (allowed) break;
    const std::string real_root = canonical(root, nullptr);
    allowed = inside(real, real_root);
  }
  if (!allowed) {
    if (package_dir.empty()) {
      return Error{real + " is outside mesh_roots" +
                   std::string(mesh_roots.empty() ? " (none configured)" : "")};
    }
    return Error{real + " is outside its package " + package_dir + " and outside mesh_roots"};
  }
  struct stat st {};
  if (::stat(real.c_str(), &st) != 0) return Error{"cannot stat " + real};
  if (!S_ISREG(st.st_mode)) return Error{real + " is not a regular file"};
  if (::access(real.c_str(), R_OK) != 0) return Error{real + " is not readable"};
  return real;
}

Expected<core::ConvexShape> loadMeshHull(const std::string& path, const core::Vec3& scale,
                                         std::size_t max_vertices) {
  try {
    std::unique_ptr<shapes::Mesh> mesh(shapes::createMeshFromResource(
        "file://" + path, Eigen::Vector3d(scale.x(), scale.y(), scale.z())));
    if (!mesh) return Error{"cannot load " + path + " (not a readable STL/DAE/OBJ mesh)"};
    if (mesh->vertex_count == 0) return Error{path + " has no vertices"};
    // Checked before hulling: a huge mesh inside mesh_roots is refused without the hull's cost.
    if (mesh->vertex_count > max_vertices) {
      return Error{path + " has " + std::to_string(mesh->vertex_count) +
                   " vertices, more than max_vertices_per_part " + std::to_string(max_vertices)};
    }
    std::vector<core::Vec3> points;
    points.reserve(mesh->vertex_count);
    for (unsigned i = 0; i < mesh->vertex_count; ++i) {
      const core::Vec3 p(mesh->vertices[3 * i], mesh->vertices[3 * i + 1],
                         mesh->vertices[3 * i + 2]);
      if (!p.allFinite()) return Error{path + ": vertex " + std::to_string(i) + " is not finite"};
      points.push_back(p);
    }
    double spread = 0.0;  // as for CONVEX parts: a point is no mesh
    for (const core::Vec3& p : points)
      spread = std::max(spread, (p - points.front()).norm());
    if (!(spread > 0.0)) return Error{"degenerate mesh " + path + ": every vertex coincides"};
    core::ConvexShape hull = core::ConvexShape::convexHull(points);
    if (const auto* poly = std::get_if<std::shared_ptr<const core::Polytope<3>>>(&hull.core())) {
      if (*poly && static_cast<std::size_t>((*poly)->size()) > max_vertices) {
        return Error{"convex hull of " + path + " has " + std::to_string((*poly)->size()) +
                     " vertices, more than max_vertices_per_part " + std::to_string(max_vertices)};
      }
    }
    return hull;
  } catch (const std::exception& e) {
    return Error{"cannot load " + path + ": " + e.what()};
  }
}

MeshCache::MeshCache(std::vector<std::string> mesh_roots, std::size_t max_vertices,
                     PackageResolver resolve_package)
    : mesh_roots_(std::move(mesh_roots)),
      max_vertices_(max_vertices),
      resolve_package_(std::move(resolve_package)) {}

Expected<core::ConvexShape> MeshCache::load(const std::string& uri, const core::Vec3& scale) {
  auto path = resolveMeshUri(uri, mesh_roots_, resolve_package_);
  if (!path) return Error{path.error()};
  const auto key = std::make_tuple(*path, scale.x(), scale.y(), scale.z());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = cache_.find(key);
    if (it != cache_.end()) return it->second;
  }
  auto hull = loadMeshHull(*path, scale, max_vertices_);
  if (!hull) return hull;
  std::lock_guard<std::mutex> lock(mutex_);
  if (cache_.size() >= kMaxEntries) cache_.clear();
  cache_.emplace(key, *hull);
  return hull;
}

std::size_t MeshCache::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return cache_.size();
}

}  // namespace ros_layer
}  // namespace collision_monitor
