/// \file
/// rviz markers for the monitor's view of the world (~markers, visualization_msgs/MarkerArray):
/// bodies drawn as their convex parts coloured by their worst pair status, witness segments,
/// distance labels and penetration normals. Built from the world model and the last cycle; the
/// builder remembers what it published so removed bodies and cleared pairs are deleted (no ghosts).
#pragma once

#include <set>
#include <string>
#include <utility>

#include <ros/time.h>
#include <visualization_msgs/MarkerArray.h>

#include "collision_monitor/world/world_model.h"

namespace collision_monitor {
namespace ros_layer {

class MarkerBuilder {
 public:
  /// Markers for `cycle` (stamped with cycle.stamp) in `fixed_frame`, including DELETE markers for
  /// everything published last time that no longer exists.
  visualization_msgs::MarkerArray build(const world::WorldModel& world,
                                        const world::CycleResult& cycle,
                                        const std::string& fixed_frame);

 private:
  /// (namespace, id) of every marker currently shown, to delete what disappears.
  std::set<std::pair<std::string, int>> shown_;
};

}  // namespace ros_layer
}  // namespace collision_monitor
