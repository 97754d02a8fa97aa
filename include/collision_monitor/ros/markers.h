/// \file
/// rviz markers for the monitor's view of the world (~markers, visualization_msgs/MarkerArray):
/// bodies drawn as their convex parts coloured by their worst pair status, witness segments,
/// distance labels and penetration normals. Built from the world model and the last cycle; the
/// builder remembers what it published so removed bodies and cleared pairs are deleted (the
/// DELETE is repeated in every array for a lifetime), and every marker has a lifetime: a
/// subscriber that missed the arrays with a DELETE (a slow link; the publisher's queue is 1)
/// drops the marker that long after the last array that showed it, and rviz drops the picture
/// of a monitor that stopped publishing.
///
/// Namespaces (one per kind, so each can be toggled in rviz):
///  - "bodies":  one marker per convex part: SPHERE (sphere, ellipsoid), CUBE (box), CYLINDER
///               (cylinder), TRIANGLE_LIST (hull triangles of polytopes and meshes; tessellated
///               capsules and cones). A body attached to a TF frame is drawn in that frame,
///               frame_locked, so rviz moves it with TF (MarkerOptions::frame_locked); a body posed
///               by a topic is drawn in the fixed frame at its pose.
///  - "padding": a translucent shell per part of a padded body (the part inflated by the padding).
///  - "witness": LINE_LIST segment between the witness points of a WARNING/COLLISION pair.
///  - "labels":  TEXT_VIEW_FACING with the signed distance in mm above the witness segment's
///               middle, stacked a line apart where labels of several pairs would meet.
///  - "normals": ARROW along the normal (from a towards b) of a penetrating pair, as long as the
///               penetration depth (at least MarkerOptions::min_arrow_length, so it stays visible).
/// The other markers are in the fixed frame. Markers are stamped with the cycle's stamp, the
/// frame-locked ones with 0 ("the latest TF": rviz would wait for TF at the cycle's stamp, which
/// a body whose TF stopped never gets). Geometry (hull triangles, tessellations) is computed once
/// per body shape and reused while the shape is unchanged. A body marker is sent again only when
/// its frame, pose, colour or geometry changed, or to refresh it, at a random time between a
/// quarter and a half of MarkerOptions::lifetime after it last went out; body markers live five
/// lifetimes (ten refreshes or more), the others one. A frame-locked robot standing or moving in
/// the clear costs the refreshes only (the PR2's 32 body markers are 273 kB; sent in every
/// array, 3.65 MB/s at 12.5 Hz). Triangle lists carry one colour
/// per face (the status colour shaded by a fixed light in the part frame): rviz draws uncoloured
/// triangle lists unlit and dark, so facets would be indistinguishable.
///
/// rviz re-creates every marker it receives, which costs far more than building them: build()
/// returns an empty array (callers skip publishing it) when called less than 1 / max_rate
/// seconds (wall clock) after its last non-empty result. Deletions are computed against what was
/// last published, and repeated for a lifetime (above).
#pragma once

#include <cstdint>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <ros/time.h>
#include <std_msgs/ColorRGBA.h>
#include <visualization_msgs/MarkerArray.h>

#include "collision_monitor/world/world_model.h"

namespace collision_monitor {
namespace ros_layer {

/// Look of the markers. Lengths in metres.
struct MarkerOptions {
  double body_alpha = 0.9;         ///< opacity of the bodies
  double padding_alpha = 0.25;     ///< opacity of the padding shells
  double line_width = 0.004;       ///< witness segment width
  double text_height = 0.03;       ///< label height
  double min_arrow_length = 0.03;  ///< normals shorter than this are drawn this long
  int tessellation = 12;           ///< directions per half turn for tessellated shapes (>= 4)
  double max_rate = 15.0;          ///< Hz: at most this many non-empty build()s per second; 0: all
  /// s: each marker's lifetime (0: forever), five times this for body and padding markers.
  /// Longer than the time between two arrays.
  double lifetime = 1.0;
  /// Bodies attached to TF frames drawn in those frames with frame_locked (rviz re-poses them
  /// with its latest TF); false: at the poses the check used, in the fixed frame.
  bool frame_locked = true;
};

class MarkerBuilder {
 public:
  explicit MarkerBuilder(const MarkerOptions& options = MarkerOptions()) : options_(options) {}

  /// Markers for `cycle` (stamped with cycle.stamp) in `fixed_frame`, including DELETE markers for
  /// everything published last time that no longer exists. The first call also starts with a
  /// DELETEALL so that markers of an earlier run of the node do not linger in an open rviz.
  visualization_msgs::MarkerArray build(const world::WorldModel& world,
                                        const world::CycleResult& cycle,
                                        const std::string& fixed_frame);
  /// The same at wall time `now` (s, steady clock), which paces the rate limit and refreshes.
  visualization_msgs::MarkerArray build(const world::WorldModel& world,
                                        const world::CycleResult& cycle,
                                        const std::string& fixed_frame, double now);

  /// Forgets what was shown (the next build() starts with a DELETEALL again).
  void reset();
  /// An array that removes every marker shown (one DELETEALL in `fixed_frame`), then reset().
  visualization_msgs::MarkerArray clear(const std::string& fixed_frame);
  /// New options (dynamic_reconfigure); the next build() sends every body marker by them.
  void setOptions(const MarkerOptions& options) {
    options_ = options;
    resendAll();
  }
  /// The next build() sends every body marker, changed or not (a new subscriber).
  void resendAll() { sent_.clear(); }

  /// Colour of a status: green clear, amber warning (ramped from yellow at `warning_distance`
  /// to orange at contact by `distance`, m), red collision, grey unknown/stale. Opaque.
  static std_msgs::ColorRGBA statusColor(world::PairStatus status, double distance,
                                         double warning_distance);
  /// Signed distance (m) as a label: "23.4 mm", "-4.0 mm" (penetration).
  static std::string distanceLabel(double distance);

  /// Number of markers currently shown (after the last build()).
  std::size_t numShown() const { return shown_.size(); }

 private:
  /// Drawable geometry of one part in the part's frame (everything but pose and colour).
  struct PartGeometry {
    visualization_msgs::Marker solid;
    core::Vec3 offset = core::Vec3::Zero();  ///< marker origin in the part frame (sphere centre)
    std::vector<float> solid_shade;          ///< per face of a TRIANGLE_LIST: light factor
    bool has_shell = false;
    visualization_msgs::Marker shell;
    std::vector<float> shell_shade;
  };
  /// Cached geometry of one body, valid while its parts' shapes and padding are unchanged.
  struct BodyGeometry {
    std::vector<world::Part> parts;  ///< copies (polytopes are shared, so this is cheap)
    double padding = 0.0;
    std::vector<PartGeometry> geometry;
    std::uint64_t generation = 0;  ///< new for every (re)built geometry
  };
  /// What a body marker was last sent with.
  struct Sent {
    std::string frame;
    geometry_msgs::Pose pose;
    std_msgs::ColorRGBA color;
    std::uint64_t generation = 0;
    double refresh_due = 0.0;  ///< steady clock, s
  };

  const BodyGeometry& geometryOf(const world::BodySpec& spec);
  int markerId(const std::string& ns, const std::string& key);

  MarkerOptions options_;
  std::map<std::string, BodyGeometry> geometry_;            ///< by body id
  std::map<std::pair<std::string, std::string>, int> ids_;  ///< (ns, key) -> marker id
  int next_id_ = 0;
  std::vector<int> free_ids_;  ///< ids whose DELETEs have stopped: taken before next_id_
  std::uint64_t next_generation_ = 1;
  bool first_ = true;
  double last_build_ = -1.0;  ///< steady clock (s) of the last non-empty build()
  /// (namespace, id) -> key of every marker currently shown, to delete what disappears.
  std::map<std::pair<std::string, int>, std::string> shown_;
  /// Body markers: (namespace, id) -> what they were last sent with.
  std::map<std::pair<std::string, int>, Sent> sent_;
  /// Deleted markers: (namespace, id) -> until when (steady clock, s) their DELETE is repeated.
  std::map<std::pair<std::string, int>, double> deleting_;
  std::minstd_rand random_;  ///< refresh times (fixed seed: the same sequence every run)
};

}  // namespace ros_layer
}  // namespace collision_monitor
