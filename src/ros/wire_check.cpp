#include "collision_monitor/ros/wire_check.h"

#include <cstring>

namespace collision_monitor {
namespace ros_layer {

namespace {

/// Walks a serialized message: reads length prefixes and skips fields, never past the end. Field
/// names are built only on failure ("body.parts[3].dimensions"), so a valid walk allocates
/// nothing.
class Walker {
 public:
  Walker(const std::uint8_t* data, std::size_t size, std::string* why)
      : pos_(data), end_(data + size), size_(size), why_(why) {}

  /// Skips `n` bytes of field `what`.
  bool skip(std::uint64_t n, const char* what) {
    if (n > left()) {
      return fail(what,
                  "needs " + std::to_string(n) + " bytes, " + std::to_string(left()) + " left");
    }
    pos_ += n;
    return true;
  }

  /// Reads a u32 length prefix of `what` and checks that `count * min_element` bytes remain.
  bool count(const char* what, std::uint64_t min_element, std::uint32_t* n) {
    if (left() < 4) return fail(what, "length prefix cut short");
    std::uint32_t v = 0;
    std::memcpy(&v, pos_, 4);  // little-endian on every ROS platform, as roscpp assumes
    pos_ += 4;
    const std::uint64_t need = static_cast<std::uint64_t>(v) * min_element;
    if (need > left()) {
      return fail(what, "claims " + std::to_string(v) + " entries (at least " +
                            std::to_string(need) + " bytes), " + std::to_string(left()) +
                            " bytes left");
    }
    *n = v;
    return true;
  }

  bool string(const char* what) {
    std::uint32_t n = 0;
    return count(what, 1, &n) && skip(n, what);
  }

  /// An array of fixed-size elements.
  bool fixedArray(const char* what, std::uint64_t element) {
    std::uint32_t n = 0;
    return count(what, element, &n) && skip(static_cast<std::uint64_t>(n) * element, what);
  }

  bool stringArray(const char* what) {
    std::uint32_t n = 0;
    if (!count(what, wire::kString, &n)) return false;
    for (item_ = 0; item_ < n; ++item_) {
      if (!string(what)) return false;
    }
    item_ = -1;
    return true;
  }

  bool header() { return skip(12, "header") && string("header.frame_id"); }

  bool shape() {
    return skip(1, "type") && fixedArray("dimensions", wire::kFloat64) &&
           fixedArray("vertices", wire::kPoint) && string("resource") &&
           skip(wire::kPoint + wire::kPose, "scale/pose");
  }

  bool body() {
    if (!header() || !string("id") || !skip(1, "operation") || !string("group")) return false;
    std::uint32_t parts = 0;
    if (!count("parts", wire::kShape, &parts)) return false;
    for (part_ = 0; part_ < parts; ++part_) {
      if (!shape()) return false;
    }
    part_ = -1;
    return skip(8 + 1, "padding/pose_from_topic") && string("pose_topic");
  }

  bool bodyPoses() {
    return header() && stringArray("ids") && fixedArray("poses", wire::kPose) &&
           fixedArray("twists", wire::kTwist);
  }

  void setPrefix(const char* prefix) { prefix_ = prefix; }

 private:
  std::uint64_t left() const { return static_cast<std::uint64_t>(end_ - pos_); }
  bool fail(const char* field, const std::string& what) {
    if (why_) {
      std::string name = prefix_;
      if (part_ >= 0) name += "parts[" + std::to_string(part_) + "].";
      name += field;
      if (item_ >= 0) name += "[" + std::to_string(item_) + "]";
      *why_ = "malformed message (" + std::to_string(size_) + " bytes): " + name + " " + what;
    }
    return false;
  }

  const std::uint8_t* pos_;
  const std::uint8_t* end_;
  std::size_t size_;
  std::string* why_;
  const char* prefix_ = "";
  std::int64_t part_ = -1;  ///< index of the Shape being walked, or -1
  std::int64_t item_ = -1;  ///< index in a string array, or -1
};

}  // namespace

bool checkBodyLayout(const std::uint8_t* data, std::size_t size, std::string* why) {
  return Walker(data, size, why).body();
}

bool checkBodyPosesLayout(const std::uint8_t* data, std::size_t size, std::string* why) {
  return Walker(data, size, why).bodyPoses();
}

bool checkCheckCollisionRequestLayout(const std::uint8_t* data, std::size_t size,
                                      std::string* why) {
  Walker w(data, size, why);
  w.setPrefix("body.");
  if (!w.body()) return false;
  w.setPrefix("");
  return w.skip(wire::kPose + wire::kFloat64, "pose/margin");
}

}  // namespace ros_layer
}  // namespace collision_monitor
