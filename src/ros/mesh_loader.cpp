#include "collision_monitor/ros/mesh_loader.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <memory>
#include <numeric>

#include <geometric_shapes/mesh_operations.h>
#include <geometric_shapes/shapes.h>
#include <ros/console.h>
#include <ros/package.h>
#include <tinyxml2.h>

#include "collision_monitor/core/shapes.h"
#include "collision_monitor/ros/conversions.h"

namespace collision_monitor {
namespace ros_layer {

namespace {

bool startsWith(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

/// The path of a URI as resource_retriever (libcurl) reads it, which rviz shows: %XX decoded
/// (a '%' not followed by two hex digits stays); a query or fragment ('?', '#') is refused, as
/// curl cut the path there (a mesh "hash#1.stl" loaded the file "hash"), and so is a NUL.
Expected<std::string> uriPath(const std::string& encoded) {
  if (encoded.find_first_of("?#") != std::string::npos) {
    return Error{
        "a URI with a query or fragment ('?' or '#') names no mesh file; percent-encode "
        "them in a file name (%3F, %23)"};
  }
  const auto hex = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  std::string out;
  out.reserve(encoded.size());
  for (std::size_t i = 0; i < encoded.size(); ++i) {
    if (encoded[i] == '%' && i + 2 < encoded.size() && hex(encoded[i + 1]) >= 0 &&
        hex(encoded[i + 2]) >= 0) {
      out.push_back(static_cast<char>(16 * hex(encoded[i + 1]) + hex(encoded[i + 2])));
      i += 2;
    } else {
      out.push_back(encoded[i]);
    }
  }
  if (out.find('\0') != std::string::npos) return Error{"the URI's path holds a NUL (%00)"};
  return out;
}

/// strerror(3)'s text of `err`, thread-safe (GNU strerror_r): meshes load on the ~bodies thread
/// while others run, and strerror's static buffer is shared with them.
std::string errnoText(int err) {
  char buf[256];
  return ::strerror_r(err, buf, sizeof(buf));
}

/// realpath(3) as a string; empty with `why` set on failure.
std::string canonical(const std::string& path, std::string* why) {
  char buf[PATH_MAX];
  if (::realpath(path.c_str(), buf) == nullptr) {
    if (why) *why = errnoText(errno);
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

/// The pieces of a mesh (vertices `points`, `triangles`) for MeshDecomposition::Pieces; empty,
/// for one hull, when it is one piece or is not split (`note` then says why).
/// `triangle_count`: the mesh's; beyond kMaxTrianglesPerVertex x `max_vertices`, `triangles` is
/// empty (not kept).
std::vector<std::vector<core::Vec3>> splitMesh(
    const std::vector<core::Vec3>& points, const std::vector<std::array<std::size_t, 3>>& triangles,
    std::size_t triangle_count, std::size_t max_vertices, std::size_t max_parts,
    std::string* note) {
  if (triangle_count > kMaxTrianglesPerVertex * max_vertices) {
    // A closed mesh has about two triangles per vertex; this bounds the edge list and its sort.
    *note = "not split into pieces: " + std::to_string(triangle_count) + " triangles, more than " +
            std::to_string(kMaxTrianglesPerVertex) + " x max_vertices_per_part; one convex hull";
    return {};
  }
  MeshPieces split = meshPieces(points, triangles);
  // One piece is its hull either way, closed or not (many collision meshes are open).
  if (split.pieces.size() == 1) return {};
  if (!split.open.empty()) {
    *note = "not split into pieces: " + split.open + "; one convex hull";
    return {};
  }
  if (split.pieces.size() > max_parts) {
    // Decided before hulling them; the body keeps the geometry `hull` would give it.
    *note = "not split into pieces: " + std::to_string(split.pieces.size()) +
            " pieces, more than max_parts_per_body " + std::to_string(max_parts) +
            "; one convex hull";
    return {};
  }
  return std::move(split.pieces);
}

/// A COLLADA file's `<asset><unit meter="...">`: metres per unit of its coordinates (1 when
/// absent or when the file is not XML, which assimp then judges). assimp puts it in the scene's
/// root transform, which geometric_shapes drops: a mesh in centimetres came out 100 times too
/// large. rviz applies it (getMeshUnitRescale), and so does this.
Expected<double> colladaUnit(const std::string& bytes, const std::string& path) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(bytes.data(), bytes.size()) != tinyxml2::XML_SUCCESS) return 1.0;
  const tinyxml2::XMLElement* e = doc.FirstChildElement("COLLADA");
  if (e) e = e->FirstChildElement("asset");
  if (e) e = e->FirstChildElement("unit");
  const char* meter = e ? e->Attribute("meter") : nullptr;
  if (meter == nullptr) return 1.0;
  double unit = 0.0;
  if (e->QueryDoubleAttribute("meter", &unit) != tinyxml2::XML_SUCCESS || !std::isfinite(unit) ||
      !(unit > 0.0)) {
    return Error{path + ": COLLADA <unit meter=" + quoteInput(meter) +
                 "> is not a number of metres > 0"};
  }
  return unit;
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
    // The package name as resource_retriever takes it (not decoded); the path after it decoded.
    const std::string raw = uri.substr(std::strlen("package://"));
    const auto raw_slash = raw.find('/');
    if (raw_slash == std::string::npos || raw_slash == 0) {
      return Error{"malformed package URI (want package://<package>/<path>)"};
    }
    auto decoded = uriPath(raw.substr(raw_slash));
    if (!decoded) return Error{decoded.error()};
    const std::string rest = raw.substr(0, raw_slash) + *decoded;
    const auto slash = raw_slash;
    if (slash + 1 >= rest.size()) {
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
    auto decoded = uriPath(uri.substr(std::strlen("file://")));
    if (!decoded) return Error{decoded.error()};
    path = *decoded;
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

std::optional<MeshDecomposition> parseMeshDecomposition(const std::string& name) {
  if (name == "hull") return MeshDecomposition::Hull;
  if (name == "pieces") return MeshDecomposition::Pieces;
  return std::nullopt;
}

const char* toString(MeshDecomposition mode) {
  return mode == MeshDecomposition::Pieces ? "pieces" : "hull";
}

MeshPieces meshPieces(const std::vector<core::Vec3>& vertices,
                      const std::vector<std::array<std::size_t, 3>>& triangles) {
  MeshPieces out;
  const std::size_t n = vertices.size();
  // Weld: one id per distinct position, by sorting.
  const auto less = [&vertices](std::size_t i, std::size_t j) {
    const core::Vec3& a = vertices[i];
    const core::Vec3& b = vertices[j];
    return a.x() != b.x() ? a.x() < b.x() : (a.y() != b.y() ? a.y() < b.y() : a.z() < b.z());
  };
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), less);
  std::vector<std::size_t> weld(n);
  std::size_t distinct = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (k > 0 && less(order[k - 1], order[k])) ++distinct;
    weld[order[k]] = distinct;
  }
  if (n > 0) ++distinct;

  std::vector<std::size_t> parent(distinct);
  std::iota(parent.begin(), parent.end(), std::size_t{0});
  const auto root = [&parent](std::size_t v) {
    while (parent[v] != v)
      v = parent[v] = parent[parent[v]];
    return v;
  };
  std::vector<bool> used(distinct, false);
  std::vector<std::pair<std::size_t, std::size_t>> edges;
  edges.reserve(3 * triangles.size());
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    std::array<std::size_t, 3> w{};
    for (int k = 0; k < 3; ++k) {
      if (triangles[t][k] >= n) {
        out.open = "triangle " + std::to_string(t) + " has a vertex index out of range";
        return out;
      }
      w[k] = weld[triangles[t][k]];
      used[w[k]] = true;
    }
    parent[root(w[1])] = root(w[0]);
    parent[root(w[2])] = root(w[0]);
    for (int k = 0; k < 3; ++k) {
      const std::size_t u = w[k], v = w[(k + 1) % 3];
      if (u != v) edges.emplace_back(std::min(u, v), std::max(u, v));
    }
  }

  // Pieces numbered by their first triangle.
  std::vector<std::size_t> piece_of(distinct, SIZE_MAX);
  for (const auto& tri : triangles) {
    const std::size_t r = root(weld[tri[0]]);
    if (piece_of[r] == SIZE_MAX) {
      piece_of[r] = out.pieces.size();
      out.pieces.emplace_back();
    }
  }
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t v = weld[order[k]];
    if (k > 0 && v == weld[order[k - 1]]) continue;  // a repeated position
    if (!used[v]) {
      if (out.open.empty()) out.open = "vertex " + std::to_string(order[k]) + " is on no triangle";
    } else {
      out.pieces[piece_of[root(v)]].push_back(vertices[order[k]]);
    }
  }
  if (!out.open.empty()) return out;

  // Closed: every edge on an even number of triangles (no boundary).
  std::sort(edges.begin(), edges.end());
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i])
      ++j;
    if ((j - i) % 2 != 0) {
      out.open = "piece " + std::to_string(piece_of[root(edges[i].first)] + 1) + " of " +
                 std::to_string(out.pieces.size()) + " is not closed (an edge on " +
                 std::to_string(j - i) + (j - i == 1 ? " triangle)" : " triangles)");
      return out;
    }
    i = j;
  }
  return out;
}

Expected<MeshParts> loadMeshParts(const std::string& path, const core::Vec3& scale,
                                  std::size_t max_vertices, MeshDecomposition mode,
                                  std::size_t max_parts) {
  try {
    // Read here, from the path that was checked: resource_retriever (libcurl) decoded %XX and
    // cut at '#' and '?' again, and loaded another file than the one checked.
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) return Error{"cannot open " + path + ": " + errnoText(errno)};
    const std::streamoff size = in.tellg();
    if (size <= 0) return Error{path + " is empty"};
    if (static_cast<std::uint64_t>(size) > kMaxMeshFileBytes) {
      return Error{path + " is " + std::to_string(size) + " bytes, more than " +
                   std::to_string(kMaxMeshFileBytes >> 20) + " MiB"};
    }
    std::string bytes(static_cast<std::size_t>(size), '\0');
    in.seekg(0);
    if (!in.read(bytes.data(), size)) return Error{"cannot read " + path};
    // assimp's format hint, as geometric_shapes' createMeshFromResource gives it.
    std::string hint;
    if (const auto dot = path.find_last_of('.'); dot != std::string::npos) {
      hint = path.substr(dot + 1);
      std::transform(hint.begin(), hint.end(), hint.begin(),
                     [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      if (hint.find("stl") != std::string::npos) hint = "stl";
    }
    auto unit = hint == "dae" ? colladaUnit(bytes, path) : Expected<double>(1.0);
    if (!unit) return Error{unit.error()};
    const core::Vec3 s = *unit * scale;
    std::unique_ptr<shapes::Mesh> mesh(shapes::createMeshFromBinary(
        bytes.data(), bytes.size(), Eigen::Vector3d(s.x(), s.y(), s.z()), hint));
    if (!mesh) {
      return Error{"cannot load " + path +
                   " (not a readable STL/DAE/OBJ mesh, or one without triangles)"};
    }
    if (mesh->vertex_count == 0) return Error{path + " has no vertices"};
    // Checked before hulling: a huge mesh inside mesh_roots is refused without the hull's cost.
    if (mesh->vertex_count > max_vertices) {
      return Error{path + " has " + std::to_string(mesh->vertex_count) +
                   " vertices, more than max_vertices_per_part " + std::to_string(max_vertices)};
    }
    // The vertices on triangles only: others (an OBJ's lines and points, unused vertices) are
    // not the surface rviz draws; they stretched the hull (an OBJ line 2 m away, by 0.34 m).
    // Triangles are kept for splitting only, and not beyond what splitMesh() takes.
    const bool keep_triangles = mode == MeshDecomposition::Pieces &&
                                mesh->triangle_count <= kMaxTrianglesPerVertex * max_vertices;
    std::vector<std::size_t> index(mesh->vertex_count, SIZE_MAX);
    std::vector<core::Vec3> points;
    std::vector<std::array<std::size_t, 3>> triangles(keep_triangles ? mesh->triangle_count : 0);
    for (unsigned t = 0; t < mesh->triangle_count; ++t) {
      for (int k = 0; k < 3; ++k) {
        const unsigned v = mesh->triangles[3 * t + k];
        if (v >= mesh->vertex_count) {
          return Error{path + ": triangle " + std::to_string(t) + " has a vertex out of range"};
        }
        if (index[v] == SIZE_MAX) {
          const core::Vec3 p(mesh->vertices[3 * v], mesh->vertices[3 * v + 1],
                             mesh->vertices[3 * v + 2]);
          if (!p.allFinite())
            return Error{path + ": vertex " + std::to_string(v) + " is not finite"};
          index[v] = points.size();
          points.push_back(p);
        }
        if (keep_triangles) triangles[t][k] = index[v];
      }
    }
    if (allCoincide(points)) return Error{"degenerate mesh " + path + ": every vertex coincides"};

    MeshParts out;
    std::vector<std::vector<core::Vec3>> pieces;
    if (mode == MeshDecomposition::Pieces) {
      pieces =
          splitMesh(points, triangles, mesh->triangle_count, max_vertices, max_parts, &out.note);
    }
    if (pieces.empty()) pieces.push_back(std::move(points));
    for (std::size_t i = 0; i < pieces.size(); ++i) {
      core::ConvexShape hull = core::ConvexShape::convexHull(pieces[i]);
      const auto* poly = std::get_if<std::shared_ptr<const core::Polytope<3>>>(&hull.core());
      if (poly && *poly && static_cast<std::size_t>((*poly)->size()) > max_vertices) {
        return Error{"convex hull of " + path +
                     (pieces.size() > 1 ? " (piece " + std::to_string(i + 1) + ")" : "") + " has " +
                     std::to_string((*poly)->size()) +
                     " vertices, more than max_vertices_per_part " + std::to_string(max_vertices)};
      }
      out.parts.push_back(std::move(hull));
    }
    return out;
  } catch (const std::exception& e) {
    return Error{"cannot load " + path + ": " + e.what()};
  }
}

MeshCache::MeshCache(std::vector<std::string> mesh_roots, std::size_t max_vertices,
                     PackageResolver resolve_package, MeshDecomposition mode, std::size_t max_parts,
                     std::string log_name)
    : mesh_roots_(std::move(mesh_roots)),
      max_vertices_(max_vertices),
      resolve_package_([this, resolve = std::move(resolve_package)](const std::string& package) {
        {
          std::lock_guard<std::mutex> lock(mutex_);
          if (missing_packages_.count(package)) return std::string();
        }
        std::string dir = resolve ? resolve(package) : std::string();
        if (dir.empty()) {
          std::lock_guard<std::mutex> lock(mutex_);
          if (missing_packages_.size() < kMaxEntries) missing_packages_.insert(package);
        }
        return dir;
      }),
      mode_(mode),
      max_parts_(max_parts),
      log_name_(std::move(log_name)) {}

Expected<std::vector<core::ConvexShape>> MeshCache::load(const std::string& uri,
                                                         const core::Vec3& scale) {
  auto path = resolveMeshUri(uri, mesh_roots_, resolve_package_);
  if (!path) return Error{path.error()};
  const auto key = std::make_tuple(*path, scale.x(), scale.y(), scale.z());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = cache_.find(key);
    if (it != cache_.end()) return it->second;
  }
  auto loaded = loadMeshParts(*path, scale, max_vertices_, mode_, max_parts_);
  if (!loaded) return Error{loaded.error()};
  if (!loaded->note.empty()) {
    ROS_WARN_STREAM((log_name_.empty() ? "" : log_name_ + ": ")
                    << "mesh " << *path << ": " << loaded->note);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (cache_.size() >= kMaxEntries) cache_.clear();
  cache_.emplace(key, loaded->parts);
  return std::move(loaded->parts);
}

std::size_t MeshCache::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return cache_.size();
}

}  // namespace ros_layer
}  // namespace collision_monitor
