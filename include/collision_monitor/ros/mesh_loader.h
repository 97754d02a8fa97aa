/// \file
/// Mesh parts: where a mesh URI may point, and loading it as a convex hull (or one per piece).
///
/// A MESH resource is resolved to a canonical path (realpath: symlinks and `..` resolved) before
/// anything is read, and refused unless that path is a regular file inside
///  - a directory of `mesh_roots` (file:// and package:// URIs), or
///  - the package's own directory (package:// URIs only).
/// So `file:///etc/passwd`, `package://pkg/../../etc/passwd` and a symlink inside a mesh root
/// that points outside it are all refused. The URI's path is percent-decoded first, as libcurl
/// (resource_retriever, rviz) reads it, and a query or fragment ('?', '#') is refused. The mesh is
/// then read from the canonical path by the node itself (not through resource_retriever, which
/// decoded the path again), so what is loaded is what was checked.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <set>
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

/// How a MESH part becomes convex parts (parameter `mesh_decomposition`).
enum class MeshDecomposition {
  Hull,    ///< "hull": the convex hull of all its vertices (the default)
  Pieces,  ///< "pieces": one hull per closed connected piece (meshPieces()); else the whole hull
};
/// "hull" / "pieces" -> the mode; nullopt for anything else.
std::optional<MeshDecomposition> parseMeshDecomposition(const std::string& name);
const char* toString(MeshDecomposition mode);

/// A triangle mesh's connected pieces: triangles that share a vertex position (compared exactly,
/// so an STL's repeated corners join) are one piece. `open` is empty when every piece is closed
/// (each of its edges is shared by an even number of its triangles, so it bounds a volume that
/// its hull contains) and every vertex is on a triangle; otherwise it says why not: the union of
/// the pieces' hulls would then not cover the body (a box of six unjoined faces is hollow).
/// Space that closed pieces only enclose between them (a box of six separate closed plates)
/// stays free: it is not inside any piece.
struct MeshPieces {
  std::vector<std::vector<core::Vec3>> pieces;  ///< vertex positions, pieces by first triangle
  std::string open;
};
MeshPieces meshPieces(const std::vector<core::Vec3>& vertices,
                      const std::vector<std::array<std::size_t, 3>>& triangles);

/// The largest mesh file read (bytes): assimp holds the file and its scene in memory at once.
constexpr std::uint64_t kMaxMeshFileBytes = std::uint64_t{256} << 20;

/// Triangles per allowed vertex beyond which a mesh is not split (a closed mesh has about 2).
constexpr std::size_t kMaxTrianglesPerVertex = 8;

/// A mesh file's convex parts.
struct MeshParts {
  std::vector<core::ConvexShape> parts;
  std::string note;  ///< why `Pieces` fell back to one hull; empty otherwise
};

/// Loads the mesh file at `path` (STL/DAE/OBJ via geometric_shapes/assimp; a COLLADA file's
/// `<unit meter>` applied, as rviz does), scaled (a negative factor mirrors), and returns the
/// convex hull of its triangles' vertices, or with `Pieces` one hull per piece; refused when the
/// mesh has more than `max_vertices` (distinct) vertices, checked right after loading and before
/// hulling, when a hull has more, or when it has no triangles. `Pieces` keeps the one hull, with a
/// note, when a piece is open, when there are more than `max_parts` pieces (checked before hulling
/// them), or more than kMaxTrianglesPerVertex x `max_vertices` triangles (checked before
/// splitting).
Expected<MeshParts> loadMeshParts(const std::string& path, const core::Vec3& scale,
                                  std::size_t max_vertices,
                                  MeshDecomposition mode = MeshDecomposition::Hull,
                                  std::size_t max_parts = SIZE_MAX);

/// resolveMeshUri + loadMeshParts with a cache of parts by (canonical path, scale): the PR2 uses
/// the same wheel mesh eight times. A fallback's note is logged (WARN, after `log_name`: the
/// monitor's name) when the mesh loads, not when it comes from the cache. Thread-safe (two
/// threads loading one mesh at once both load it).
class MeshCache {
 public:
  MeshCache(std::vector<std::string> mesh_roots, std::size_t max_vertices,
            PackageResolver resolve_package = rosPackagePath,
            MeshDecomposition mode = MeshDecomposition::Hull, std::size_t max_parts = SIZE_MAX,
            std::string log_name = "");
  Expected<std::vector<core::ConvexShape>> load(const std::string& uri, const core::Vec3& scale);
  /// Meshes kept (path, scale). Past kMaxEntries the cache starts again empty: a stream of bodies
  /// with ever new scales cannot grow it without bound (bodies keep their own hulls).
  std::size_t size() const;
  static constexpr std::size_t kMaxEntries = 256;

 private:
  std::vector<std::string> mesh_roots_;
  std::size_t max_vertices_;
  PackageResolver resolve_package_;
  MeshDecomposition mode_;
  std::size_t max_parts_;
  std::string log_name_;
  mutable std::mutex mutex_;
  std::map<std::tuple<std::string, double, double, double>, std::vector<core::ConvexShape>> cache_;
  /// Packages the resolver did not find (at most kMaxEntries), not asked again: rospack prints
  /// two lines on stderr for each such lookup (the PR2 with its mesh package missing: 31 pairs
  /// beside the node's own errors).
  std::set<std::string> missing_packages_;
};

}  // namespace ros_layer
}  // namespace collision_monitor
