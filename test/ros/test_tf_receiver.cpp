// TfReceiver's choice of the TF stamps a check looks a frame up at between two checks. No master.
#include <gtest/gtest.h>

#include <vector>

#include "collision_monitor/ros/tf_receiver.h"

namespace collision_monitor {
namespace ros_layer {
namespace {

std::vector<ros::Time> seconds(const std::vector<int>& s) {
  std::vector<ros::Time> out;
  for (int v : s)
    out.emplace_back(v, 0);
  return out;
}

TEST(TfReceiver, SpreadKeepsEveryStampWithinTheBound) {
  const auto ten = seconds({1, 2, 3, 4, 5, 6, 7, 8, 9, 10});
  EXPECT_EQ(TfReceiver::spread(ten, 10), ten);
  EXPECT_EQ(TfReceiver::spread(ten, 32), ten);
  EXPECT_EQ(TfReceiver::spread({}, 4), std::vector<ros::Time>());
}

TEST(TfReceiver, SpreadThinsEvenlyAndKeepsTheLast) {
  const auto ten = seconds({1, 2, 3, 4, 5, 6, 7, 8, 9, 10});
  // Picks n - 1 - floor(k n / most) for k = most - 1 .. 0: indices 2, 4, 7, 9.
  EXPECT_EQ(TfReceiver::spread(ten, 4), seconds({3, 5, 8, 10}));
  EXPECT_EQ(TfReceiver::spread(ten, 5), seconds({2, 4, 6, 8, 10}));
  EXPECT_EQ(TfReceiver::spread(ten, 9), seconds({2, 3, 4, 5, 6, 7, 8, 9, 10}));
  EXPECT_EQ(TfReceiver::spread(ten, 1), seconds({10}));
  EXPECT_EQ(TfReceiver::spread(ten, 0), std::vector<ros::Time>());
}

}  // namespace
}  // namespace ros_layer
}  // namespace collision_monitor
