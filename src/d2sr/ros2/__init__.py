"""``d2sr ros2``: a ROS 2 node with no ROS install. It speaks DDS through Cyclone DDS's Python binding
(``pip install '.[ros2]'``) with ROS 2's names and types, so ``ros2 topic echo``, rviz and rosbag2 see it
as any other node: topic ``/a/b`` is DDS topic ``rt/a/b``, ``sensor_msgs/msg/Image`` is
``sensor_msgs::msg::dds_::Image_``. Torch-free."""

from d2sr.ros2.camera import Camera, Stats
from d2sr.ros2.node import Ros2Node, cameras_from
from d2sr.ros2.wire import Wire, dds_topic

__all__ = ["Camera", "Ros2Node", "Stats", "Wire", "cameras_from", "dds_topic"]
