/// \file
/// Bounds-checked deserialization of the node's variable-size inputs.
///
/// roscpp's vector deserializer resizes (and zero-fills) a vector to the length prefix it reads
/// *before* it checks that the buffer holds that many elements: a 40-byte Body whose
/// `parts[0].dimensions` claims 2^31 entries allocates 16 GB before the stream is found short.
/// Strings are safe (`IStream::advance` checks the length before the copy), arrays are not.
///
/// The node therefore subscribes to (and serves) `Checked<M>`: the same message `M` on the wire
/// (same MD5, datatype and definition), whose deserializer first walks the raw bytes with a small
/// layout walker that checks every length prefix against the bytes that remain (times the
/// element's minimum serialized size, in 64-bit arithmetic). Only then does it deserialize
/// normally, so no allocation is larger than a small multiple of the message itself. A message
/// that fails the walk is not deserialized: `Checked<M>::refused` says why, and the callback
/// counts and logs it like any other refused input (roscpp never sees an exception).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include <collision_monitor/Body.h>
#include <collision_monitor/BodyPoses.h>
#include <collision_monitor/CheckCollision.h>
#include <ros/message_traits.h>
#include <ros/serialization.h>
#include <ros/service_traits.h>

namespace collision_monitor {
namespace ros_layer {

/// Minimum serialized sizes (bytes) of the elements of the checked arrays.
namespace wire {
constexpr std::uint64_t kString = 4;   ///< u32 length (+ bytes)
constexpr std::uint64_t kFloat64 = 8;  ///< float64
constexpr std::uint64_t kPoint = 24;   ///< geometry_msgs/Point, Vector3
constexpr std::uint64_t kPose = 56;    ///< geometry_msgs/Pose
constexpr std::uint64_t kTwist = 48;   ///< geometry_msgs/Twist
/// collision_monitor/Shape: type, dimensions[], vertices[], resource, scale, pose.
constexpr std::uint64_t kShape = 1 + 4 + 4 + 4 + kPoint + kPose;
}  // namespace wire

/// Layout walkers over a serialized message: true when every length prefix fits in the bytes
/// that remain and the buffer holds the whole message (trailing bytes are ignored, as roscpp
/// does); false with `why` (names the field, the claimed count and the bytes left) otherwise.
/// They never allocate more than `why`, and run in time linear in `size`.
bool checkBodyLayout(const std::uint8_t* data, std::size_t size, std::string* why);
bool checkBodyPosesLayout(const std::uint8_t* data, std::size_t size, std::string* why);
bool checkCheckCollisionRequestLayout(const std::uint8_t* data, std::size_t size, std::string* why);

/// Which walker checks a message type (specialised below for the node's inputs).
template <class M>
struct LayoutCheck;

template <>
struct LayoutCheck<collision_monitor::Body> {
  static bool check(const std::uint8_t* d, std::size_t n, std::string* why) {
    return checkBodyLayout(d, n, why);
  }
};
template <>
struct LayoutCheck<collision_monitor::BodyPoses> {
  static bool check(const std::uint8_t* d, std::size_t n, std::string* why) {
    return checkBodyPosesLayout(d, n, why);
  }
};
template <>
struct LayoutCheck<collision_monitor::CheckCollisionRequest> {
  static bool check(const std::uint8_t* d, std::size_t n, std::string* why) {
    return checkCheckCollisionRequestLayout(d, n, why);
  }
};

/// Message `M` deserialized only after its layout was checked. When the check fails, the `M` part
/// stays default-constructed and `refused` holds the reason (with the message size).
template <class M>
struct Checked : public M {
  std::string refused;  ///< empty: deserialized normally
  std::size_t wire_size = 0;
};

}  // namespace ros_layer
}  // namespace collision_monitor

// Checked<M> is M on the wire: every trait forwards to M's.
namespace ros {
namespace message_traits {
template <class M>
struct IsMessage<collision_monitor::ros_layer::Checked<M>> : IsMessage<M> {};
template <class M>
struct IsMessage<const collision_monitor::ros_layer::Checked<M>> : IsMessage<M> {};
template <class M>
struct HasHeader<collision_monitor::ros_layer::Checked<M>> : HasHeader<M> {};
template <class M>
struct HasHeader<const collision_monitor::ros_layer::Checked<M>> : HasHeader<M> {};
template <class M>
struct MD5Sum<collision_monitor::ros_layer::Checked<M>> {
  static const char* value() { return MD5Sum<M>::value(); }
  static const char* value(const collision_monitor::ros_layer::Checked<M>&) { return value(); }
};
template <class M>
struct DataType<collision_monitor::ros_layer::Checked<M>> {
  static const char* value() { return DataType<M>::value(); }
  static const char* value(const collision_monitor::ros_layer::Checked<M>&) { return value(); }
};
template <class M>
struct Definition<collision_monitor::ros_layer::Checked<M>> {
  static const char* value() { return Definition<M>::value(); }
  static const char* value(const collision_monitor::ros_layer::Checked<M>&) { return value(); }
};
}  // namespace message_traits

namespace service_traits {
template <class M>
struct MD5Sum<collision_monitor::ros_layer::Checked<M>> {
  static const char* value() { return MD5Sum<M>::value(); }
  static const char* value(const collision_monitor::ros_layer::Checked<M>&) { return value(); }
};
template <class M>
struct DataType<collision_monitor::ros_layer::Checked<M>> {
  static const char* value() { return DataType<M>::value(); }
  static const char* value(const collision_monitor::ros_layer::Checked<M>&) { return value(); }
};
}  // namespace service_traits

namespace serialization {
template <class M>
struct Serializer<collision_monitor::ros_layer::Checked<M>> {
  using Wrapped = collision_monitor::ros_layer::Checked<M>;

  template <typename Stream>
  inline static void write(Stream& stream, const Wrapped& m) {
    Serializer<M>::write(stream, static_cast<const M&>(m));
  }

  template <typename Stream>
  inline static void read(Stream& stream, Wrapped& m) {
    const std::size_t size = stream.getLength();
    m.wire_size = size;
    std::string why;
    if (!collision_monitor::ros_layer::LayoutCheck<M>::check(stream.getData(), size, &why)) {
      m.refused = std::move(why);
      return;
    }
    Serializer<M>::read(stream, static_cast<M&>(m));
  }

  inline static uint32_t serializedLength(const Wrapped& m) {
    return Serializer<M>::serializedLength(static_cast<const M&>(m));
  }
};
}  // namespace serialization
}  // namespace ros
