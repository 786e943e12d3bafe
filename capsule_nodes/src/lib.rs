//! ROS plumbing
